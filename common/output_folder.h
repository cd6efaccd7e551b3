// The output folder of a run or replay. A new run never destroys an earlier one: a folder holding an earlier objscan
// output (session.lcmlog, replay.lcmlog, summary.json or processes.txt) is moved aside to DIR.1 (or the first free
// DIR.N) and a fresh DIR is made; a folder holding anything else is refused, never moved or written into.
#pragma once

#include <string>

namespace objscan {

// Makes `dir` ready for new output (created with its parents when missing). Returns false with *error when it cannot
// be made, is not a folder, or is a non-empty folder that is not an objscan output. *moved_to is set to the new
// name of an earlier output that was moved aside, else cleared.
bool PrepareOutputFolder(const std::string& dir, std::string* moved_to, std::string* error);

}  // namespace objscan

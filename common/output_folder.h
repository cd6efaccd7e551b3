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

// Marks a result file as partial (a run interrupted or one that lost a process: the survivors wrote what they had),
// in the file itself: a PLY gets "comment partial: REASON" after its format line, a text file whose first line is a
// '#' comment (TUM trajectories) gets "# partial: REASON" after that line. Other files are left alone (false, *error
// says why); so is a file already marked. The file is rewritten through a temporary file and a rename. REASON is one
// line (newlines become spaces).
bool MarkResultFilePartial(const std::string& path, const std::string& reason, std::string* error);

}  // namespace objscan

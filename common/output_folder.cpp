#include "common/output_folder.h"

#include <filesystem>
#include <system_error>

namespace objscan {
namespace fs = std::filesystem;

bool PrepareOutputFolder(const std::string& dir, std::string* moved_to, std::string* error) {
  moved_to->clear();
  std::error_code ec;
  const fs::path path(dir);
  if (!fs::exists(path, ec)) {
    fs::create_directories(path, ec);
    if (ec) *error = "cannot create output folder " + dir + ": " + ec.message();
    return !ec;
  }
  if (!fs::is_directory(path, ec)) {
    *error = "output folder " + dir + " exists and is not a folder";
    return false;
  }
  if (fs::is_empty(path, ec)) return true;
  bool earlier_output = false;
  for (const char* name : {"session.lcmlog", "replay.lcmlog", "summary.json", "processes.txt"})
    earlier_output = earlier_output || fs::exists(path / name, ec);
  if (!earlier_output) {
    *error = "output folder " + dir +
             " holds files that are not an objscan output; give a new or empty folder (nothing was written)";
    return false;
  }
  // DIR/ and DIR name the same folder: its aside name is built from the path without trailing separators.
  std::string base = path.string();
  while (base.size() > 1 && base.back() == '/') base.pop_back();
  for (int n = 1; n < 10000; ++n) {
    const fs::path aside(base + "." + std::to_string(n));
    if (fs::exists(aside, ec)) continue;
    fs::rename(path, aside, ec);
    if (ec) {
      *error = "cannot move the earlier output in " + dir + " aside to " + aside.string() + ": " + ec.message();
      return false;
    }
    *moved_to = aside.string();
    fs::create_directories(path, ec);
    if (ec) *error = "cannot create output folder " + dir + ": " + ec.message();
    return !ec;
  }
  *error = "output folder " + dir + ": no free name to move the earlier output to (" + base + ".1 .. .9999 exist)";
  return false;
}

}  // namespace objscan

#include "common/output_folder.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
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

bool MarkResultFilePartial(const std::string& path, const std::string& reason, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = "cannot read " + path;
    return false;
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  const std::string content = buffer.str();
  in.close();
  std::string line = reason;
  std::replace(line.begin(), line.end(), '\n', ' ');
  std::replace(line.begin(), line.end(), '\r', ' ');
  size_t insert_at = std::string::npos;
  std::string mark;
  if (content.compare(0, 4, "ply\n") == 0) {
    const size_t header_end = content.find("end_header\n");
    const size_t format = content.find("\nformat ");
    if (header_end == std::string::npos || format == std::string::npos || format > header_end) {
      *error = path + ": not a PLY header (no format line before end_header)";
      return false;
    }
    if (content.find("\ncomment partial: ") < header_end) return true;  // marked already
    insert_at = content.find('\n', format + 1) + 1;
    mark = "comment partial: " + line + "\n";
  } else if (!content.empty() && content[0] == '#') {
    const size_t first_end = content.find('\n');
    if (first_end == std::string::npos) {
      *error = path + ": one line only";
      return false;
    }
    if (content.compare(first_end + 1, 11, "# partial: ") == 0) return true;  // marked already
    insert_at = first_end + 1;
    mark = "# partial: " + line + "\n";
  } else {
    *error = path + ": neither a PLY nor a text file with a '#' header";
    return false;
  }
  const std::string tmp = path + ".partial.tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(content.data(), static_cast<std::streamsize>(insert_at));
    out << mark;
    out.write(content.data() + insert_at, static_cast<std::streamsize>(content.size() - insert_at));
    if (!out) {
      *error = "cannot write " + tmp;
      std::remove(tmp.c_str());
      return false;
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    *error = "cannot replace " + path + ": " + ec.message();
    std::remove(tmp.c_str());
    return false;
  }
  return true;
}

}  // namespace objscan

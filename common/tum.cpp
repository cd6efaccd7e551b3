#include "common/tum.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace objscan {

bool ReadTumTrajectory(const std::string& path, std::vector<StampedPose>* poses, std::string* error,
                       bool* units_mm) {
  std::ifstream in(path);
  if (!in) {
    *error = "cannot read " + path;
    return false;
  }
  poses->clear();
  if (units_mm) *units_mm = false;
  std::string line;
  int number = 0;
  const auto fail = [&](const std::string& why) {
    *error = path + ":" + std::to_string(number) + ": " + why;
    return false;
  };
  while (std::getline(in, line)) {
    ++number;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos) continue;
    if (line[first] == '#') {
      std::string text;
      for (size_t i = first + 1; i < line.size(); ++i)
        if (!std::isspace(static_cast<unsigned char>(line[i])))
          text += static_cast<char>(std::tolower(static_cast<unsigned char>(line[i])));
      if (units_mm && (text == "units:mm" || text == "unit:mm")) *units_mm = true;
      continue;
    }
    std::istringstream fields(line);
    std::vector<double> v;
    std::string token;
    while (fields >> token) {
      errno = 0;
      char* end = nullptr;
      const double x = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(x))
        return fail("bad number '" + token + "'");
      v.push_back(x);
    }
    if (v.size() != 8)
      return fail("expected 't tx ty tz qx qy qz qw', got " + std::to_string(v.size()) + " numbers");
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1.0) > 1e-3) return fail("quaternion is not unit");
    q.normalize();
    StampedPose p;
    p.t = v[0];
    p.world_from_camera.linear() = q.toRotationMatrix();
    p.world_from_camera.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    poses->push_back(p);
  }
  return true;
}

bool WriteTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses,
                        const std::vector<std::string>& header, std::string* error, int position_decimals) {
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (!out) {
    *error = "cannot write " + path;
    return false;
  }
  for (const auto& h : header) std::fprintf(out, "# %s\n", h.c_str());
  const int d = std::min(position_decimals, 17);
  for (const auto& p : poses) {
    const Eigen::Quaterniond q(p.world_from_camera.linear());
    const Eigen::Vector3d t = p.world_from_camera.translation();
    if (d < 0)  // lossless: every double reads back exactly
      std::fprintf(out, "%.6f %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", p.t, t.x(), t.y(), t.z(), q.x(), q.y(),
                   q.z(), q.w());
    else
      std::fprintf(out, "%.6f %.*f %.*f %.*f %.9f %.9f %.9f %.9f\n", p.t, d, t.x(), d, t.y(), d, t.z(), q.x(), q.y(),
                   q.z(), q.w());
  }
  const bool ok = std::ferror(out) == 0;
  if (std::fclose(out) != 0 || !ok) {
    *error = "write error on " + path;
    return false;
  }
  return true;
}

}  // namespace objscan

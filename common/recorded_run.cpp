#include "common/recorded_run.h"

#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace objscan {
namespace {

bool Fail(std::string* error, const std::string& text) {
  if (error) *error = text;
  return false;
}

std::string Where(const std::string& path, int line) { return path + ":" + std::to_string(line) + ": "; }

// Splits a line into whitespace-separated tokens; false for comments and blank lines.
bool Tokens(const std::string& line, std::vector<std::string>* tokens) {
  tokens->clear();
  const auto first = line.find_first_not_of(" \t\r");
  if (first == std::string::npos || line[first] == '#') return false;
  std::istringstream in(line);
  std::string token;
  while (in >> token) tokens->push_back(token);
  return true;
}

bool WholeDouble(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size() && std::isfinite(*value);
}

bool WholeInt64(const std::string& text, int64_t* value) {
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE) return false;
  *value = v;
  return true;
}

bool CloseFile(std::FILE* out, const std::string& path, std::string* error) {
  const bool ok = std::ferror(out) == 0;
  if (std::fclose(out) != 0 || !ok) return Fail(error, "cannot write " + path);
  return true;
}

}  // namespace

bool WriteFrameTimes(const std::string& path, const std::vector<FrameTime>& times, std::string* error) {
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (!out) return Fail(error, "cannot write " + path);
  std::fprintf(out,
               "# objscan image times: FILE_NAME UTIME_US per image of images/, on the clock of odometry.txt\n");
  for (const auto& t : times) std::fprintf(out, "%s %" PRId64 "\n", t.file_name.c_str(), t.utime);
  return CloseFile(out, path, error);
}

bool ReadFrameTimes(const std::string& path, std::vector<FrameTime>* times, std::string* error) {
  std::ifstream in(path);
  if (!in) return Fail(error, "cannot read " + path);
  times->clear();
  std::set<std::string> names;
  std::string line;
  std::vector<std::string> tokens;
  for (int number = 1; std::getline(in, line); ++number) {
    if (!Tokens(line, &tokens)) continue;
    FrameTime t;
    if (tokens.size() != 2 || !WholeInt64(tokens[1], &t.utime))
      return Fail(error, Where(path, number) + "expected 'FILE_NAME UTIME_US' (a whole number of µs)");
    if (t.utime < 0) return Fail(error, Where(path, number) + "negative time");
    t.file_name = tokens[0];
    if (!names.insert(t.file_name).second) return Fail(error, Where(path, number) + t.file_name + " listed twice");
    times->push_back(t);
  }
  return true;
}

bool WriteOdometryFile(const std::string& path, const std::vector<OdometryReading>& readings, std::string* error) {
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (!out) return Fail(error, "cannot write " + path);
  std::fprintf(out,
               "# objscan robot odometry (odometry_t), one reading per line in time order. Odometry frame: x forward, "
               "y left, z up at the robot's start pose; theta about +z; tilt positive = looking down.\n"
               "# t_s utime_us seq x_mm y_mm theta_rad pan_rad tilt_rad v_mm_s omega_rad_s pan_rate_rad_s "
               "tilt_rate_rad_s\n");
  for (const auto& r : readings) {
    std::fprintf(out, "%.6f %" PRId64 " %" PRId64 " %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n",
                 static_cast<double>(r.utime) / 1e6, r.utime, r.seq, r.x_mm, r.y_mm, r.theta_rad, r.pan_rad,
                 r.tilt_rad, r.v_mm_s, r.omega_rad_s, r.pan_rate_rad_s, r.tilt_rate_rad_s);
  }
  return CloseFile(out, path, error);
}

bool ReadOdometryFile(const std::string& path, std::vector<OdometryReading>* readings, std::string* error) {
  std::ifstream in(path);
  if (!in) return Fail(error, "cannot read " + path);
  readings->clear();
  std::string line;
  std::vector<std::string> tokens;
  for (int number = 1; std::getline(in, line); ++number) {
    if (!Tokens(line, &tokens)) continue;
    if (tokens.size() != 12)
      return Fail(error, Where(path, number) + "expected 12 columns (t_s utime_us seq x_mm y_mm theta_rad pan_rad "
                                               "tilt_rad v_mm_s omega_rad_s pan_rate_rad_s tilt_rate_rad_s), got " +
                             std::to_string(tokens.size()));
    OdometryReading r;
    double t_s = 0;
    double* fields[] = {&r.x_mm, &r.y_mm, &r.theta_rad, &r.pan_rad, &r.tilt_rad,
                        &r.v_mm_s, &r.omega_rad_s, &r.pan_rate_rad_s, &r.tilt_rate_rad_s};
    bool ok = WholeDouble(tokens[0], &t_s) && WholeInt64(tokens[1], &r.utime) && WholeInt64(tokens[2], &r.seq);
    for (int i = 0; ok && i < 9; ++i) ok = WholeDouble(tokens[3 + i], fields[i]);
    if (!ok) return Fail(error, Where(path, number) + "a value is not a finite number");
    if (std::abs(t_s * 1e6 - static_cast<double>(r.utime)) > 1000)
      return Fail(error, Where(path, number) + "t_s " + tokens[0] + " disagrees with utime_us " + tokens[1]);
    if (!readings->empty() && r.utime <= readings->back().utime)
      return Fail(error, Where(path, number) + "utime_us " + tokens[1] + " does not increase");
    readings->push_back(r);
  }
  return true;
}

OdometryReading RobotDescription::ToObjscanConvention(const OdometryReading& encoder_reading) const {
  OdometryReading r = encoder_reading;
  r.pan_rad = pan_sign * (encoder_reading.pan_rad - pan_zero_rad);
  r.tilt_rad = tilt_sign * (encoder_reading.tilt_rad - tilt_zero_rad);
  r.pan_rate_rad_s = pan_sign * encoder_reading.pan_rate_rad_s;
  r.tilt_rate_rad_s = tilt_sign * encoder_reading.tilt_rate_rad_s;
  return r;
}

bool WriteRobotFile(const std::string& path, const RobotDescription& robot, std::string* error) {
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (!out) return Fail(error, "cannot write " + path);
  const RobotGeometry& g = robot.geometry;
  std::fprintf(out,
               "# objscan robot description (common/recorded_run.h): geometry in mm, frames as in "
               "common/robot_model.h;\n# objscan angle = sign * (encoder angle - zero), pan > 0 = left, "
               "tilt > 0 = looking down\n");
  std::fprintf(out, "mast_height_mm = %.17g\nmast_offset_x_mm = %.17g\nmast_offset_y_mm = %.17g\n", g.mast_height_mm,
               g.mast_offset_x_mm, g.mast_offset_y_mm);
  std::fprintf(out, "camera_offset_x_mm = %.17g\ncamera_offset_y_mm = %.17g\ncamera_offset_z_mm = %.17g\n",
               g.camera_offset_mm.x(), g.camera_offset_mm.y(), g.camera_offset_mm.z());
  std::fprintf(out, "wheel_base_mm = %.17g\n", g.wheel_base_mm);
  std::fprintf(out, "pan_sign = %g\ntilt_sign = %g\npan_zero_rad = %.17g\ntilt_zero_rad = %.17g\n", robot.pan_sign,
               robot.tilt_sign, robot.pan_zero_rad, robot.tilt_zero_rad);
  std::fprintf(out,
               "footprint_radius_mm = %.17g\nmax_speed_mm_s = %.17g\nmax_omega_deg_s = %.17g\npan_limit_deg = %.17g\n"
               "tilt_min_deg = %.17g\ntilt_max_deg = %.17g\n",
               robot.footprint_radius_mm, robot.max_speed_mm_s, robot.max_omega_deg_s, robot.pan_limit_deg,
               robot.tilt_min_deg, robot.tilt_max_deg);
  return CloseFile(out, path, error);
}

bool ReadRobotFile(const std::string& path, RobotDescription* robot, std::string* error) {
  std::ifstream in(path);
  if (!in) return Fail(error, "cannot read " + path);
  RobotDescription r;
  const std::map<std::string, double*> fields = {
      {"mast_height_mm", &r.geometry.mast_height_mm},
      {"mast_offset_x_mm", &r.geometry.mast_offset_x_mm},
      {"mast_offset_y_mm", &r.geometry.mast_offset_y_mm},
      {"camera_offset_x_mm", &r.geometry.camera_offset_mm.x()},
      {"camera_offset_y_mm", &r.geometry.camera_offset_mm.y()},
      {"camera_offset_z_mm", &r.geometry.camera_offset_mm.z()},
      {"wheel_base_mm", &r.geometry.wheel_base_mm},
      {"pan_sign", &r.pan_sign},
      {"tilt_sign", &r.tilt_sign},
      {"pan_zero_rad", &r.pan_zero_rad},
      {"tilt_zero_rad", &r.tilt_zero_rad},
      {"footprint_radius_mm", &r.footprint_radius_mm},
      {"max_speed_mm_s", &r.max_speed_mm_s},
      {"max_omega_deg_s", &r.max_omega_deg_s},
      {"pan_limit_deg", &r.pan_limit_deg},
      {"tilt_min_deg", &r.tilt_min_deg},
      {"tilt_max_deg", &r.tilt_max_deg},
  };
  std::set<std::string> seen;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos) continue;
    const auto eq = line.find('=');
    if (eq == std::string::npos) return Fail(error, Where(path, number) + "expected 'name = value'");
    auto trim = [](std::string s) {
      const auto a = s.find_first_not_of(" \t\r");
      const auto b = s.find_last_not_of(" \t\r");
      return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
    };
    const std::string name = trim(line.substr(0, eq)), value = trim(line.substr(eq + 1));
    const auto it = fields.find(name);
    if (it == fields.end()) return Fail(error, Where(path, number) + "unknown name '" + name + "'");
    if (!seen.insert(name).second) return Fail(error, Where(path, number) + "'" + name + "' given twice");
    if (!WholeDouble(value, it->second))
      return Fail(error, Where(path, number) + "'" + value + "' is not a finite number");
  }
  if (!seen.count("mast_height_mm")) return Fail(error, path + ": mast_height_mm is required");
  if (std::abs(r.pan_sign) != 1 || std::abs(r.tilt_sign) != 1)
    return Fail(error, path + ": pan_sign and tilt_sign must be 1 or -1");
  std::string why;
  if (!r.geometry.IsValid(&why)) return Fail(error, path + ": " + why);
  if (!(r.footprint_radius_mm > 0) || !(r.max_speed_mm_s > 0) || !(r.max_omega_deg_s > 0))
    return Fail(error, path + ": footprint_radius_mm, max_speed_mm_s and max_omega_deg_s must be > 0");
  if (!(r.pan_limit_deg > 0 && r.pan_limit_deg <= 180))
    return Fail(error, path + ": pan_limit_deg must be in (0, 180]");
  if (!(r.tilt_min_deg < r.tilt_max_deg && r.tilt_min_deg >= -90 && r.tilt_max_deg <= 90))
    return Fail(error, path + ": tilt_min_deg < tilt_max_deg, both in [-90, 90], is required");
  *robot = r;
  return true;
}

}  // namespace objscan

#include "tools/export/colmap_convert.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

namespace objscan {
namespace {
bool Fail(std::string* error, const std::string& text) {
  if (error) *error = text;
  return false;
}

bool ParseDouble(const std::string& token, double* value) {
  try {
    size_t used = 0;
    *value = std::stod(token, &used);
    return used == token.size();
  } catch (const std::exception&) {
    return false;
  }
}

bool ParseInt(const std::string& token, int64_t* value) {
  try {
    size_t used = 0;
    *value = std::stoll(token, &used);
    return used == token.size();
  } catch (const std::exception&) {
    return false;
  }
}

std::string Trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}
}  // namespace

bool ReadColmapImagesTxt(const std::string& path, std::vector<ColmapImage>* images, std::string* error) {
  std::ifstream in(path);
  if (!in) return Fail(error, "cannot read " + path);
  images->clear();
  std::string line;
  int number = 0;
  bool expect_observations = false;
  while (std::getline(in, line)) {
    ++number;
    const std::string where = path + ":" + std::to_string(number);
    const std::string trimmed = Trim(line);
    if (!trimmed.empty() && trimmed[0] == '#') continue;
    if (expect_observations) {
      expect_observations = false;
      std::istringstream ss(trimmed);
      std::vector<std::string> tokens;
      for (std::string t; ss >> t;) tokens.push_back(t);
      if (tokens.size() % 3 != 0) return Fail(error, where + ": observations are not 'X Y POINT3D_ID' triples");
      ColmapImage& image = images->back();
      for (size_t i = 0; i < tokens.size(); i += 3) {
        double x = 0, y = 0;
        int64_t id = 0;
        if (!ParseDouble(tokens[i], &x) || !ParseDouble(tokens[i + 1], &y) || !ParseInt(tokens[i + 2], &id))
          return Fail(error,
                      where + ": bad observation '" + tokens[i] + " " + tokens[i + 1] + " " + tokens[i + 2] + "'");
        ++image.num_observations;
        if (id != -1) ++image.num_triangulated;
      }
      continue;
    }
    if (trimmed.empty()) continue;
    std::istringstream ss(trimmed);
    std::vector<std::string> tokens;
    for (std::string t; tokens.size() < 9 && ss >> t;) tokens.push_back(t);
    std::string name;
    std::getline(ss, name);
    name = Trim(name);
    if (tokens.size() < 9 || name.empty())
      return Fail(error, where + ": expected 'IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME'");
    ColmapImage image;
    double v[7];
    for (int i = 0; i < 7; ++i)
      if (!ParseDouble(tokens[1 + i], &v[i])) return Fail(error, where + ": bad number '" + tokens[1 + i] + "'");
    if (!ParseInt(tokens[0], &image.image_id) || !ParseInt(tokens[8], &image.camera_id))
      return Fail(error, where + ": bad IMAGE_ID or CAMERA_ID");
    Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
    if (!(q.norm() > 1e-9) || !std::isfinite(q.norm())) return Fail(error, where + ": invalid quaternion");
    image.camera_from_world_rotation = q.normalized();
    image.camera_from_world_translation = Eigen::Vector3d(v[4], v[5], v[6]);
    if (!image.camera_from_world_translation.allFinite()) return Fail(error, where + ": non-finite translation");
    image.name = name;
    images->push_back(image);
    expect_observations = true;
  }
  return true;
}

bool FrameIndexFromName(const std::string& name, int64_t* index) {
  std::string stem = name;
  const size_t slash = stem.find_last_of("/\\");
  if (slash != std::string::npos) stem = stem.substr(slash + 1);
  const size_t dot = stem.find_last_of('.');
  if (dot != std::string::npos && dot > 0) stem.resize(dot);
  size_t end = stem.size();
  while (end > 0 && !std::isdigit(static_cast<unsigned char>(stem[end - 1]))) --end;
  size_t begin = end;
  while (begin > 0 && std::isdigit(static_cast<unsigned char>(stem[begin - 1]))) --begin;
  if (begin == end || end - begin > 18) return false;
  *index = std::stoll(stem.substr(begin, end - begin));
  return true;
}

bool ColmapImagesToTum(const std::vector<ColmapImage>& images, double rate_hz, std::vector<StampedPose>* poses,
                       std::string* error) {
  if (!(rate_hz > 0)) return Fail(error, "rate must be > 0 Hz");
  std::vector<std::pair<int64_t, StampedPose>> indexed;
  std::set<int64_t> seen;
  for (const auto& image : images) {
    int64_t index = 0;
    if (!FrameIndexFromName(image.name, &index))
      return Fail(error, "image name '" + image.name + "' holds no frame number");
    if (!seen.insert(index).second)
      return Fail(error, "two images with frame number " + std::to_string(index) + " ('" + image.name + "')");
    StampedPose pose;
    pose.t = static_cast<double>(index) / rate_hz;
    const Eigen::Matrix3d world_from_camera_rotation = image.camera_from_world_rotation.toRotationMatrix().transpose();
    pose.world_from_camera.linear() = world_from_camera_rotation;
    pose.world_from_camera.translation() = -world_from_camera_rotation * image.camera_from_world_translation;
    indexed.emplace_back(index, pose);
  }
  std::sort(indexed.begin(), indexed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  poses->clear();
  for (const auto& item : indexed) poses->push_back(item.second);
  return true;
}

bool ColmapCameraFromCalibration(const PinholeCamera& camera, std::string* model, std::string* params,
                                 std::string* error) {
  if (camera.skew != 0) return Fail(error, "COLMAP camera models have no skew (calibration skew is not 0)");
  char buf[512];
  const double cx = camera.cx + 0.5, cy = camera.cy + 0.5;
  if (!camera.HasDistortion()) {
    *model = "PINHOLE";
    std::snprintf(buf, sizeof(buf), "%.17g,%.17g,%.17g,%.17g", camera.fx, camera.fy, cx, cy);
  } else if (camera.k3 == 0) {
    *model = "OPENCV";
    std::snprintf(buf, sizeof(buf), "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", camera.fx, camera.fy, cx, cy,
                  camera.k1, camera.k2, camera.p1, camera.p2);
  } else {
    *model = "FULL_OPENCV";
    std::snprintf(buf, sizeof(buf), "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,0,0,0", camera.fx, camera.fy,
                  cx, cy, camera.k1, camera.k2, camera.p1, camera.p2, camera.k3);
  }
  *params = buf;
  return true;
}

}  // namespace objscan

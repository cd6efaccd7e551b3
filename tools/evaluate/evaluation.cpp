#include "tools/evaluate/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <unordered_map>

#include "common/point_grid.h"
#include "common/statistics.h"

namespace objscan {

bool ReadTumTrajectory(const std::string& path, std::vector<StampedPose>* poses, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = "cannot read " + path;
    return false;
  }
  poses->clear();
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    double t, x, y, z, qx, qy, qz, qw;
    if (!(ss >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) {
      *error = path + ":" + std::to_string(number) + ": expected 't tx ty tz qx qy qz qw'";
      return false;
    }
    StampedPose p;
    p.t = t;
    p.world_from_camera.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
    p.world_from_camera.translation() = Eigen::Vector3d(x, y, z);
    poses->push_back(p);
  }
  return true;
}

bool WriteTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses,
                        const std::vector<std::string>& header, std::string* error) {
  std::ofstream out(path);
  if (!out) {
    *error = "cannot write " + path;
    return false;
  }
  for (const auto& h : header) out << "# " << h << "\n";
  char buf[256];
  for (const auto& p : poses) {
    const Eigen::Quaterniond q(p.world_from_camera.linear());
    const Eigen::Vector3d t = p.world_from_camera.translation();
    std::snprintf(buf, sizeof(buf), "%.6f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", p.t, t.x(), t.y(), t.z(), q.x(), q.y(),
                  q.z(), q.w());
    out << buf;
  }
  return static_cast<bool>(out);
}

bool EvaluateTumTrajectories(const std::vector<StampedPose>& estimated, const std::vector<StampedPose>& truth,
                             bool with_scale, double max_dt_s, TrajectoryEvaluation* out, std::string* error) {
  std::vector<StampedPose> sorted_truth = truth;
  std::sort(sorted_truth.begin(), sorted_truth.end(), [](auto& a, auto& b) { return a.t < b.t; });
  std::vector<Eigen::Isometry3d> est, tru;
  for (const auto& e : estimated) {
    auto it = std::lower_bound(sorted_truth.begin(), sorted_truth.end(), e.t,
                               [](const StampedPose& p, double t) { return p.t < t; });
    const StampedPose* best = nullptr;
    if (it != sorted_truth.end()) best = &*it;
    if (it != sorted_truth.begin() && (!best || std::abs((it - 1)->t - e.t) < std::abs(best->t - e.t)))
      best = &*(it - 1);
    if (best && std::abs(best->t - e.t) <= max_dt_s) {
      est.push_back(e.world_from_camera);
      tru.push_back(best->world_from_camera);
    }
  }
  TrajectoryEvaluation r;
  r.num_estimated = static_cast<int>(estimated.size());
  r.num_truth = static_cast<int>(truth.size());
  r.num_matched = static_cast<int>(est.size());
  r.registered_fraction = truth.empty() ? 0.0 : double(r.num_matched) / double(truth.size());
  if (!EvaluateTrajectory(est, tru, with_scale, &r.error)) {
    *error = "fewer than 3 matched poses, or degenerate (collinear) positions";
    return false;
  }
  *out = r;
  return true;
}

bool ReadPlyPoints(const std::string& path, std::vector<Eigen::Vector3d>* points, std::string* error,
                   std::vector<Eigen::Vector3d>* normals) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = "cannot read " + path;
    return false;
  }
  std::string line, format;
  long vertex_count = -1;
  bool in_vertex = false;
  struct Prop {
    std::string name, type;
  };
  std::vector<Prop> props;
  std::getline(in, line);
  if (line.rfind("ply", 0) != 0) {
    *error = path + ": not a PLY file";
    return false;
  }
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ss(line);
    std::string word;
    ss >> word;
    if (word == "format")
      ss >> format;
    else if (word == "element") {
      std::string name;
      long count;
      ss >> name >> count;
      in_vertex = name == "vertex";
      if (in_vertex) vertex_count = count;
    } else if (word == "property" && in_vertex) {
      Prop p;
      ss >> p.type;
      if (p.type == "list") {
        *error = path + ": list property in vertex element";
        return false;
      }
      ss >> p.name;
      props.push_back(p);
    } else if (word == "end_header") {
      break;
    }
  }
  if (vertex_count < 0) {
    *error = path + ": no vertex element";
    return false;
  }
  auto type_size = [](const std::string& t) -> int {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
    if (t == "double" || t == "float64") return 8;
    return 0;
  };
  int xi = -1, yi = -1, zi = -1;
  for (size_t i = 0; i < props.size(); ++i) {
    if (props[i].name == "x") xi = static_cast<int>(i);
    if (props[i].name == "y") yi = static_cast<int>(i);
    if (props[i].name == "z") zi = static_cast<int>(i);
  }
  if (xi < 0 || yi < 0 || zi < 0) {
    *error = path + ": vertex has no x y z";
    return false;
  }
  int nxi = -1, nyi = -1, nzi = -1;
  for (size_t i = 0; i < props.size(); ++i) {
    if (props[i].name == "nx") nxi = static_cast<int>(i);
    if (props[i].name == "ny") nyi = static_cast<int>(i);
    if (props[i].name == "nz") nzi = static_cast<int>(i);
  }
  if (normals) {
    if (nxi < 0 || nyi < 0 || nzi < 0) {
      *error = path + ": vertex has no nx ny nz";
      return false;
    }
    normals->clear();
  }
  points->clear();
  points->reserve(static_cast<size_t>(vertex_count));
  if (format == "ascii") {
    for (long v = 0; v < vertex_count; ++v) {
      if (!std::getline(in, line)) break;
      std::istringstream ss(line);
      std::vector<double> values(props.size());
      for (auto& value : values) ss >> value;
      if (!ss) {
        *error = path + ": bad vertex line " + std::to_string(v);
        return false;
      }
      points->emplace_back(values[xi], values[yi], values[zi]);
      if (normals) normals->emplace_back(values[nxi], values[nyi], values[nzi]);
    }
  } else if (format == "binary_little_endian") {
    std::vector<int> offsets;
    int stride = 0;
    for (const auto& p : props) {
      const int s = type_size(p.type);
      if (s == 0) {
        *error = path + ": unknown property type " + p.type;
        return false;
      }
      offsets.push_back(stride);
      stride += s;
    }
    std::vector<char> row(stride);
    auto read_value = [&](int i) -> double {
      const char* at = row.data() + offsets[i];
      if (props[i].type == "double" || props[i].type == "float64") {
        double d;
        std::memcpy(&d, at, 8);
        return d;
      }
      float f;
      std::memcpy(&f, at, 4);
      return f;
    };
    for (long v = 0; v < vertex_count; ++v) {
      if (!in.read(row.data(), stride)) break;
      points->emplace_back(read_value(xi), read_value(yi), read_value(zi));
      if (normals) normals->emplace_back(read_value(nxi), read_value(nyi), read_value(nzi));
    }
  } else {
    *error = path + ": unsupported PLY format " + format;
    return false;
  }
  if (static_cast<long>(points->size()) != vertex_count) {
    *error = path + ": file ends after " + std::to_string(points->size()) + " of " + std::to_string(vertex_count) +
             " vertices";
    return false;
  }
  return true;
}

std::vector<int> VisibleSurfacePoints(const std::vector<Eigen::Vector3d>& points,
                                      const std::vector<Eigen::Vector3d>& normals,
                                      const std::vector<StampedPose>& cameras, const ViewIntrinsics& intrinsics,
                                      int min_views, double min_cos, bool occlusion, double occlusion_tolerance) {
  std::vector<int> visible;
  if (points.size() != normals.size() || intrinsics.width <= 0 || intrinsics.height <= 0) return visible;
  const int width = intrinsics.width, height = intrinsics.height;
  constexpr double kMaxTanAngle = 10.0;  // the grazing term's bound (84.3 deg; also for points seen from behind)
  const double min_focal = std::min(intrinsics.fx, intrinsics.fy);
  std::vector<Eigen::Vector3d> unit_normals(normals.size());
  for (size_t i = 0; i < normals.size(); ++i) unit_normals[i] = normals[i].normalized();
  std::vector<int> views(points.size(), 0);
  std::vector<float> depth_buffer;
  std::vector<int> pixel_index(points.size());  // -1 = behind the camera or outside the image
  std::vector<double> camera_depth(points.size());
  for (const StampedPose& camera : cameras) {
    const Eigen::Isometry3d camera_from_world = camera.world_from_camera.inverse();
    const Eigen::Vector3d center = camera.world_from_camera.translation();
    // Projections (nearest pixel) of every point in front of the camera and inside the image, and the z-buffer.
    if (occlusion) depth_buffer.assign(static_cast<size_t>(width) * height, std::numeric_limits<float>::infinity());
    for (size_t i = 0; i < points.size(); ++i) {
      pixel_index[i] = -1;
      const Eigen::Vector3d p = camera_from_world * points[i];
      if (!(p.z() > 0)) continue;
      const double u = intrinsics.fx * p.x() / p.z() + intrinsics.cx;
      const double v = intrinsics.fy * p.y() / p.z() + intrinsics.cy;
      if (!(u >= 0 && v >= 0 && u <= width - 1 && v <= height - 1)) continue;
      pixel_index[i] = static_cast<int>(std::lround(v) * width + std::lround(u));
      camera_depth[i] = p.z();
      if (occlusion) {
        float& d = depth_buffer[static_cast<size_t>(pixel_index[i])];
        d = std::min(d, static_cast<float>(p.z()));
      }
    }
    for (size_t i = 0; i < points.size(); ++i) {
      if (pixel_index[i] < 0) continue;
      const Eigen::Vector3d to_camera = center - points[i];
      const double cos_angle = unit_normals[i].dot(to_camera) / to_camera.norm();
      if (!(cos_angle >= min_cos)) continue;
      if (occlusion) {
        // Two points in one pixel are up to sqrt(2) footprints apart across the image; a surface seen at angle θ
        // from its normal changes depth by tan θ per unit of that.
        const double tan_angle =
            cos_angle > 0 ? std::min(kMaxTanAngle, std::sqrt(std::max(0.0, 1 - cos_angle * cos_angle)) / cos_angle)
                          : kMaxTanAngle;
        const double footprint = camera_depth[i] / min_focal;  // units per pixel at the point's depth
        const double tolerance = occlusion_tolerance + footprint * (1 + std::sqrt(2.0) * tan_angle);
        if (camera_depth[i] > depth_buffer[static_cast<size_t>(pixel_index[i])] + tolerance) continue;
      }
      ++views[i];
    }
  }
  for (size_t i = 0; i < points.size(); ++i)
    if (views[i] >= min_views) visible.push_back(static_cast<int>(i));
  return visible;
}

SurfaceEvaluation EvaluateSurface(const std::vector<Eigen::Vector3d>& model, const std::vector<Eigen::Vector3d>& truth,
                                  double completeness_threshold) {
  return EvaluateSurface(model, truth, truth, completeness_threshold);
}

SurfaceEvaluation EvaluateSurface(const std::vector<Eigen::Vector3d>& model,
                                  const std::vector<Eigen::Vector3d>& accuracy_truth,
                                  const std::vector<Eigen::Vector3d>& completeness_truth,
                                  double completeness_threshold) {
  SurfaceEvaluation r;
  r.num_model = static_cast<int>(model.size());
  r.num_truth = static_cast<int>(completeness_truth.size());
  if (model.empty() || accuracy_truth.empty() || completeness_truth.empty()) return r;
  const double cell = std::max(completeness_threshold, 1e-9);
  const PointGrid truth_grid(accuracy_truth, cell);
  std::vector<double> d;
  d.reserve(model.size());
  for (const auto& p : model) d.push_back(truth_grid.NearestExact(p));
  r.accuracy_p50 = Percentile(d, 0.5);
  r.accuracy_p90 = Percentile(d, 0.9);
  r.accuracy_max = *std::max_element(d.begin(), d.end());
  const PointGrid model_grid(model, cell);
  int covered = 0;
  for (const auto& p : completeness_truth)
    if (model_grid.Nearest(p, 1) <= completeness_threshold) ++covered;
  r.completeness = double(covered) / double(completeness_truth.size());
  return r;
}

}  // namespace objscan

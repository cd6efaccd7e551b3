#include "tools/evaluate/evaluation.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <unordered_map>

#include "common/kd_tree.h"
#include "common/point_grid.h"
#include "common/statistics.h"

namespace objscan {

bool EvaluateTumTrajectories(const std::vector<StampedPose>& estimated, const std::vector<StampedPose>& truth,
                             bool with_scale, double max_dt_s, TrajectoryEvaluation* out, std::string* error) {
  std::vector<StampedPose> sorted_truth = truth;
  std::sort(sorted_truth.begin(), sorted_truth.end(), [](auto& a, auto& b) { return a.t < b.t; });
  std::vector<Eigen::Isometry3d> est, tru;
  std::vector<double> matched_t;
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
      matched_t.push_back(e.t);
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
  r.matched_t_s = std::move(matched_t);
  for (size_t i = 0; i < est.size(); ++i)
    r.matched_error.push_back((r.error.alignment * est[i].translation() - tru[i].translation()).norm());
  *out = r;
  return true;
}

namespace {

// Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = va + vb + vc;
  if (!(std::abs(denom) > 0)) return a;  // degenerate triangle
  const double v = vb / denom, w = vc / denom;
  return a + v * ab + w * ac;
}

}  // namespace


MeshDistance::MeshDistance(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles)
    : vertices_(vertices) {
  for (const Eigen::Vector3i& t : triangles) {
    if ((t.array() < 0).any() || (t.array() >= static_cast<int>(vertices.size())).any()) continue;
    const Eigen::Vector3d &a = vertices[t[0]], &b = vertices[t[1]], &c = vertices[t[2]];
    if (!a.allFinite() || !b.allFinite() || !c.allFinite()) continue;
    triangles_.push_back(t);
  }
  if (triangles_.empty()) return;
  // Cells about twice the mean edge: a few triangles per cell, few cells per triangle.
  double edges = 0;
  Eigen::Vector3d lo = vertices_[triangles_[0][0]], hi = lo;
  for (const Eigen::Vector3i& t : triangles_)
    for (int k = 0; k < 3; ++k) {
      edges += (vertices_[t[k]] - vertices_[t[(k + 1) % 3]]).norm();
      lo = lo.cwiseMin(vertices_[t[k]]);
      hi = hi.cwiseMax(vertices_[t[k]]);
    }
  cell_ = std::max(2.0 * edges / (3.0 * triangles_.size()), 1e-6);
  // At most ~4M cells over the bounding box (a few large triangles would otherwise make it huge).
  cell_ = std::max(cell_, (hi - lo).maxCoeff() / 160.0);
  for (size_t i = 0; i < triangles_.size(); ++i) {
    const Eigen::Vector3i& t = triangles_[i];
    const Eigen::Vector3d tlo = vertices_[t[0]].cwiseMin(vertices_[t[1]]).cwiseMin(vertices_[t[2]]);
    const Eigen::Vector3d thi = vertices_[t[0]].cwiseMax(vertices_[t[1]]).cwiseMax(vertices_[t[2]]);
    const Eigen::Vector3i c0 = Cell(tlo), c1 = Cell(thi);
    for (int z = c0.z(); z <= c1.z(); ++z)
      for (int y = c0.y(); y <= c1.y(); ++y)
        for (int x = c0.x(); x <= c1.x(); ++x) cells_[Key(Eigen::Vector3i(x, y, z))].push_back(static_cast<int>(i));
  }
  bounds_lo_ = Cell(lo);
  bounds_hi_ = Cell(hi);
}

Eigen::Vector3i MeshDistance::Cell(const Eigen::Vector3d& p) const { return (p / cell_).array().floor().cast<int>(); }

uint64_t MeshDistance::Key(const Eigen::Vector3i& c) {
  const auto u = [](int v) { return static_cast<uint64_t>(static_cast<uint32_t>(v + (1 << 20))) & 0x1fffff; };
  return (u(c.x()) << 42) | (u(c.y()) << 21) | u(c.z());
}

double MeshDistance::TriangleDistance(const Eigen::Vector3d& q, int i) const {
  const Eigen::Vector3i& t = triangles_[static_cast<size_t>(i)];
  return (q - ClosestPointOnTriangle(q, vertices_[t[0]], vertices_[t[1]], vertices_[t[2]])).norm();
}

double MeshDistance::Distance(const Eigen::Vector3d& q) const {
  double best = std::numeric_limits<double>::infinity();
  if (triangles_.empty() || !q.allFinite()) return best;
  const Eigen::Vector3i c = Cell(q);
  // Rings of cells around q's cell until the best distance is within the ring already searched (a triangle only in
  // cells of ring r + 1 or farther is at least r cells away); far queries (outside the grid's reach) search all.
  const Eigen::Vector3i below = bounds_lo_ - c, above = c - bounds_hi_;
  const int outside = std::max(0, std::max(below.maxCoeff(), above.maxCoeff()));
  constexpr int kMaxRings = 12;
  if (outside > kMaxRings / 2) {
    for (size_t i = 0; i < triangles_.size(); ++i) best = std::min(best, TriangleDistance(q, static_cast<int>(i)));
    return best;
  }
  for (int r = 0; r <= kMaxRings; ++r) {
    for (int dz = -r; dz <= r; ++dz)
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != r) continue;  // the ring's shell only
          auto it = cells_.find(Key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (int i : it->second) best = std::min(best, TriangleDistance(q, i));
        }
    if (best <= r * cell_) return best;
  }
  for (size_t i = 0; i < triangles_.size(); ++i) best = std::min(best, TriangleDistance(q, static_cast<int>(i)));
  return best;
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

namespace {

void SetAccuracy(std::vector<double> d, SurfaceEvaluation* r) {
  r->accuracy_p50 = Percentile(d, 0.5);
  r->accuracy_p90 = Percentile(d, 0.9);
  r->accuracy_max = *std::max_element(d.begin(), d.end());
}

double Completeness(const std::vector<Eigen::Vector3d>& model, const std::vector<Eigen::Vector3d>& completeness_truth,
                    double threshold) {
  const PointGrid model_grid(model, std::max(threshold, 1e-9));
  int covered = 0;
  for (const auto& p : completeness_truth)
    if (model_grid.Nearest(p, 1) <= threshold) ++covered;
  return double(covered) / double(completeness_truth.size());
}

// Accuracy from distance_to_truth(model point) over every model point, completeness over completeness_truth.
template <typename DistanceFn>
SurfaceEvaluation Evaluate(const std::vector<Eigen::Vector3d>& model,
                           const std::vector<Eigen::Vector3d>& completeness_truth, double completeness_threshold,
                           bool truth_empty, std::vector<double>* distances, DistanceFn&& distance_to_truth) {
  SurfaceEvaluation r;
  if (distances) distances->clear();
  r.num_model = static_cast<int>(model.size());
  r.num_truth = static_cast<int>(completeness_truth.size());
  if (model.empty() || truth_empty || completeness_truth.empty()) return r;
  std::vector<double> d;
  d.reserve(model.size());
  for (const auto& p : model) d.push_back(distance_to_truth(p));
  if (distances) *distances = d;
  SetAccuracy(std::move(d), &r);
  r.completeness = Completeness(model, completeness_truth, completeness_threshold);
  return r;
}

}  // namespace

SurfaceEvaluation EvaluateSurfaceToMesh(const std::vector<Eigen::Vector3d>& model, const MeshDistance& truth_mesh,
                                        const std::vector<Eigen::Vector3d>& completeness_truth,
                                        double completeness_threshold, std::vector<double>* distances) {
  return Evaluate(model, completeness_truth, completeness_threshold, truth_mesh.empty(), distances,
                  [&](const Eigen::Vector3d& p) { return truth_mesh.Distance(p); });
}

SurfaceEvaluation EvaluateSurface(const std::vector<Eigen::Vector3d>& model,
                                  const std::vector<Eigen::Vector3d>& accuracy_truth,
                                  const std::vector<Eigen::Vector3d>& completeness_truth, double completeness_threshold,
                                  std::vector<double>* distances) {
  const KdTree truth_tree(accuracy_truth);
  return Evaluate(model, completeness_truth, completeness_threshold, truth_tree.empty(), distances,
                  [&](const Eigen::Vector3d& p) { return truth_tree.NearestDistance(p); });
}

bool JsonNumbers(const std::string& json_text, const std::string& key, int n, std::vector<double>* values) {
  values->clear();
  const size_t at = json_text.find("\"" + key + "\"");
  if (at == std::string::npos) return false;
  size_t pos = json_text.find(':', at + key.size() + 2);
  if (pos == std::string::npos) return false;
  ++pos;
  while (pos < json_text.size() && std::isspace(static_cast<unsigned char>(json_text[pos]))) ++pos;
  const bool array = pos < json_text.size() && json_text[pos] == '[';
  if (array) ++pos;
  for (int i = 0; i < n; ++i) {
    const char* begin = json_text.c_str() + pos;
    char* end = nullptr;
    const double v = std::strtod(begin, &end);
    if (end == begin || !std::isfinite(v)) return false;
    values->push_back(v);
    pos += static_cast<size_t>(end - begin);
    while (pos < json_text.size() && std::isspace(static_cast<unsigned char>(json_text[pos]))) ++pos;
    if (i + 1 < n) {
      if (!array || pos >= json_text.size() || json_text[pos] != ',') return false;
      ++pos;
    }
  }
  return !array || (pos < json_text.size() && json_text[pos] == ']');
}

TargetEvaluation EvaluateTarget(const Eigen::Vector3d& center_mm, const Eigen::Vector3d& size_mm,
                                const Eigen::Vector3d& true_center_mm, const Eigen::Vector3d& true_size_mm,
                                const Sim3& truth_from_estimate) {
  TargetEvaluation e;
  e.center_aligned_mm = truth_from_estimate * center_mm;
  e.center_error_mm = (e.center_aligned_mm - true_center_mm).norm();
  e.center_error_xy_mm = (e.center_aligned_mm - true_center_mm).head<2>().norm();
  const double s = truth_from_estimate.scale;
  e.size_error_mm = Eigen::Vector3d(s * size_mm.head<2>().maxCoeff() - true_size_mm.head<2>().maxCoeff(),
                                    s * size_mm.head<2>().minCoeff() - true_size_mm.head<2>().minCoeff(),
                                    s * size_mm.z() - true_size_mm.z());
  return e;
}

bool TrueBoxAtYaw(const std::vector<Eigen::Vector3d>& true_vertices_mm, double yaw_rad, Eigen::Vector3d* center_mm,
                  Eigen::Vector3d* size_mm) {
  if (true_vertices_mm.empty()) return false;
  const Eigen::Matrix3d world_from_box = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Eigen::Vector3d& v : true_vertices_mm) {
    const Eigen::Vector3d b = world_from_box.transpose() * v;
    lo = lo.cwiseMin(b);
    hi = hi.cwiseMax(b);
  }
  *center_mm = world_from_box * (0.5 * (lo + hi));
  *size_mm = hi - lo;
  return true;
}

double YawInTruthFrame(double yaw_rad, const Sim3& truth_from_estimate) {
  const Eigen::Vector3d axis = truth_from_estimate.rotation * Eigen::Vector3d(std::cos(yaw_rad), std::sin(yaw_rad), 0);
  return std::atan2(axis.y(), axis.x());
}

}  // namespace objscan

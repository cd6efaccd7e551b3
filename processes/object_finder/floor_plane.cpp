#include "processes/object_finder/floor_plane.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

namespace objscan {

Eigen::Isometry3d FloorPlane::FloorFromWorld() const {
  Eigen::Isometry3d floor_from_world = Eigen::Isometry3d::Identity();
  floor_from_world.linear() = Eigen::Quaterniond::FromTwoVectors(normal, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  floor_from_world.translation() = Eigen::Vector3d(0, 0, offset_mm);
  return floor_from_world;
}

namespace {

constexpr int kSamplePoints = 512;  // points the RANSAC hypotheses are scored on
constexpr int kIterations = 400;    // 3-point samples
constexpr uint32_t kSeed = 24u;     // fixed: the same input gives the same floor

int CountInliers(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& indices, const FloorPlane& plane,
                 double inlier_mm) {
  int count = 0;
  for (int i : indices) count += std::abs(plane.Height(points[i])) <= inlier_mm;
  return count;
}

// Total least squares plane through the points with |height| <= inlier_mm; false when fewer than 3 or too tilted.
bool Refit(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& indices, double inlier_mm,
           double min_normal_z, FloorPlane* plane) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (int i : indices)
    if (std::abs(plane->Height(points[i])) <= inlier_mm) {
      sum += points[i];
      ++n;
    }
  if (n < 3) return false;
  const Eigen::Vector3d mean = sum / n;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i : indices)
    if (std::abs(plane->Height(points[i])) <= inlier_mm) {
      const Eigen::Vector3d d = points[i] - mean;
      cov += d * d.transpose();
    }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
  Eigen::Vector3d normal = solver.eigenvectors().col(0);  // smallest eigenvalue
  if (normal.z() < 0) normal = -normal;
  if (!(normal.z() >= min_normal_z)) return false;
  plane->normal = normal;
  plane->offset_mm = -normal.dot(mean);
  return true;
}

FloorFit FitOnce(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& candidates,
                 const FloorFitOptions& options, const FloorPlane* previous) {
  FloorFit fit;
  const int n = static_cast<int>(candidates.size());
  if (n < std::max(3, options.min_points)) return fit;
  const int m = std::min(n, kSamplePoints);
  std::vector<int> sample(m);
  for (int k = 0; k < m; ++k) sample[k] = candidates[static_cast<int64_t>(k) * n / m];
  const double min_normal_z = std::cos(options.max_tilt_deg * M_PI / 180.0);

  FloorPlane best;
  int best_count = 0;
  if (previous) {
    best = *previous;
    best_count = CountInliers(points, sample, best, options.inlier_mm);
  }
  std::mt19937 rng(kSeed);
  for (int it = 0; it < kIterations; ++it) {
    const int a = static_cast<int>(rng() % m), b = static_cast<int>(rng() % m), c = static_cast<int>(rng() % m);
    if (a == b || b == c || a == c) continue;
    const Eigen::Vector3d& p = points[sample[a]];
    Eigen::Vector3d normal = (points[sample[b]] - p).cross(points[sample[c]] - p);
    const double norm = normal.norm();
    if (!(norm > 1e-9)) continue;
    normal /= norm;
    if (normal.z() < 0) normal = -normal;
    if (normal.z() < min_normal_z) continue;
    FloorPlane plane{normal, -normal.dot(p)};
    const int count = CountInliers(points, sample, plane, options.inlier_mm);
    if (count > best_count) {
      best_count = count;
      best = plane;
    }
  }
  if (best_count < 3) return fit;
  for (int pass = 0; pass < 2; ++pass)
    if (!Refit(points, candidates, options.inlier_mm, min_normal_z, &best)) return fit;
  fit.plane = best;
  fit.inliers = CountInliers(points, candidates, best, options.inlier_mm);
  fit.found = fit.inliers >= options.min_points;
  return fit;
}

}  // namespace

FloorFit FitFloor(const std::vector<Eigen::Vector3d>& points, const FloorFitOptions& options,
                  const FloorPlane* previous) {
  std::vector<int> candidates(points.size());
  for (size_t i = 0; i < points.size(); ++i) candidates[i] = static_cast<int>(i);
  FloorFit best = FitOnce(points, candidates, options, previous);
  // The floor is the lowest horizontal plane: a table top with more landmarks than the floor leaves the floor's
  // points clearly below it. Points below the floor itself are only noise and phantoms (few, not a plane).
  for (int retry = 0; retry < 2 && best.found; ++retry) {
    std::vector<int> below;
    for (int i : candidates)
      if (best.plane.Height(points[i]) < -3.0 * options.inlier_mm) below.push_back(i);
    if (static_cast<int>(below.size()) < std::max<double>(options.min_points, 0.25 * best.inliers)) break;
    FloorFit lower = FitOnce(points, below, options, nullptr);
    if (!lower.found) break;
    lower.inliers = CountInliers(points, candidates, lower.plane, options.inlier_mm);
    // A floor under a table top is a plane of its own size; a few dozen noisy points below the floor are not (room_01:
    // a 30 000-landmark map once put the floor 195 mm low on such points).
    if (lower.inliers < 0.25 * best.inliers) break;
    best = lower;
    candidates.swap(below);
  }
  return best;
}

}  // namespace objscan

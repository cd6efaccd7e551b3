#include "common/floor_fit.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

namespace objscan {

Eigen::Isometry3d FloorPlane::FloorFromWorld() const {
  Eigen::Isometry3d floor_from_world = Eigen::Isometry3d::Identity();
  floor_from_world.linear() = Eigen::Quaterniond::FromTwoVectors(normal, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  floor_from_world.translation() = Eigen::Vector3d(0, 0, offset_mm);
  return floor_from_world;
}

namespace {

double MinCosine(double max_tilt_deg) { return std::cos(max_tilt_deg * M_PI / 180.0); }

// Indices in [0, n) from the chosen sequence (see SampleIndexSequence).
class SampleIndices {
 public:
  SampleIndices(SampleIndexSequence sequence, uint64_t seed, size_t n)
      : sequence_(sequence),
        mt_(static_cast<uint32_t>(seed)),
        uniform_(0, static_cast<int>(n) - 1),
        lcg_(seed),
        n_(n) {}

  size_t Next() {
    switch (sequence_) {
      case SampleIndexSequence::kMt19937Uniform:
        return static_cast<size_t>(uniform_(mt_));
      case SampleIndexSequence::kLcg:
        lcg_ = lcg_ * 6364136223846793005ULL + 1442695040888963407ULL;
        return static_cast<uint32_t>(lcg_ >> 33) % n_;
      case SampleIndexSequence::kMt19937Modulo:
        break;
    }
    return mt_() % n_;
  }

 private:
  SampleIndexSequence sequence_;
  std::mt19937 mt_;
  std::uniform_int_distribution<int> uniform_;
  uint64_t lcg_;
  size_t n_;
};

}  // namespace

PlaneSupport MostSupportedPlane(const std::vector<Eigen::Vector3d>& points, const PlaneSampling& sampling,
                                double inlier_mm, const FloorPlane* start,
                                const std::function<bool(const FloorPlane&)>& admissible) {
  PlaneSupport best;
  if (start) {
    best.plane = *start;
    best.inliers = CountPlaneInliers(points, best.plane, inlier_mm);
  }
  const size_t n = points.size();
  if (n < 3) return best;
  const double min_cos = MinCosine(sampling.max_tilt_deg);
  SampleIndices indices(sampling.sequence, sampling.seed, n);
  for (int it = 0; it < sampling.iterations; ++it) {
    const size_t a = indices.Next(), b = indices.Next(), c = indices.Next();
    if (a == b || b == c || a == c) continue;
    const Eigen::Vector3d& p = points[a];
    Eigen::Vector3d normal = (points[b] - p).cross(points[c] - p);
    const double norm = normal.norm();
    if (!(norm > 1e-9)) continue;
    normal /= norm;
    double along_up = normal.dot(sampling.up);
    if (along_up < 0) {
      normal = -normal;
      along_up = -along_up;
    }
    if (along_up < min_cos) continue;
    const FloorPlane plane{normal, -normal.dot(p)};
    if (admissible && !admissible(plane)) continue;
    const int count = CountPlaneInliers(points, plane, inlier_mm);
    if (count > best.inliers) {
      best.inliers = count;
      best.plane = plane;
    }
  }
  return best;
}

int CountPlaneInliers(const std::vector<Eigen::Vector3d>& points, const FloorPlane& plane, double inlier_mm) {
  int count = 0;
  for (const Eigen::Vector3d& p : points) count += std::abs(plane.Height(p)) <= inlier_mm;
  return count;
}

int CountPointsBelow(const std::vector<Eigen::Vector3d>& points, const FloorPlane& plane, double depth_mm) {
  int count = 0;
  for (const Eigen::Vector3d& p : points) count += plane.Height(p) < -depth_mm;
  return count;
}

bool RefitPlaneToInliers(const std::vector<Eigen::Vector3d>& points, double inlier_mm, const Eigen::Vector3d& up,
                         FloorPlane* plane) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (const Eigen::Vector3d& p : points)
    if (std::abs(plane->Height(p)) <= inlier_mm) {
      sum += p;
      ++n;
    }
  if (n < 3) return false;
  const Eigen::Vector3d mean = sum / n;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points)
    if (std::abs(plane->Height(p)) <= inlier_mm) {
      const Eigen::Vector3d d = p - mean;
      cov += d * d.transpose();
    }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
  Eigen::Vector3d normal = solver.eigenvectors().col(0);  // smallest eigenvalue
  if (normal.dot(up) < 0) normal = -normal;
  plane->normal = normal;
  plane->offset_mm = -normal.dot(mean);
  return true;
}

bool NormalWithinTilt(const FloorPlane& plane, const Eigen::Vector3d& up, double max_tilt_deg) {
  return plane.normal.dot(up) >= MinCosine(max_tilt_deg);
}

}  // namespace objscan

// Test support (tests only): synthetic planar point sets for the floor-fitting tests (common/floor_fit_test.cpp,
// processes/object_finder/floor_plane_test.cpp).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace objscan {
namespace testing_support {

// deg, angle between two directions.
inline double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

// Points on the plane through `origin` with normal `normal` (height noise sigma), over a square of half side `half`.
inline void AddPlane(const Eigen::Vector3d& origin, const Eigen::Vector3d& normal, double half, int count,
                     double sigma, std::mt19937* rng, std::vector<Eigen::Vector3d>* points) {
  const Eigen::Vector3d a = normal.unitOrthogonal(), b = normal.cross(a);
  std::uniform_real_distribution<double> u(-half, half);
  std::normal_distribution<double> g(0, sigma);
  for (int i = 0; i < count; ++i) points->push_back(origin + u(*rng) * a + u(*rng) * b + g(*rng) * normal);
}

}  // namespace testing_support
}  // namespace objscan

// PointGrid: a uniform hash grid over a fixed set of 3-D points, for neighbour queries within a bounded radius.
// The grid keeps a reference to the caller's points (they must outlive it and not change) and refers to them by
// index. Cell size and distances share the points' unit (mm here). Never throws beyond std::bad_alloc.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <unordered_map>
#include <vector>

namespace objscan {

class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector3d>& points, double cell) : points_(points), cell_(cell) {
    for (size_t i = 0; i < points.size(); ++i) cells_[Key(points[i])].push_back(static_cast<int>(i));
  }

  // Calls fn(index) for every point within radius of q (cells visited in x, y, z order from the lowest; points of a
  // cell in input order).
  template <class Fn>
  void ForEachWithin(const Eigen::Vector3d& q, double radius, Fn&& fn) const {
    const Eigen::Vector3i c = Cell(q);
    const int rings = static_cast<int>(std::ceil(radius / cell_));
    const double r2 = radius * radius;
    for (int dx = -rings; dx <= rings; ++dx)
      for (int dy = -rings; dy <= rings; ++dy)
        for (int dz = -rings; dz <= rings; ++dz) {
          auto it = cells_.find(Pack(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (int i : it->second)
            if ((points_[i] - q).squaredNorm() <= r2) fn(i);
        }
  }

  // Nearest distance, searching rings up to max_rings cells away; +inf if nothing found. Cost grows with
  // max_rings^4: keep it small (common/kd_tree.h answers at any distance).
  double Nearest(const Eigen::Vector3d& q, int max_rings) const {
    const Eigen::Vector3i c = Cell(q);
    double best = std::numeric_limits<double>::infinity();
    for (int r = 0; r <= max_rings; ++r) {
      for (int dx = -r; dx <= r; ++dx)
        for (int dy = -r; dy <= r; ++dy)
          for (int dz = -r; dz <= r; ++dz) {
            if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != r) continue;
            auto it = cells_.find(Pack(c + Eigen::Vector3i(dx, dy, dz)));
            if (it == cells_.end()) continue;
            for (int i : it->second) best = std::min(best, (points_[i] - q).norm());
          }
      if (best <= r * cell_) break;  // nothing in a further ring can be closer
    }
    return best;
  }

 private:
  Eigen::Vector3i Cell(const Eigen::Vector3d& p) const {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / cell_)), static_cast<int>(std::floor(p.y() / cell_)),
                           static_cast<int>(std::floor(p.z() / cell_)));
  }
  static int64_t Pack(const Eigen::Vector3i& c) {
    return (static_cast<int64_t>(c.x() + (1 << 20)) << 42) | (static_cast<int64_t>(c.y() + (1 << 20)) << 21) |
           static_cast<int64_t>(c.z() + (1 << 20));
  }
  int64_t Key(const Eigen::Vector3d& p) const { return Pack(Cell(p)); }

  const std::vector<Eigen::Vector3d>& points_;
  double cell_;
  std::unordered_map<int64_t, std::vector<int>> cells_;
};

}  // namespace objscan

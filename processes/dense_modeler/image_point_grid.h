// ImagePointGrid: points of one image (px) in a uniform grid of square cells, for neighbour queries (LCM-free).
// Cells cover the pixels [-0.5, size - 0.5] of a width x height image; points outside it go to the border cells
// (queries stay exact: a point is never put in a cell farther from an in-image query than its own). Points are
// referred to by the caller's index. Never throws beyond std::bad_alloc.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <utility>
#include <vector>

namespace objscan {

class ImagePointGrid {
 public:
  // Cells `cell_px` wide (at least 4 px; at most 4096 cells per axis).
  ImagePointGrid(int width, int height, double cell_px) {
    cell_ = std::max(std::abs(cell_px), 4.0);
    nx_ = std::max(1, static_cast<int>(std::min(4096.0, std::ceil((width + 1) / cell_))));
    ny_ = std::max(1, static_cast<int>(std::min(4096.0, std::ceil((height + 1) / cell_))));
    head_.assign(static_cast<size_t>(nx_) * ny_, -1);
  }
  double cell() const { return cell_; }
  // Cell of a pixel (clamped to the grid).
  int Cell(const Eigen::Vector2d& px) const {
    const int cx = std::clamp(static_cast<int>(std::floor((px.x() + 0.5) / cell_)), 0, nx_ - 1);
    const int cy = std::clamp(static_cast<int>(std::floor((px.y() + 0.5) / cell_)), 0, ny_ - 1);
    return cy * nx_ + cx;
  }
  void Insert(const Eigen::Vector2d& px, int index) {
    const int c = Cell(px);
    if (static_cast<size_t>(index) >= next_.size()) next_.resize(index + 1, -1);
    next_[index] = head_[c];
    head_[c] = index;
  }
  // Calls visit(index) for the points of the 3x3 cells around px until it returns true; true if it did. With cells
  // at least r wide, every point within r of px is among them.
  template <typename Visit>
  bool AnyNear(const Eigen::Vector2d& px, Visit visit) const {
    const int c = Cell(px), cx = c % nx_, cy = c / nx_;
    for (int y = std::max(0, cy - 1); y <= std::min(ny_ - 1, cy + 1); ++y)
      for (int x = std::max(0, cx - 1); x <= std::min(nx_ - 1, cx + 1); ++x)
        for (int i = head_[y * nx_ + x]; i >= 0; i = next_[i])
          if (visit(i)) return true;
    return false;
  }
  // Rings around px's cell: ring r holds the cells r cells away (Chebyshev); ring 0 is the cell itself. After rings
  // 0..r every point closer than r x cell() to an in-image px has been visited. MaxRing: the last ring with cells.
  int MaxRing(const Eigen::Vector2d& px) const {
    const int c = Cell(px), cx = c % nx_, cy = c / nx_;
    return std::max({cx, nx_ - 1 - cx, cy, ny_ - 1 - cy});
  }
  template <typename Visit>
  void ForEachInRing(const Eigen::Vector2d& px, int ring, Visit visit) const {
    const int c = Cell(px), cx = c % nx_, cy = c / nx_;
    auto cell = [&](int x, int y) {
      if (x < 0 || y < 0 || x >= nx_ || y >= ny_) return;
      for (int i = head_[y * nx_ + x]; i >= 0; i = next_[i]) visit(i);
    };
    if (ring == 0) return cell(cx, cy);
    for (int x = cx - ring; x <= cx + ring; ++x) cell(x, cy - ring), cell(x, cy + ring);          // top and bottom rows
    for (int y = cy - ring + 1; y <= cy + ring - 1; ++y) cell(cx - ring, y), cell(cx + ring, y);  // the sides
  }

  // Distance from an in-image p to the nearest of points (the points inserted, by index); +inf when there are
  // none. Exact: rings are searched until no unvisited point can be closer.
  double NearestDistance(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& p) const {
    double best = std::numeric_limits<double>::infinity();
    if (points.empty()) return best;
    const int last = MaxRing(p);
    for (int r = 0; r <= last; ++r) {
      ForEachInRing(p, r, [&](int i) { best = std::min(best, (points[i] - p).norm()); });
      if (best <= r * cell_) break;
    }
    return best;
  }
  // The k nearest of points to an in-image p as (squared distance, index), smallest first, ties by lower index:
  // the first k of all points sorted that way (fewer when there are fewer points).
  void NearestK(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& p, size_t k,
                std::vector<std::pair<double, size_t>>* out) const {
    out->clear();
    if (k == 0 || points.empty()) return;
    const int last = MaxRing(p);
    for (int r = 0; r <= last; ++r) {
      ForEachInRing(p, r, [&](int i) { out->emplace_back((points[i] - p).squaredNorm(), static_cast<size_t>(i)); });
      if (out->size() < k) continue;
      std::nth_element(out->begin(), out->begin() + (k - 1), out->end());
      const double reach = r * cell_;
      if ((*out)[k - 1].first < reach * reach) break;  // every unvisited point is at least reach away
    }
    const size_t n = std::min(k, out->size());
    std::partial_sort(out->begin(), out->begin() + n, out->end());
    out->resize(n);
  }

 private:
  double cell_ = 1;
  int nx_ = 1, ny_ = 1;
  std::vector<int> head_, next_;
};

}  // namespace objscan

// ImagePointGrid: points of one image (px) in a uniform grid of square cells, for neighbour queries (LCM-free).
// Cells cover the pixels [-0.5, size - 0.5] of a width x height image; points outside it go to the border cells
// (queries stay exact: clamping never puts a point in a cell farther from a query's cell than its own). Points are
// referred to by the caller's index: insert each index (>= 0) once, with the position that the `points` vector given
// to the queries holds at that index. Coordinates must be finite. Const queries may run concurrently; Insert may
// not. Never throws beyond std::bad_alloc.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <limits>
#include <utility>
#include <vector>

namespace objscan {

class ImagePointGrid {
 public:
  // Cells cell_px wide (at least 4 px; at most 4096 cells per axis).
  ImagePointGrid(int width, int height, double cell_px) {
    cell_px_ = std::max(std::abs(cell_px), 4.0);
    nx_ = std::max(1, static_cast<int>(std::min(4096.0, std::ceil((width + 1) / cell_px_))));
    ny_ = std::max(1, static_cast<int>(std::min(4096.0, std::ceil((height + 1) / cell_px_))));
    head_.assign(static_cast<size_t>(nx_) * ny_, -1);
  }
  double cell_px() const { return cell_px_; }  // px, cell width
  // Index of the cell of a pixel (clamped to the grid; a non-finite pixel gets cell 0).
  int CellIndex(const Eigen::Vector2d& px) const { return Clamped(px.y(), ny_) * nx_ + Clamped(px.x(), nx_); }
  // Adds point `index` at px (negative indices are ignored).
  void Insert(const Eigen::Vector2d& px, int index) {
    if (index < 0) return;
    const int c = CellIndex(px);
    if (static_cast<size_t>(index) >= next_.size()) next_.resize(static_cast<size_t>(index) + 1, -1);
    next_[index] = head_[c];
    head_[c] = index;
    ++size_;
  }
  // Calls visit(index) for the points of the 3x3 cells around px until it returns true; true if it did. With cells
  // at least r wide, every point within r of px is among them.
  template <typename Visit>
  bool AnyNear(const Eigen::Vector2d& px, Visit visit) const {
    const int c = CellIndex(px), cx = c % nx_, cy = c / nx_;
    for (int y = std::max(0, cy - 1); y <= std::min(ny_ - 1, cy + 1); ++y)
      for (int x = std::max(0, cx - 1); x <= std::min(nx_ - 1, cx + 1); ++x)
        for (int i = head_[y * nx_ + x]; i >= 0; i = next_[i])
          if (visit(i)) return true;
    return false;
  }
  // Rings around px's cell: ring r holds the grid's cells r cells away (Chebyshev); ring 0 is the cell itself. A
  // point not visited after rings 0..r is farther than (r - 1) x cell_px() from px (r x cell_px() but for the
  // rounding of cell boundaries). MaxRing: the last ring with cells.
  int MaxRing(const Eigen::Vector2d& px) const {
    const int c = CellIndex(px), cx = c % nx_, cy = c / nx_;
    return std::max({cx, nx_ - 1 - cx, cy, ny_ - 1 - cy});
  }
  template <typename Visit>
  void ForEachInRing(const Eigen::Vector2d& px, int ring, Visit visit) const {
    const int c = CellIndex(px), cx = c % nx_, cy = c / nx_;
    auto visit_cell = [&](int x, int y) {
      for (int i = head_[y * nx_ + x]; i >= 0; i = next_[i]) visit(i);
    };
    if (ring == 0) {
      visit_cell(cx, cy);
      return;
    }
    const int x0 = std::max(0, cx - ring), x1 = std::min(nx_ - 1, cx + ring);
    const int y0 = std::max(0, cy - ring + 1), y1 = std::min(ny_ - 1, cy + ring - 1);
    for (const int y : {cy - ring, cy + ring}) {  // the top and bottom rows
      if (y < 0 || y >= ny_) continue;
      for (int x = x0; x <= x1; ++x) visit_cell(x, y);
    }
    for (const int x : {cx - ring, cx + ring}) {  // the sides between them
      if (x < 0 || x >= nx_) continue;
      for (int y = y0; y <= y1; ++y) visit_cell(x, y);
    }
  }

  // Distance (px) from p to the nearest of points (the points inserted, by index); +inf when there are none. Exact:
  // rings are searched until no unvisited point can be closer.
  double NearestDistance(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& p) const {
    double best = std::numeric_limits<double>::infinity();
    if (points.empty() || size_ == 0) return best;
    const int last = MaxRing(p);
    for (int r = 0; r <= last; ++r) {
      ForEachInRing(p, r, [&](int i) { best = std::min(best, (points[i] - p).norm()); });
      if (best <= (r - 1) * cell_px_) break;
    }
    return best;
  }
  // The k nearest of points to p as (squared distance px^2, index), smallest first, ties by lower index: the first
  // k of all inserted points sorted that way (fewer when fewer were inserted).
  void NearestK(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& p, size_t k,
                std::vector<std::pair<double, size_t>>* out) const {
    out->clear();
    if (k == 0 || points.empty() || size_ == 0) return;
    const int last = MaxRing(p);
    for (int r = 0; r <= last; ++r) {
      ForEachInRing(p, r, [&](int i) { out->emplace_back((points[i] - p).squaredNorm(), static_cast<size_t>(i)); });
      if (out->size() >= size_) break;  // every point visited
      if (out->size() < k || r < 1) continue;
      std::nth_element(out->begin(), out->begin() + (k - 1), out->end());
      const double reach = (r - 1) * cell_px_;
      if ((*out)[k - 1].first < reach * reach) break;  // every unvisited point is farther than reach
    }
    const size_t n = std::min(k, out->size());
    std::partial_sort(out->begin(), out->begin() + n, out->end());
    out->resize(n);
  }

 private:
  int Clamped(double coordinate, int cells) const {
    const double c = std::floor((coordinate + 0.5) / cell_px_);
    return c >= 0 ? static_cast<int>(std::min(c, cells - 1.0)) : 0;  // NaN compares false: cell 0
  }

  double cell_px_ = 1;  // px
  int nx_ = 1, ny_ = 1;
  size_t size_ = 0;  // points inserted
  std::vector<int> head_, next_;
};

}  // namespace objscan

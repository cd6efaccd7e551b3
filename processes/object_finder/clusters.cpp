#include "processes/object_finder/clusters.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "common/point_grid.h"

namespace objscan {

namespace {

int Root(std::vector<int>& parent, int i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

double Cross(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

// Andrew's monotone chain; counter-clockwise, no repeated or collinear points.
std::vector<Eigen::Vector2d> ConvexHull(std::vector<Eigen::Vector2d> p) {
  std::sort(p.begin(), p.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return p;
  std::vector<Eigen::Vector2d> hull(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && Cross(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && Cross(hull[k - 2], hull[k - 1], p[i - 1]) <= 0) --k;
    hull[k++] = p[i - 1];
  }
  hull.resize(k - 1);
  return hull;
}

Rectangle2d RectangleAlong(const std::vector<Eigen::Vector2d>& points, double yaw) {
  const Eigen::Vector2d a(std::cos(yaw), std::sin(yaw)), b(-std::sin(yaw), std::cos(yaw));
  double min_a = std::numeric_limits<double>::infinity(), max_a = -min_a, min_b = min_a, max_b = -min_a;
  for (const auto& p : points) {
    min_a = std::min(min_a, p.dot(a));
    max_a = std::max(max_a, p.dot(a));
    min_b = std::min(min_b, p.dot(b));
    max_b = std::max(max_b, p.dot(b));
  }
  Rectangle2d r;
  r.yaw_rad = yaw;
  r.extents = Eigen::Vector2d(max_a - min_a, max_b - min_b);
  r.centre = 0.5 * (min_a + max_a) * a + 0.5 * (min_b + max_b) * b;
  return r;
}

// The footprint of a cluster, robust to the few stray landmarks a 50 mm linkage picks up around an object (room_05:
// a 258 x 218 mm box measured 361 x 276 mm from 1959 landmarks, and dropped as too large). Below kRobustMinPoints
// points: the minimum-area rectangle of all. Above: its yaw from the points without the kStrayFraction farthest from
// the median, its extents between the kTrimFraction and 1 - kTrimFraction quantiles along that yaw (a box's faces
// hold many points at their extreme; a sphere's extent shrinks by ~4 kTrimFraction).
constexpr int kRobustMinPoints = 50;
constexpr double kStrayFraction = 0.02;
constexpr double kTrimFraction = 0.01;

double Quantile(std::vector<double>* v, double q) {
  const size_t k = std::min(v->size() - 1, static_cast<size_t>(q * static_cast<double>(v->size())));
  std::nth_element(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(k), v->end());
  return (*v)[k];
}

Rectangle2d RobustRectangle(const std::vector<Eigen::Vector2d>& points) {
  if (static_cast<int>(points.size()) < kRobustMinPoints) return MinAreaRectangle(points);
  std::vector<double> xs, ys;
  for (const auto& p : points) {
    xs.push_back(p.x());
    ys.push_back(p.y());
  }
  const Eigen::Vector2d median(Quantile(&xs, 0.5), Quantile(&ys, 0.5));
  std::vector<double> distance;
  for (const auto& p : points) distance.push_back((p - median).norm());
  std::vector<double> sorted = distance;
  const double keep_within = Quantile(&sorted, 1.0 - kStrayFraction);
  std::vector<Eigen::Vector2d> core;
  for (size_t i = 0; i < points.size(); ++i)
    if (distance[i] <= keep_within) core.push_back(points[i]);
  const double yaw = MinAreaRectangle(core).yaw_rad;
  const Eigen::Vector2d a(std::cos(yaw), std::sin(yaw)), b(-std::sin(yaw), std::cos(yaw));
  std::vector<double> along_a, along_b;
  for (const auto& p : points) {
    along_a.push_back(p.dot(a));
    along_b.push_back(p.dot(b));
  }
  const double min_a = Quantile(&along_a, kTrimFraction), max_a = Quantile(&along_a, 1.0 - kTrimFraction);
  const double min_b = Quantile(&along_b, kTrimFraction), max_b = Quantile(&along_b, 1.0 - kTrimFraction);
  Rectangle2d r;
  r.yaw_rad = yaw;
  r.extents = Eigen::Vector2d(max_a - min_a, max_b - min_b);
  r.centre = 0.5 * (min_a + max_a) * a + 0.5 * (min_b + max_b) * b;
  return r;
}

}  // namespace

std::vector<std::vector<int>> EuclideanClusters(const std::vector<Eigen::Vector3d>& points, double distance_mm,
                                                int min_points) {
  const int n = static_cast<int>(points.size());
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  const PointGrid grid(points, distance_mm);
  for (int i = 0; i < n; ++i) {
    grid.ForEachWithin(points[i], distance_mm, [&](int j) {
      if (j <= i) return;
      const int ri = Root(parent, i), rj = Root(parent, j);
      if (ri != rj) parent[std::max(ri, rj)] = std::min(ri, rj);  // the root is the smallest index
    });
  }
  std::vector<int> slot(n, -1);
  std::vector<std::vector<int>> clusters;
  for (int i = 0; i < n; ++i) {  // ascending: clusters ordered by first index, members sorted
    const int r = Root(parent, i);
    if (slot[r] < 0) {
      slot[r] = static_cast<int>(clusters.size());
      clusters.emplace_back();
    }
    clusters[slot[r]].push_back(i);
  }
  clusters.erase(
      std::remove_if(clusters.begin(), clusters.end(),
                     [min_points](const std::vector<int>& c) { return static_cast<int>(c.size()) < min_points; }),
      clusters.end());
  return clusters;
}

Rectangle2d MinAreaRectangle(const std::vector<Eigen::Vector2d>& points) {
  if (points.empty()) return {};
  const std::vector<Eigen::Vector2d> hull = ConvexHull(points);
  Rectangle2d best = RectangleAlong(points, 0.0);
  if (hull.size() >= 3) {
    double best_area = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < hull.size(); ++i) {
      const Eigen::Vector2d edge = hull[(i + 1) % hull.size()] - hull[i];
      const Rectangle2d r = RectangleAlong(hull, std::atan2(edge.y(), edge.x()));
      const double area = r.extents.x() * r.extents.y();
      if (area < best_area - 1e-9) {
        best_area = area;
        best = r;
      }
    }
  }
  while (best.yaw_rad >= M_PI / 4) {
    best.yaw_rad -= M_PI / 2;
    best.extents = Eigen::Vector2d(best.extents.y(), best.extents.x());
  }
  while (best.yaw_rad < -M_PI / 4) {
    best.yaw_rad += M_PI / 2;
    best.extents = Eigen::Vector2d(best.extents.y(), best.extents.x());
  }
  return best;
}

ClusterBox FitClusterBox(const std::vector<Eigen::Vector3d>& floor_points, const std::vector<int>& members,
                         const FloorPlane& floor, const std::vector<double>* errors_px) {
  ClusterBox box;
  box.points = static_cast<int>(members.size());
  if (members.empty()) return box;
  std::vector<Eigen::Vector2d> xy;
  xy.reserve(members.size());
  double top = -std::numeric_limits<double>::infinity(), lowest = std::numeric_limits<double>::infinity();
  for (int i : members) {
    xy.emplace_back(floor_points[i].x(), floor_points[i].y());
    top = std::max(top, floor_points[i].z());
    lowest = std::min(lowest, floor_points[i].z());
  }
  const Rectangle2d rect = RobustRectangle(xy);
  const double height = std::max(0.0, top);
  box.size_mm = Eigen::Vector3d(rect.extents.x(), rect.extents.y(), height);
  box.yaw_rad = rect.yaw_rad;
  box.lowest_mm = lowest;
  box.centre_mm = floor.FloorFromWorld().inverse() * Eigen::Vector3d(rect.centre.x(), rect.centre.y(), 0.5 * height);
  const double area_mm2 = (rect.extents.x() + rect.extents.y()) * height + rect.extents.x() * rect.extents.y();
  box.texture_density = area_mm2 > 0 ? box.points / (area_mm2 / 10000.0) : 0.0;
  if (errors_px) {
    std::vector<double> e;
    e.reserve(members.size());
    for (int i : members) e.push_back((*errors_px)[i]);
    std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
    box.median_error_px = e[e.size() / 2];
  }
  return box;
}

}  // namespace objscan

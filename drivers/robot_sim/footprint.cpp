#include "drivers/robot_sim/footprint.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace objscan {
namespace {

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

double PointSegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double length2 = ab.squaredNorm();
  const double t = length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

bool SegmentsIntersect(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                       const Eigen::Vector2d& d) {
  const double d1 = Cross(b - a, c - a), d2 = Cross(b - a, d - a);
  const double d3 = Cross(d - c, a - c), d4 = Cross(d - c, b - c);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  // touching or collinear cases
  return PointSegmentDistance(c, a, b) < 1e-9 || PointSegmentDistance(d, a, b) < 1e-9 ||
         PointSegmentDistance(a, c, d) < 1e-9 || PointSegmentDistance(b, c, d) < 1e-9;
}

FloorObstacle Circle(const SceneObject& o, double radius) {
  FloorObstacle f;
  f.is_circle = true;
  f.center_mm = o.center_mm.head<2>();
  f.radius_mm = radius;
  return f;
}

}  // namespace

double FloorObstacle::SignedDistance(const Eigen::Vector2d& p) const {
  if (is_circle) return (p - center_mm).norm() - radius_mm;
  double edge_distance = std::numeric_limits<double>::infinity();
  bool inside = true;
  const size_t n = polygon_mm.size();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = polygon_mm[i];
    const Eigen::Vector2d& b = polygon_mm[(i + 1) % n];
    if (Cross(b - a, p - a) < 0) inside = false;  // right of a counter-clockwise edge: outside
    edge_distance = std::min(edge_distance, PointSegmentDistance(p, a, b));
  }
  return inside ? -edge_distance : edge_distance;
}

bool FloorObstacle::IntersectsSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const {
  if (is_circle) return PointSegmentDistance(center_mm, a, b) <= radius_mm;
  if (SignedDistance(a) <= 0 || SignedDistance(b) <= 0) return true;
  const size_t n = polygon_mm.size();
  for (size_t i = 0; i < n; ++i)
    if (SegmentsIntersect(a, b, polygon_mm[i], polygon_mm[(i + 1) % n])) return true;
  return false;
}

std::vector<Eigen::Vector2d> ConvexHull(std::vector<Eigen::Vector2d> points) {
  std::sort(points.begin(), points.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  // Andrew's monotone chain.
  std::vector<Eigen::Vector2d> hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && Cross(hull[k - 1] - hull[k - 2], points[i] - hull[k - 2]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && Cross(hull[k - 1] - hull[k - 2], points[i] - hull[k - 2]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

std::vector<FloorObstacle> FloorObstacles(const Scene& scene) {
  std::vector<FloorObstacle> out;
  for (const SceneObject& o : scene.objects) {
    if (o.type == ShapeType::kFloor || o.bounds.isEmpty() || o.bounds.max().z() < kDrivableHeightMm) continue;
    FloorObstacle f;
    if (o.type == ShapeType::kSphere || o.type == ShapeType::kCylinder) {
      f = Circle(o, o.radius_mm);
    } else if (o.type == ShapeType::kBox) {
      const Eigen::Rotation2Dd rot(o.yaw_rad);
      const double hx = o.size_mm.x() / 2, hy = o.size_mm.y() / 2;
      for (const Eigen::Vector2d& corner :
           {Eigen::Vector2d(-hx, -hy), Eigen::Vector2d(hx, -hy), Eigen::Vector2d(hx, hy), Eigen::Vector2d(-hx, hy)})
        f.polygon_mm.push_back(o.center_mm.head<2>() + rot * corner);
    } else {  // mesh
      std::vector<Eigen::Vector2d> projected;
      projected.reserve(o.mesh.positions.size());
      for (const Eigen::Vector3f& p : o.mesh.positions) projected.push_back(p.head<2>().cast<double>());
      f.polygon_mm = ConvexHull(std::move(projected));
      if (f.polygon_mm.size() < 3) {  // degenerate (a vertical sheet seen from above): its bounding circle
        f = Circle(o, 0.5 * (o.bounds.max() - o.bounds.min()).head<2>().norm());
        f.center_mm = o.bounds.center().head<2>();
      }
    }
    f.object_id = o.id;
    f.name = o.name;
    out.push_back(std::move(f));
  }
  return out;
}

FootprintChecker::FootprintChecker(const Scene& scene, double radius_mm)
    : radius_mm_(radius_mm), obstacles_(FloorObstacles(scene)) {
  if (!std::isfinite(radius_mm) || radius_mm <= 0) throw std::invalid_argument("footprint radius must be > 0 mm");
}

double FootprintChecker::Clearance(const Eigen::Vector2d& base_xy, int* object_id) const {
  double best = std::numeric_limits<double>::infinity();
  int best_id = -1;
  for (const FloorObstacle& f : obstacles_) {
    const double clearance = f.SignedDistance(base_xy) - radius_mm_;
    if (clearance < best) {
      best = clearance;
      best_id = f.object_id;
    }
  }
  if (object_id) *object_id = best_id;
  return best;
}

bool FootprintChecker::StepBlocked(double x_mm, double y_mm, double theta_rad, double distance_mm, double dtheta_rad,
                                   int* object_id) const {
  if (object_id) *object_id = -1;
  if (obstacles_.empty() || distance_mm == 0) return false;
  const double start_clearance = Clearance(Eigen::Vector2d(x_mm, y_mm));
  const int samples = std::max(1, static_cast<int>(std::ceil(std::abs(distance_mm) / 5.0)));
  for (int k = 1; k <= samples; ++k) {
    const double s = static_cast<double>(k) / samples;
    const double half = dtheta_rad * s / 2;
    const double chord = std::abs(half) > 1e-9 ? distance_mm * s * std::sin(half) / half : distance_mm * s;
    const Eigen::Vector2d p(x_mm + chord * std::cos(theta_rad + half), y_mm + chord * std::sin(theta_rad + half));
    int id = -1;
    const double clearance = Clearance(p, &id);
    if (clearance < 0 && clearance < start_clearance) {
      if (object_id) *object_id = id;
      return true;
    }
  }
  return false;
}

bool ContactCounter::Record(Frame frame) {
  if (frame == Frame::kIdle) return false;
  if (frame == Frame::kFree) {
    in_contact_ = false;
    return false;
  }
  ++blocked_frames_;
  if (in_contact_) return false;
  in_contact_ = true;
  ++collisions_;
  return true;
}

}  // namespace objscan

#include "processes/planner/motion.h"

#include "processes/planner/path_search.h"

#include <algorithm>
#include <cmath>

namespace objscan {
namespace {
constexpr double kTurnInPlaceRad = 50 * M_PI / 180;
constexpr double kHeadingGain = 2.0;  // 1/s, yaw rate per rad of heading error
}  // namespace

void PathFollower::SetPath(std::vector<Eigen::Vector2d> path) {
  path_ = std::move(path);
  index_ = 0;
}

bool PathFollower::Reached(const BasePose& base, double tolerance_mm) const {
  return !path_.empty() && (path_.back() - base.position()).norm() <= tolerance_mm;
}

bool LineOfSight(const OccupancyMap& map, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const double length = (b - a).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length / 25.0)));
  for (int i = 1; i <= steps; ++i)
    if (!map.FootprintSafe(a + (b - a) * (static_cast<double>(i) / steps))) return false;
  return true;
}

Velocity PathFollower::Follow(const OccupancyMap& map, const BasePose& base, double speed, double max_omega) {
  if (path_.empty()) return {};
  const Eigen::Vector2d p = base.position();
  // Progress: the nearest point among the next few (never backwards).
  size_t best = index_;
  double best_d = (path_[index_] - p).norm();
  for (size_t i = index_ + 1; i < path_.size() && i < index_ + 30; ++i) {
    const double d = (path_[i] - p).norm();
    if (d < best_d) {
      best = i;
      best_d = d;
    }
  }
  index_ = best;
  const double lookahead = 350;
  Eigen::Vector2d target = path_[std::min(index_ + 1, path_.size() - 1)];
  for (size_t i = index_ + 1; i < path_.size() && (path_[i] - p).norm() <= lookahead; ++i)
    if (LineOfSight(map, p, path_[i])) target = path_[i];
  const double to_goal = (path_.back() - p).norm();
  if ((target - p).norm() < 1.0) return {};
  const double error = WrapAngle(std::atan2(target.y() - p.y(), target.x() - p.x()) - base.theta_rad);
  Velocity out;
  out.omega_rad_s = std::clamp(kHeadingGain * error, -max_omega, max_omega);
  if (std::abs(error) < kTurnInPlaceRad)
    out.v_mm_s = speed * std::cos(error) * std::clamp(to_goal / 300.0, 0.25, 1.0);
  return out;
}

Eigen::Vector2d PathFollower::PointAhead(const BasePose& base, double distance) const {
  const Eigen::Vector2d heading(std::cos(base.theta_rad), std::sin(base.theta_rad));
  if (path_.size() < 2) return base.position() + distance * heading;
  double left = distance;
  Eigen::Vector2d from = base.position();
  for (size_t i = std::min(index_ + 1, path_.size() - 1); i < path_.size(); ++i) {
    const double d = (path_[i] - from).norm();
    if (d >= left) return from + (path_[i] - from) * (left / d);
    left -= d;
    from = path_[i];
  }
  const Eigen::Vector2d last = path_.back() - path_[path_.size() - 2];
  return path_.back() + (last.norm() > 0 ? Eigen::Vector2d(last.normalized()) : heading) * left;
}

bool PathFollower::StillFree(const OccupancyMap& map, double distance) const {
  double travelled = 0;
  const size_t first = std::max<size_t>(index_, 1);  // path_[0] is where the robot started (exempt, like the search)
  for (size_t i = first; i < path_.size() && travelled <= distance; ++i) {
    if (i > first) travelled += (path_[i] - path_[i - 1]).norm();
    int index;
    if (!map.IndexOf(path_[i], &index) || !map.Passable(index)) return false;
  }
  return true;
}

Velocity FollowCircle(const BasePose& base, const Eigen::Vector2d& centre, double radius, double speed,
                      double max_omega, bool clockwise) {
  const Eigen::Vector2d r = base.position() - centre;
  const double azimuth = std::atan2(r.y(), r.x());
  const double radial_error = r.norm() - radius;
  const double sign = clockwise ? -1.0 : 1.0;
  const double heading = azimuth + sign * (M_PI / 2 + std::atan2(radial_error, 400.0));
  const double error = WrapAngle(heading - base.theta_rad);
  Velocity out;
  if (std::abs(error) > M_PI / 6) {
    out.omega_rad_s = std::clamp(kHeadingGain * error, -max_omega, max_omega);
    return out;
  }
  out.v_mm_s = speed * std::cos(error);
  out.omega_rad_s = std::clamp(sign * out.v_mm_s / radius + kHeadingGain * error, -max_omega, max_omega);
  return out;
}

BasePose Integrate(const BasePose& b, const Velocity& vel, double dt) {
  BasePose out = b;
  const double v = vel.v_mm_s, w = vel.omega_rad_s;
  if (std::abs(w) < 1e-9) {
    out.x_mm += v * dt * std::cos(b.theta_rad);
    out.y_mm += v * dt * std::sin(b.theta_rad);
  } else {
    out.x_mm += v / w * (std::sin(b.theta_rad + w * dt) - std::sin(b.theta_rad));
    out.y_mm -= v / w * (std::cos(b.theta_rad + w * dt) - std::cos(b.theta_rad));
  }
  out.theta_rad = WrapAngle(b.theta_rad + w * dt);
  return out;
}

namespace {
// Distance to the nearest obstacle or unknown cell beyond the footprint (mm; negative = overlapping), at a point.
double Margin(const OccupancyMap& map, const Eigen::Vector2d& p) {
  int index;
  if (!map.IndexOf(p, &index)) return -1e9;
  if (map.StateOf(index) != OccupancyMap::State::kFree) return -1e6;
  return std::min(map.ObstacleDistanceMm(index), map.UnknownDistanceMm(index));
}

bool SweepSafe(const OccupancyMap& map, const BasePose& base, const Velocity& v, double horizon_s, bool start_safe) {
  const double speed = std::abs(v.v_mm_s);
  const int steps = std::max(1, static_cast<int>(std::ceil(std::max(speed * horizon_s / 20.0, horizon_s / 0.05))));
  const double dt = horizon_s / steps;
  BasePose pose = base;
  double previous = Margin(map, base.position());
  auto obstacle_distance = [&](const Eigen::Vector2d& p) {
    int index;
    return map.IndexOf(p, &index) ? map.ObstacleDistanceMm(index) : -1e9;
  };
  double previous_obstacle = obstacle_distance(base.position());
  for (int i = 0; i < steps; ++i) {
    pose = Integrate(pose, v, dt);
    if (start_safe) {
      if (!map.FootprintSafe(pose.position())) return false;
    } else {
      // Leaving an unsafe spot: never closer to what makes it unsafe, and never closer to an obstacle within the
      // footprint's reach (the margin alone may be the unknown floor's, which moving toward an obstacle the base
      // is touching does not change: the toy room's base pushed 9 s against a box it had felt).
      const double m = Margin(map, pose.position()), o = obstacle_distance(pose.position());
      if (m < previous) return false;
      if (o < previous_obstacle && o < map.SafeObstacleDistanceMm()) return false;
      previous = m;
      previous_obstacle = o;
    }
  }
  return true;
}
}  // namespace

Velocity SafeVelocity(const OccupancyMap& map, const BasePose& base, const Velocity& wanted, double horizon_s,
                      bool* limited) {
  *limited = false;
  if (wanted.v_mm_s == 0) return {0, wanted.omega_rad_s};
  const bool start_safe = map.FootprintSafe(base.position());
  for (double scale : {1.0, 0.5, 0.25}) {
    const Velocity v{wanted.v_mm_s * scale, wanted.omega_rad_s};
    if (SweepSafe(map, base, v, horizon_s, start_safe)) {
      *limited = scale < 1.0;
      return v;
    }
  }
  *limited = true;
  return {0, wanted.omega_rad_s};
}

std::vector<Eigen::Vector2d> TrailBack(const std::vector<Eigen::Vector2d>& path, const Eigen::Vector2d& from,
                                       double length_mm, double min_length_mm, double max_gap_mm) {
  std::vector<Eigen::Vector2d> trail{from};
  double length = 0;
  for (auto it = path.rbegin(); it != path.rend() && length < length_mm; ++it) {
    const double step = (*it - trail.back()).norm();
    if (step > max_gap_mm) break;
    if (step < 1) continue;
    length += step;
    trail.push_back(*it);
  }
  // Back and forth over the same floor (a shuttle's legs): the trail ends at its point farthest from `from`.
  size_t farthest = 0;
  for (size_t i = 1; i < trail.size(); ++i)
    if ((trail[i] - from).norm() > (trail[farthest] - from).norm()) farthest = i;
  trail.resize(farthest + 1);
  if (PathLength(trail) < min_length_mm || (trail.back() - from).norm() < 0.5 * min_length_mm) trail.clear();
  return trail;
}

namespace {
// Distance from p to the polyline, and the arc length of its nearest point from the polyline's start.
double DistanceToPolyline(const std::vector<Eigen::Vector2d>& line, const Eigen::Vector2d& p, double* along) {
  double best = (line.front() - p).norm(), s = 0;
  if (along) *along = 0;
  for (size_t i = 1; i < line.size(); ++i) {
    const Eigen::Vector2d a = line[i - 1], ab = line[i] - a;
    const double l2 = ab.squaredNorm();
    const double t = l2 > 0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
    const double d = (a + t * ab - p).norm();
    if (d < best) {
      best = d;
      if (along) *along = s + t * std::sqrt(l2);
    }
    s += std::sqrt(l2);
  }
  return best;
}

Eigen::Vector2d PointAlong(const std::vector<Eigen::Vector2d>& line, double s) {
  for (size_t i = 1; i < line.size(); ++i) {
    const double l = (line[i] - line[i - 1]).norm();
    if (s <= l && l > 0) return line[i - 1] + (line[i] - line[i - 1]) * (s / l);
    s -= l;
  }
  return line.back();
}
}  // namespace

Velocity FollowTrail(const BasePose& base, const std::vector<Eigen::Vector2d>& trail, bool reverse, double speed,
                     double max_omega, bool* reached) {
  *reached = true;
  if (trail.empty()) return {};
  const Eigen::Vector2d p = base.position();
  const double to_end = (trail.back() - p).norm();
  if (to_end <= 40) return {};
  *reached = false;
  double along = 0;
  DistanceToPolyline(trail, p, &along);
  const double total = PathLength(trail);
  const Eigen::Vector2d target = PointAlong(trail, std::min(total, along + 120.0));
  const Eigen::Vector2d d = (target - p).norm() > 1 ? Eigen::Vector2d(target - p) : Eigen::Vector2d(trail.back() - p);
  const double travel_heading = base.theta_rad + (reverse ? M_PI : 0.0);
  const double error = WrapAngle(std::atan2(d.y(), d.x()) - travel_heading);
  Velocity out;
  out.omega_rad_s = std::clamp(kHeadingGain * error, -max_omega, max_omega);
  if (std::abs(error) < 60 * M_PI / 180) {
    const double v = speed * std::cos(error) * std::clamp(std::min(to_end, total - along) / 150.0, 0.3, 1.0);
    out.v_mm_s = reverse ? -v : v;
  }
  return out;
}

bool StaysOnTrail(const std::vector<Eigen::Vector2d>& trail, const BasePose& base, const Velocity& v,
                  double horizon_s, double tolerance_mm) {
  if (trail.empty()) return false;
  const int steps = std::max(1, static_cast<int>(std::ceil(horizon_s / 0.05)));
  BasePose pose = base;
  for (int i = 0; i < steps; ++i) {
    pose = Integrate(pose, v, horizon_s / steps);
    if (DistanceToPolyline(trail, pose.position(), nullptr) > tolerance_mm) return false;
  }
  return true;
}

bool ContactDetector::Update(double commanded_v_mm_s, double heading_rad, const Eigen::Vector2d& odometry_mm,
                             double dt_s, int64_t now_us) {
  const bool driving = std::abs(commanded_v_mm_s) > 20;
  const double moved = (odometry_mm - start_).norm();
  if (!driving || start_us_ < 0 || moved >= 20) {
    start_ = odometry_mm;
    start_us_ = now_us;
    expected_.setZero();
    return false;
  }
  expected_ += commanded_v_mm_s * dt_s * Eigen::Vector2d(std::cos(heading_rad), std::sin(heading_rad));
  const double expected = expected_.norm();
  if (now_us - start_us_ < 1000000 || expected < 20 || moved >= 0.25 * expected) return false;
  expected_mm_ = expected;
  moved_mm_ = moved;
  window_s_ = (now_us - start_us_) * 1e-6;
  start_ = odometry_mm;
  start_us_ = now_us;
  expected_.setZero();
  return true;
}

}  // namespace objscan

#include "processes/planner/toy_world.h"

#include <algorithm>
#include <cmath>

#include "processes/planner/motion.h"

namespace objscan {
namespace toy {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kDt = 1.0 / 30.0;
constexpr double kHeadBias = 0.5 * kDeg;
constexpr double kFootprint = 200;

Eigen::Matrix3d Yaw(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix(); }

// True when the segment a -> b (t in [0, t_end]) enters the solid.
bool SegmentHits(const Solid& s, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double t_end) {
  if (s.kind == Solid::kBox) {
    const Eigen::Vector3d c(s.centre_mm.x(), s.centre_mm.y(), 0.5 * s.size_mm.z());
    const Eigen::Matrix3d r = Yaw(s.yaw_rad).transpose();
    const Eigen::Vector3d p = r * (a - c), q = r * (b - c), half = 0.5 * s.size_mm;
    double t0 = 0, t1 = t_end;
    for (int k = 0; k < 3; ++k) {
      const double d = q[k] - p[k];
      if (std::abs(d) < 1e-12) {
        if (std::abs(p[k]) > half[k]) return false;
        continue;
      }
      double ta = (-half[k] - p[k]) / d, tb = (half[k] - p[k]) / d;
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      if (t0 > t1) return false;
    }
    return true;
  }
  const double radius = 0.5 * s.size_mm.x();
  const Eigen::Vector2d p = a.head<2>() - s.centre_mm, d = (b - a).head<2>();
  double t0 = 0, t1 = t_end;
  const double qa = d.squaredNorm(), qb = 2 * p.dot(d), qc = p.squaredNorm() - radius * radius;
  if (qa < 1e-12) {
    if (qc > 0) return false;
  } else {
    const double disc = qb * qb - 4 * qa * qc;
    if (disc < 0) return false;
    const double sq = std::sqrt(disc);
    t0 = std::max(t0, (-qb - sq) / (2 * qa));
    t1 = std::min(t1, (-qb + sq) / (2 * qa));
    if (t0 > t1) return false;
  }
  const double dz = b.z() - a.z();
  if (std::abs(dz) < 1e-12) return a.z() >= 0 && a.z() <= s.size_mm.z();
  double za = (0 - a.z()) / dz, zb = (s.size_mm.z() - a.z()) / dz;
  if (za > zb) std::swap(za, zb);
  return std::max(t0, za) <= std::min(t1, zb);
}

// Signed distance (mm) from a floor point to the solid's footprint (negative inside).
double FootprintDistance(const Solid& s, const Eigen::Vector2d& p) {
  if (s.kind == Solid::kCylinder) return (p - s.centre_mm).norm() - 0.5 * s.size_mm.x();
  const Eigen::Vector2d q = Yaw(-s.yaw_rad).topLeftCorner<2, 2>() * (p - s.centre_mm);
  const Eigen::Vector2d d = q.cwiseAbs() - 0.5 * s.size_mm.head<2>();
  return d.cwiseMax(0.0).norm() + std::min(std::max(d.x(), d.y()), 0.0);
}

// Surface points of a solid (no bottom) at `spacing`; edges only for untextured solids.
void SampleSurface(const Solid& s, double spacing, bool edges_only, std::vector<Eigen::Vector3d>* positions,
                   std::vector<Eigen::Vector3d>* normals) {
  const Eigen::Matrix3d r = Yaw(s.yaw_rad);
  const Eigen::Vector3d base(s.centre_mm.x(), s.centre_mm.y(), 0);
  auto add = [&](const Eigen::Vector3d& local, const Eigen::Vector3d& n) {
    positions->push_back(base + r * local);
    normals->push_back(r * n);
  };
  const double h = s.size_mm.z();
  if (s.kind == Solid::kCylinder) {
    const double radius = 0.5 * s.size_mm.x();
    const int around = std::max(8, static_cast<int>(2 * M_PI * radius / spacing));
    for (int i = 0; i < around; ++i) {
      const double a = 2 * M_PI * i / around;
      const Eigen::Vector3d n(std::cos(a), std::sin(a), 0);
      if (edges_only) {
        add(Eigen::Vector3d(radius * n.x(), radius * n.y(), h), n);
        continue;
      }
      for (double z = 0.5 * spacing; z < h; z += spacing) add(Eigen::Vector3d(radius * n.x(), radius * n.y(), z), n);
    }
    if (!edges_only)
      for (double rr = 0.5 * spacing; rr < radius; rr += spacing)
        for (int i = 0; i < std::max(1, static_cast<int>(2 * M_PI * rr / spacing)); ++i) {
          const double a = 2 * M_PI * i / std::max(1, static_cast<int>(2 * M_PI * rr / spacing));
          add(Eigen::Vector3d(rr * std::cos(a), rr * std::sin(a), h), Eigen::Vector3d::UnitZ());
        }
    return;
  }
  const Eigen::Vector3d half = 0.5 * s.size_mm;
  if (edges_only) {
    for (int sx = -1; sx <= 1; sx += 2)
      for (int sy = -1; sy <= 1; sy += 2)
        for (double z = 0.5 * spacing; z <= h; z += spacing)
          add(Eigen::Vector3d(sx * half.x(), sy * half.y(), z), Eigen::Vector3d(sx, sy, 0).normalized());
    return;
  }
  for (double x = -half.x() + 0.5 * spacing; x < half.x(); x += spacing)
    for (double y = -half.y() + 0.5 * spacing; y < half.y(); y += spacing)
      add(Eigen::Vector3d(x, y, h), Eigen::Vector3d::UnitZ());
  for (double z = 0.5 * spacing; z < h; z += spacing) {
    for (double x = -half.x() + 0.5 * spacing; x < half.x(); x += spacing) {
      add(Eigen::Vector3d(x, half.y(), z), Eigen::Vector3d::UnitY());
      add(Eigen::Vector3d(x, -half.y(), z), -Eigen::Vector3d::UnitY());
    }
    for (double y = -half.y() + 0.5 * spacing; y < half.y(); y += spacing) {
      add(Eigen::Vector3d(half.x(), y, z), Eigen::Vector3d::UnitX());
      add(Eigen::Vector3d(-half.x(), y, z), -Eigen::Vector3d::UnitX());
    }
  }
}

}  // namespace

void AddWalls(Room* room, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  room->min_mm = lo;
  room->max_mm = hi;
  const double t = 100, h = 1200;
  const double w = hi.x() - lo.x() + 2 * t, d = hi.y() - lo.y() + 2 * t;
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  auto wall = [&](const char* name, Eigen::Vector2d c, double sx, double sy) {
    Solid s;
    s.name = name;
    s.centre_mm = c;
    s.size_mm = Eigen::Vector3d(sx, sy, h);
    room->solids.push_back(s);
  };
  wall("wall_west", {lo.x() - t / 2, mid.y()}, t, d);
  wall("wall_east", {hi.x() + t / 2, mid.y()}, t, d);
  wall("wall_south", {mid.x(), lo.y() - t / 2}, w, t);
  wall("wall_north", {mid.x(), hi.y() + t / 2}, w, t);
}

Room MakeLivingRoom(bool with_target) {
  Room room;
  AddWalls(&room, {-5200, -1800}, {1800, 3200});
  auto add = [&](const char* name, Solid::Kind kind, Eigen::Vector2d c, Eigen::Vector3d size, double yaw_deg) {
    Solid s;
    s.name = name;
    s.kind = kind;
    s.centre_mm = c;
    s.size_mm = size;
    s.yaw_rad = yaw_deg * kDeg;
    room.solids.push_back(s);
    return &room.solids.back();
  };
  if (with_target) add("target", Solid::kBox, {-3800, 1600}, {160, 140, 100}, 20)->is_target = true;
  add("table", Solid::kBox, {-1800, 1200}, {800, 600, 700}, 0);
  add("pillar", Solid::kCylinder, {-600, 1800}, {300, 300, 1500}, 0);
  add("crate", Solid::kBox, {-3500, -800}, {300, 300, 300}, 30);
  add("rug", Solid::kBox, {-2000, -600}, {1200, 800, 5}, 0)->drivable = true;
  add("plain_can", Solid::kCylinder, {800, 1500}, {120, 120, 100}, 0)->textured = false;
  return room;
}

ToyWorld::ToyWorld(const Room& room, const RobotGeometry& robot, uint64_t seed) : room_(room), robot_(robot) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 3.0);
  for (int i = 0; i < static_cast<int>(room_.solids.size()); ++i) {
    const Solid& s = room_.solids[i];
    if (s.is_target) target_index_ = i;
    std::vector<Eigen::Vector3d> positions, normals;
    const bool wall = s.name.rfind("wall", 0) == 0;
    if (!s.invisible) SampleSurface(s, s.drivable ? 100 : (wall ? 80 : 60), !s.textured, &positions, &normals);
    for (size_t k = 0; k < positions.size(); ++k) points_.emplace_back(positions[k], normals[k], i);
    if (s.is_target) {
      positions.clear();
      normals.clear();
      SampleSurface(s, 10, false, &positions, &normals);
      for (size_t k = 0; k < positions.size(); ++k) target_samples_.emplace_back(positions[k], normals[k], i);
    }
  }
  for (double x = room_.min_mm.x() + 50; x < room_.max_mm.x(); x += 100)
    for (double y = room_.min_mm.y() + 50; y < room_.max_mm.y(); y += 100) {
      bool inside = false;
      for (const Solid& s : room_.solids) inside = inside || FootprintDistance(s, {x, y}) < 20;
      if (!inside) points_.emplace_back(Eigen::Vector3d(x, y, 0), Eigen::Vector3d::UnitZ(), -1);
    }
  for (Point& p : points_)
    p.noisy = (p.position + Eigen::Vector3d(noise(rng), noise(rng), noise(rng))).cast<float>();
}

Eigen::Isometry3d ToyWorld::WorldFromCamera() const { return objscan::WorldFromCamera(robot_, base_, pan_, tilt_); }

OdometryReading ToyWorld::Odometry() const {
  OdometryReading r;
  r.utime = utime() + 15000;
  r.seq = seq_;
  r.x_mm = odometry_.x_mm;
  r.y_mm = odometry_.y_mm;
  r.theta_rad = odometry_.theta_rad;
  r.pan_rad = pan_ + kHeadBias;
  r.tilt_rad = tilt_ + kHeadBias;
  return r;
}

CameraPoseEstimate ToyWorld::CameraPose() const {
  CameraPoseEstimate p;
  p.utime = utime();
  p.seq = seq_;
  p.world_from_camera = WorldFromCamera();
  p.status = PoseStatus::kTracking;
  p.scale_source = ScaleSource::kOdometry;
  return p;
}

bool ToyWorld::Hidden(const Eigen::Vector3d& from, const Eigen::Vector3d& to, int except) const {
  const double length = (to - from).norm();
  const double t_end = length > 4 ? 1 - 2 / length : 1;
  for (int i = 0; i < static_cast<int>(room_.solids.size()); ++i)
    if (i != except && SegmentHits(room_.solids[i], from, to, t_end)) return true;
  return false;
}

bool ToyWorld::Visible(const Eigen::Isometry3d& camera_from_world, const Eigen::Vector3d& camera, const Point& p,
                       double range, double margin, double max_incidence_cos) const {
  const Eigen::Vector3d d = camera - p.position;
  const double distance = d.norm();
  if (distance > range || p.normal.dot(d) < max_incidence_cos * distance) return false;
  double u, v;
  if (!camera_.Project(camera_from_world * p.position, &u, &v) || !camera_.InImage(u, v, margin)) return false;
  return !Hidden(camera, p.position, p.solid);
}

bool ToyWorld::Landmarks(std::vector<MapLandmark>* landmarks) {
  if (seq_ % 6 != 0) return false;
  if (force_restart_at_ >= 0 && seq_ >= force_restart_at_) {
    force_restart_at_ = -1;
    map_.clear();
    // The finder's clusters were the old map's landmarks: a target not confirmed yet is forgotten, and found again
    // only once the new map has points on it (kRefindFrames in view).
    if (!confirmed_) {
      places_.clear();
      refind_frames_left_ = kRefindFrames;
    }
    for (Point& p : points_) {
      p.sightings = 0;
      p.last_camera = Eigen::Vector3d::Constant(1e9);
    }
  }
  const Eigen::Isometry3d world_from_camera = WorldFromCamera();
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  const Eigen::Vector3d camera = world_from_camera.translation();
  for (Point& p : points_) {
    if (p.sightings >= 2 || !Visible(camera_from_world, camera, p, 3000, 5, 0.1)) continue;
    if ((camera - p.last_camera).norm() < 30) continue;
    p.last_camera = camera;
    if (++p.sightings == 2) map_.push_back({p.noisy, 2, 0.5f});
  }
  *landmarks = map_;
  return true;
}

TargetObservation ToyWorld::FindTarget() {
  TargetObservation o;
  o.utime = utime();
  o.seq = seq_;
  if (target_index_ < 0 || (force_dropped_from_ >= 0 && seq_ >= force_dropped_from_)) return o;
  const Solid& t = room_.solids[target_index_];
  const Eigen::Vector3d centre = TargetCentre();
  o.centre_mm = centre + Eigen::Vector3d(8, -6, 4);
  o.size_mm = t.size_mm;
  o.yaw_rad = t.yaw_rad;
  const Eigen::Isometry3d world_from_camera = WorldFromCamera();
  const Eigen::Vector3d camera = world_from_camera.translation();
  double u, v;
  const bool in_view = (camera - centre).norm() <= 3000 &&
                       camera_.Project(world_from_camera.inverse() * centre, &u, &v) && camera_.InImage(u, v, 20) &&
                       !Hidden(camera, centre, target_index_);
  if (in_view && refind_frames_left_ > 0) {
    --refind_frames_left_;
  } else if (in_view) {
    last_in_view_ = seq_;
    bool known = false;
    // distinct views as the object finder counts them (min_view_baseline_mm)
    for (const Eigen::Vector2d& p : places_) known = known || (p - base_.position()).norm() < 150;
    if (!known) places_.push_back(base_.position());
  }
  if (static_cast<int>(places_.size()) >= places_to_confirm_) confirmed_ = true;
  o.state = places_.empty() ? TargetState::kSearching
                            : (confirmed_ ? TargetState::kConfirmed : TargetState::kCandidate);
  if (confirmed_ && seq_ - last_in_view_ > 45) o.state = TargetState::kLost;
  if (seq_ >= force_lost_from_ && seq_ < force_lost_to_) o.state = TargetState::kLost;
  o.confidence = o.state == TargetState::kConfirmed ? 0.9 : 0.4;
  return o;
}

bool ToyWorld::DenseModel(VoxelCloud* voxels) {
  if (target_index_ < 0 || seq_ % 6 != 0) return false;
  const Eigen::Isometry3d world_from_camera = WorldFromCamera();
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  const Eigen::Vector3d camera = world_from_camera.translation();
  for (Point& p : target_samples_) {
    if (p.sightings >= 2 || !Visible(camera_from_world, camera, p, 2000, 10, 0.5)) continue;
    if ((camera - p.last_camera).norm() < 20) continue;
    p.last_camera = camera;
    ++p.sightings;
  }
  if (seq_ % 30 != 0) return false;
  voxels->voxel_size_mm = 10;
  voxels->centres_mm.clear();
  for (const Point& p : target_samples_)
    if (p.sightings >= 2) voxels->centres_mm.push_back(p.position);
  return true;
}

Eigen::Vector3d ToyWorld::TargetCentre() const {
  if (target_index_ < 0) return Eigen::Vector3d::Zero();
  const Solid& t = room_.solids[target_index_];
  return Eigen::Vector3d(t.centre_mm.x(), t.centre_mm.y(), 0.5 * t.size_mm.z());
}

double ToyWorld::Clearance(const Eigen::Vector2d& p) const {
  double best = 1e9;
  for (const Solid& s : room_.solids)
    if (!s.drivable) best = std::min(best, FootprintDistance(s, p) - kFootprint);
  return best;
}

void ToyWorld::Advance(const PlannerCommand& command) {
  const PlannerCommand held = held_;
  held_ = command;
  Velocity v;
  if (!held.stop) {
    v.v_mm_s = std::clamp(held.v_mm_s, -400.0, 400.0);
    v.omega_rad_s = std::clamp(held.omega_rad_s, -M_PI / 2, M_PI / 2);
  }
  const BasePose before = base_;
  const BasePose next = Integrate(base_, v, kDt);
  if (Clearance(next.position()) < 0 && Clearance(next.position()) < Clearance(base_.position())) {
    ++collisions_;  // the simulator stops the base instead of driving into a solid
  } else {
    base_ = next;
  }
  const BasePose step = Between(before, base_);
  const double distance = std::hypot(step.x_mm, step.y_mm);
  odometry_ = Compose(odometry_, {1.02 * step.x_mm, 1.02 * step.y_mm,
                                  1.01 * step.theta_rad + 0.5 * kDeg / 1000 * distance});
  if (!held.stop) {
    const double max_step = 2.0 * kDt;
    pan_ += std::clamp(WrapAngle(held.pan_rad - kHeadBias - pan_), -max_step, max_step);
    tilt_ += std::clamp(held.tilt_rad - kHeadBias - tilt_, -max_step, max_step);
  }
  ++seq_;
}

}  // namespace toy
}  // namespace objscan

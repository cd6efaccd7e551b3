// Test support (tests and benchmark only): a synthetic sparse map of a room with known truth, no rendering.
// Surfaces are sampled as landmarks (fixed per-point noise) in the floor frame (z = height above the floor), then
// placed in world by world_from_floor (identity = level floor at z = 0). Observe() plays one keyframe: every
// landmark whose point is in front of the camera, inside the image, within max_range_mm and on a surface facing the
// camera gains 3 observations (first sighting: enters the map with 3) — the map the pose solver would publish.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "processes/object_finder/object_finder.h"

namespace objscan {
namespace testing_support {

class SyntheticRoom {
 public:
  struct Object {
    std::string name;
    int only_update = -1;  // >= 0: observed in that update (Observe call index) only
    bool hidden = false;   // not observed while set (occluded, removed)
    double error_px = 0.5;  // px, reprojection error of its landmarks (outline points of an untextured object: high)
  };

  explicit SyntheticRoom(uint32_t seed = 7) : rng_(seed) {
    camera_.width = 640;
    camera_.height = 480;
    camera_.fx = camera_.fy = 800;
    camera_.cx = 319.5;
    camera_.cy = 239.5;
  }

  Eigen::Isometry3d world_from_floor = Eigen::Isometry3d::Identity();
  double max_range_mm = 4500;
  double noise_mm = 1.0;  // per-point position noise (sigma, each axis)
  // Fraction of the already-mapped points in view that gain observations in Observe (the others' tracks ended: KLT
  // ids never come back, so a surface seen again after the camera looked away is mostly new landmarks).
  double refresh_fraction = 1.0;

  const FinderCamera& camera() const { return camera_; }
  Object& object(int index) { return objects_[index]; }
  int num_landmarks() const { return static_cast<int>(points_.size()); }
  Eigen::Vector3d World(const Eigen::Vector3d& floor_point) const { return world_from_floor * floor_point; }

  // Floor points uniform over [-half, half]^2 with height noise (sigma).
  int AddFloor(double half_extent_mm, int count, double height_noise_mm) {
    const int id = NewObject("floor");
    std::uniform_real_distribution<double> u(-half_extent_mm, half_extent_mm);
    std::normal_distribution<double> z(0.0, height_noise_mm);
    for (int i = 0; i < count; ++i)
      Add(Eigen::Vector3d(u(rng_), u(rng_), z(rng_)), Eigen::Vector3d::UnitZ(), id, false);
    return id;
  }
  // A box standing on the floor: four sides and the top, density landmarks per 100 cm^2.
  int AddBox(const std::string& name, const Eigen::Vector2d& centre, const Eigen::Vector3d& size, double yaw_rad,
             double density) {
    const int id = NewObject(name);
    const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d c(centre.x(), centre.y(), 0.5 * size.z());
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    for (int axis = 0; axis < 3; ++axis)
      for (int side = -1; side <= 1; side += 2) {
        if (axis == 2 && side < 0) continue;  // bottom lies on the floor
        const int a = (axis + 1) % 3, b = (axis + 2) % 3;
        const int count = static_cast<int>(std::lround(size[a] * size[b] / 10000.0 * density));
        for (int i = 0; i < count; ++i) {
          Eigen::Vector3d local;
          local[axis] = 0.5 * side * size[axis];
          local[a] = u(rng_) * size[a];
          local[b] = u(rng_) * size[b];
          Add(c + r * local, r * (side * Eigen::Vector3d::Unit(axis)), id);
        }
      }
    return id;
  }
  // A sphere resting on the floor (points below min_height_mm are hidden by the floor contact).
  int AddSphere(const std::string& name, const Eigen::Vector2d& centre, double diameter, double density,
                double min_height_mm = 12) {
    const int id = NewObject(name);
    const double radius = 0.5 * diameter;
    const int count = static_cast<int>(std::lround(M_PI * diameter * diameter / 10000.0 * density));
    std::normal_distribution<double> g(0, 1);
    for (int i = 0; i < count; ++i) {
      const Eigen::Vector3d n = Eigen::Vector3d(g(rng_), g(rng_), g(rng_)).normalized();
      const Eigen::Vector3d p = Eigen::Vector3d(centre.x(), centre.y(), radius) + radius * n;
      if (p.z() >= min_height_mm) Add(p, n, id);
    }
    return id;
  }
  // A vertical cylinder (side and top) standing on the floor.
  int AddCylinder(const std::string& name, const Eigen::Vector2d& centre, double radius, double height,
                  double density) {
    const int id = NewObject(name);
    std::uniform_real_distribution<double> u(0, 1);
    const int side = static_cast<int>(std::lround(2 * M_PI * radius * height / 10000.0 * density));
    for (int i = 0; i < side; ++i) {
      const double a = 2 * M_PI * u(rng_);
      const Eigen::Vector3d n(std::cos(a), std::sin(a), 0);
      Add(Eigen::Vector3d(centre.x(), centre.y(), u(rng_) * height) + radius * n, n, id);
    }
    const int top = static_cast<int>(std::lround(M_PI * radius * radius / 10000.0 * density));
    for (int i = 0; i < top; ++i) {
      const double a = 2 * M_PI * u(rng_), r = radius * std::sqrt(u(rng_));
      Add(Eigen::Vector3d(centre.x() + r * std::cos(a), centre.y() + r * std::sin(a), height), Eigen::Vector3d::UnitZ(),
          id);
    }
    return id;
  }
  // A thin vertical wall from a to b (both faces textured).
  int AddWall(const std::string& name, const Eigen::Vector2d& a, const Eigen::Vector2d& b, double height,
              double density) {
    const int id = NewObject(name);
    const Eigen::Vector2d d = b - a;
    const Eigen::Vector3d n(-d.y() / d.norm(), d.x() / d.norm(), 0);
    const int count = static_cast<int>(std::lround(d.norm() * height / 10000.0 * density));
    std::uniform_real_distribution<double> u(0, 1);
    for (int face = -1; face <= 1; face += 2)
      for (int i = 0; i < count; ++i) {
        const Eigen::Vector2d p = a + u(rng_) * d;
        Add(Eigen::Vector3d(p.x(), p.y(), u(rng_) * height) + face * 5.0 * n, face * n, id);
      }
    return id;
  }
  // Low clutter on the floor in a ring around a point (the noisy landmarks where an object meets the floor, crumbs),
  // heights uniform in [min_z, max_z], seen from anywhere.
  int AddClutter(const Eigen::Vector2d& centre, double min_radius_mm, double max_radius_mm, int count, double min_z,
                 double max_z) {
    const int id = NewObject("clutter");
    std::uniform_real_distribution<double> r(min_radius_mm, max_radius_mm), a(0, 2 * M_PI), z(min_z, max_z);
    for (int i = 0; i < count; ++i) {
      const double rr = r(rng_), aa = a(rng_);
      Add(Eigen::Vector3d(centre.x() + rr * std::cos(aa), centre.y() + rr * std::sin(aa), z(rng_)),
          Eigen::Vector3d::Zero(), id);
    }
    return id;
  }
  // Isolated points (each at least min_separation_mm from every other landmark above the floor), seen from anywhere.
  int AddPhantoms(int count, double half_extent_mm, double min_z, double max_z, double min_separation_mm = 250) {
    const int id = NewObject("phantoms");
    std::uniform_real_distribution<double> u(-half_extent_mm, half_extent_mm), z(min_z, max_z);
    for (int added = 0, tries = 0; added < count && tries < 100 * count; ++tries) {
      const Eigen::Vector3d p(u(rng_), u(rng_), z(rng_));
      bool isolated = true;
      for (const auto& q : points_)
        if (q.object != floor_object_ && (q.truth - p).norm() < min_separation_mm) isolated = false;
      if (!isolated) continue;
      Add(p, Eigen::Vector3d::Zero(), id);
      ++added;
    }
    return id;
  }

  // One keyframe seen from world_from_camera (world frame): updates the observation counts, returns the map.
  FinderInput Observe(const Eigen::Isometry3d& world_from_camera, int64_t seq, bool with_robot_position = true) {
    const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
    const Eigen::Vector3d eye = world_from_camera.translation();
    for (size_t i = 0; i < points_.size(); ++i) {
      const Point& pt = points_[i];
      const Object& o = objects_[pt.object];
      if (o.hidden || (o.only_update >= 0 && o.only_update != updates_)) continue;
      const Eigen::Vector3d w = World(pt.truth);
      const Eigen::Vector3d c = camera_from_world * w;
      if (!(c.z() > 10) || c.norm() > max_range_mm) continue;
      const double u = camera_.fx * c.x() / c.z() + camera_.cx, v = camera_.fy * c.y() / c.z() + camera_.cy;
      if (u < -0.5 || v < -0.5 || u > camera_.width - 0.5 || v > camera_.height - 0.5) continue;
      if (!pt.normal.isZero() && (world_from_floor.linear() * pt.normal).dot(eye - w) <= 0) continue;
      if (counts_[i] > 0 && static_cast<double>(i % 100) >= 100 * refresh_fraction) continue;
      counts_[i] += 3;
    }
    ++updates_;
    FinderInput in;
    in.seq = seq;
    in.utime = seq * 100000;
    in.world_from_camera = world_from_camera;
    in.camera = camera_;
    in.has_robot_position = with_robot_position;
    in.robot_xy_mm = eye.head<2>();
    for (size_t i = 0; i < points_.size(); ++i) {
      if (counts_[i] == 0) continue;
      MapLandmark l;
      l.id = 1000 + static_cast<int64_t>(i);
      l.position_mm = World(points_[i].truth + points_[i].noise);
      l.num_observations = counts_[i];
      l.reprojection_error_px = objects_[points_[i].object].error_px;
      in.landmarks.push_back(l);
    }
    return in;
  }

  // Camera at eye looking at target (both in the floor frame), image x to the right, returned in world.
  Eigen::Isometry3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) const {
    const Eigen::Vector3d z = (target - eye).normalized();
    const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();  // right
    const Eigen::Vector3d y = z.cross(x);                                      // down
    Eigen::Isometry3d floor_from_camera = Eigen::Isometry3d::Identity();
    floor_from_camera.linear() << x, y, z;
    floor_from_camera.translation() = eye;
    return world_from_floor * floor_from_camera;
  }
  // The robot's camera on a circle about centre (floor frame), at angle_deg, 400 mm high, looking at look_at.
  Eigen::Isometry3d OnCircle(const Eigen::Vector2d& centre, double radius, double angle_deg,
                             const Eigen::Vector3d& look_at) const {
    const double a = angle_deg * M_PI / 180.0;
    return LookAt(Eigen::Vector3d(centre.x() + radius * std::cos(a), centre.y() + radius * std::sin(a), 400.0),
                  look_at);
  }

 private:
  struct Point {
    Eigen::Vector3d truth;   // floor frame
    Eigen::Vector3d normal;  // floor frame; zero: visible from everywhere
    Eigen::Vector3d noise;
    int object;
  };
  int NewObject(const std::string& name) {
    objects_.push_back(Object{name});
    if (name == "floor") floor_object_ = static_cast<int>(objects_.size()) - 1;
    return static_cast<int>(objects_.size()) - 1;
  }
  void Add(const Eigen::Vector3d& p, const Eigen::Vector3d& normal, int object, bool noisy = true) {
    std::normal_distribution<double> g(0.0, noise_mm);
    const Eigen::Vector3d noise = noisy ? Eigen::Vector3d(g(rng_), g(rng_), g(rng_)) : Eigen::Vector3d::Zero();
    points_.push_back(Point{p, normal, noise, object});
    counts_.push_back(0);
  }

  std::mt19937 rng_;
  FinderCamera camera_;
  std::vector<Object> objects_;
  std::vector<Point> points_;
  std::vector<int> counts_;
  int floor_object_ = -1;
  int updates_ = 0;
};

}  // namespace testing_support
}  // namespace objscan

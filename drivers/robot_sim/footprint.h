// Collision geometry of the simulated robot's base (LCM-free): the base is a circle of a given radius on the floor,
// the scene's objects are their floor footprints, and a base step that would make the circle overlap one is refused.
// World frame: z up, floor z = 0, lengths in mm, angles in rad.
//
// Floor footprints (FloorObstacles): box = its yawed rectangle, cylinder = its circle, sphere = the circle of its
// radius, mesh = the convex hull of its placed vertices projected on the floor. Objects whose top is lower than
// kDrivableHeightMm (rugs, mats) are driven over and never collide; the floor never collides. Heights otherwise do
// not matter (the base cannot pass under anything).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "drivers/robot_sim/scene.h"

namespace objscan {

constexpr double kDrivableHeightMm = 20;  // mm, objects lower than this are driven over

struct FloorObstacle {
  int object_id = -1;  // index in Scene::objects
  std::string name;
  bool is_circle = false;
  Eigen::Vector2d center_mm = Eigen::Vector2d::Zero();  // circles: centre (world x, y)
  double radius_mm = 0;                                 // circles
  std::vector<Eigen::Vector2d> polygon_mm;              // otherwise: convex, counter-clockwise, >= 3 vertices

  // Signed distance (mm) from a floor point to the footprint: > 0 outside, < 0 inside (minus the depth).
  double SignedDistance(const Eigen::Vector2d& point) const;
  // True when the segment a-b touches the footprint.
  bool IntersectsSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const;
};

// The footprints of every object the base can hit (file order), see the header comment.
std::vector<FloorObstacle> FloorObstacles(const Scene& scene);

// Convex hull (counter-clockwise, no collinear points) of floor points; fewer than 3 distinct points come back as
// they are (deduplicated).
std::vector<Eigen::Vector2d> ConvexHull(std::vector<Eigen::Vector2d> points);

class FootprintChecker {
 public:
  // radius_mm: the base circle's radius (> 0, finite; throws std::invalid_argument otherwise).
  FootprintChecker(const Scene& scene, double radius_mm);

  // Clearance (mm) between the base circle centred at base_xy and the nearest footprint: < 0 = overlap. +infinity
  // when the scene has no obstacle. *object_id (if given) = that footprint's object, -1 when none.
  double Clearance(const Eigen::Vector2d& base_xy, int* object_id = nullptr) const;
  bool Overlaps(const Eigen::Vector2d& base_xy, int* object_id = nullptr) const {
    return Clearance(base_xy, object_id) < 0;
  }
  // Whether a base step from (x, y, theta) along a constant-curvature arc of signed length distance_mm turning by
  // dtheta_rad must be refused: some point of the arc (checked every <= 5 mm, end included) overlaps a footprint
  // and is closer to it than the start (so a base that starts overlapping may still back out). *object_id = the
  // footprint hit (-1 when the step is free).
  bool StepBlocked(double x_mm, double y_mm, double theta_rad, double distance_mm, double dtheta_rad,
                   int* object_id = nullptr) const;

  double radius_mm() const { return radius_mm_; }
  const std::vector<FloorObstacle>& obstacles() const { return obstacles_; }

 private:
  double radius_mm_;
  std::vector<FloorObstacle> obstacles_;
};

// Counts contact episodes frame by frame: a collision is an entry into contact, however many frames it lasts.
//   kBlocked  this frame is in contact (command mode: its base step was refused; orbit mode: its footprint overlaps)
//   kFree     the base moved (or stands) without contact: an episode ends
//   kIdle     the base did not try to move: contact state unchanged (a robot standing against a wall, turning in
//             place or pausing, is still in the same episode)
class ContactCounter {
 public:
  enum class Frame { kFree, kBlocked, kIdle };
  // Returns true when this frame starts a new collision.
  bool Record(Frame frame);
  int64_t collisions() const { return collisions_; }
  int64_t blocked_frames() const { return blocked_frames_; }
  bool in_contact() const { return in_contact_; }

 private:
  int64_t collisions_ = 0;
  int64_t blocked_frames_ = 0;
  bool in_contact_ = false;
};

}  // namespace objscan

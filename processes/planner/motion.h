// Motion primitives of the planner, LCM-free: a path follower (pure pursuit), a circle follower (tangential driving
// around a centre), the swept-footprint check, and the head's rate limits.
// Units: mm, rad, s. Velocities: v_mm_s forward (negative: backing up, which only the planner's look-around shuttle
// does, over floor it came from), omega_rad_s counter-clockwise.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "processes/planner/occupancy_map.h"
#include "processes/planner/planner_geometry.h"

namespace objscan {

struct Velocity {
  double v_mm_s = 0;
  double omega_rad_s = 0;
};

// Pure pursuit along a polyline. The lookahead point is the farthest path point within 350 mm whose straight line
// from the robot crosses only Passable cells (no corner cutting through cells the path avoided). The robot turns in
// place while the lookahead point is more than 50 deg off its heading, slows down over the last 300 mm.
class PathFollower {
 public:
  void SetPath(std::vector<Eigen::Vector2d> path);
  void Clear() { path_.clear(); }
  bool empty() const { return path_.empty(); }
  const std::vector<Eigen::Vector2d>& path() const { return path_; }
  Eigen::Vector2d goal() const { return path_.empty() ? Eigen::Vector2d::Zero() : path_.back(); }
  // Advances along the path and returns the velocity towards the lookahead point (zero when reached).
  Velocity Follow(const OccupancyMap& map, const BasePose& base, double speed_mm_s, double max_omega_rad_s);
  bool Reached(const BasePose& base, double tolerance_mm) const;
  // Point `distance_mm` further along the path from the robot's progress (extrapolated beyond the goal along the
  // last segment's direction, or the robot's heading for a one-point path).
  Eigen::Vector2d PointAhead(const BasePose& base, double distance_mm) const;
  // False when a path point within `distance_mm` ahead of the progress is no longer Passable.
  bool StillFree(const OccupancyMap& map, double distance_mm) const;

 private:
  std::vector<Eigen::Vector2d> path_;
  size_t index_ = 0;  // the path point nearest the robot so far
};

// Circle of radius_mm around centre, counter-clockwise (or clockwise): heading along the tangent, corrected towards
// the circle, yaw rate = feed-forward +-v / radius plus a heading gain. Turns in place when the heading is > 30 deg
// off.
Velocity FollowCircle(const BasePose& base, const Eigen::Vector2d& centre, double radius_mm, double speed_mm_s,
                      double max_omega_rad_s, bool clockwise = false);

// True when every point of the segment a -> b (every 25 mm) lies in a Passable cell.
bool LineOfSight(const OccupancyMap& map, const Eigen::Vector2d& a, const Eigen::Vector2d& b);

// The robot's own trail: positions it drove through (Planner::path(), every 50 mm, world mm). The floor its
// footprint swept there is known free whatever the map says, up to the odometry's drift over the trail's length.
// TrailBack: the trail from `from` back along `path` (its newest point last) until length_mm, ending early at a
// jump of more than max_gap_mm between points (a relocalization), and cut at its point farthest from `from` (a
// trail that went back and forth over the same floor). First point `from`; a trail shorter than min_length_mm, or
// whose end is less than half that from `from`, comes back empty.
std::vector<Eigen::Vector2d> TrailBack(const std::vector<Eigen::Vector2d>& path, const Eigen::Vector2d& from,
                                       double length_mm, double min_length_mm, double max_gap_mm = 150);
// Pure pursuit along a trail towards its last point (lookahead 120 mm beyond the nearest point on it), driving
// forward or backing up (reverse: the base's rear leads, heading kept). Turns in place when the lookahead point is
// more than 60 deg off the direction of travel; slows down over the last 150 mm. *reached (zero velocity) within
// 40 mm of the last point.
Velocity FollowTrail(const BasePose& base, const std::vector<Eigen::Vector2d>& trail, bool reverse,
                     double speed_mm_s, double max_omega_rad_s, bool* reached);
// True when the base keeps within tolerance_mm of the trail (as a polyline) under velocity v for horizon_s.
bool StaysOnTrail(const std::vector<Eigen::Vector2d>& trail, const BasePose& base, const Velocity& v,
                  double horizon_s, double tolerance_mm);

// Integrates a unicycle for dt seconds.
BasePose Integrate(const BasePose& base, const Velocity& velocity, double dt_s);

// The swept-footprint check (forward or backing up): the velocity if the round footprint stays FootprintSafe along the motion over
// horizon_s (checked every 20 mm / 0.05 s), else the same at half and quarter speed, else turning in place (always
// safe for a round footprint). A robot already in an unsafe spot may move when the motion increases its distance to
// obstacles and unknown cells. *limited tells whether the speed was cut.
Velocity SafeVelocity(const OccupancyMap& map, const BasePose& base, const Velocity& wanted, double horizon_s,
                      bool* limited);

// Contact felt through the odometry: a base driven for at least a second whose odometry moved under a quarter of the
// commanded motion (and under 20 mm) stands against something (the simulator stops a base that touches an object, a
// real one stalls or its bumper stops it). The commanded motion is summed as a vector along the base's heading, so
// a leg backed up and driven forward again within the second (the look-around shuttle) expects what the base
// really moved, not the sum of both legs (room_06: "driven 33 mm, moved 5 mm", a contact felt where nothing was,
// boxed the robot in at its start). The window restarts when the base is not driven (|v| <= 20 mm/s), when the
// odometry moved 20 mm, and after a contact.
class ContactDetector {
 public:
  // One step: commanded forward speed (mm/s, negative backing up), the base heading (rad, world), the odometry's
  // base position (mm, odometry frame), the step's duration (s) and time (µs). True when a contact is felt.
  bool Update(double commanded_v_mm_s, double heading_rad, const Eigen::Vector2d& odometry_mm, double dt_s,
              int64_t now_us);
  // Figures of the last contact: commanded motion (mm), odometry motion (mm), window (s).
  double expected_mm() const { return expected_mm_; }
  double moved_mm() const { return moved_mm_; }
  double window_s() const { return window_s_; }

 private:
  Eigen::Vector2d start_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d expected_ = Eigen::Vector2d::Zero();  // mm, summed commanded motion (world directions)
  int64_t start_us_ = -1;
  double expected_mm_ = 0, moved_mm_ = 0, window_s_ = 0;
};

}  // namespace objscan

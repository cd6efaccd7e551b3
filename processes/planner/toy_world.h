// A 2.5-D toy world for the planner's closed-loop tests and benchmark (test support, not part of the library):
// a room of box walls and solids (boxes, vertical cylinders; drivable ones like a rug), a unicycle robot that obeys
// the planner's commands one frame late (as the simulator in lock-step), and fake perception:
//   landmarks   points sampled on the solids' surfaces and the floor; a point joins the (whole, growing) sparse map
//               once it was seen in 2 perception updates from camera positions >= 30 mm apart: in the image, within
//               3 m, facing the camera, not hidden by another solid; positions get seeded N(0, 3 mm) noise.
//               Untextured solids give points on their edges only.
//   target      the finder "sees" the target when its centre is in the image (20 px inside), within 3 m and not
//               hidden; CANDIDATE after 1-2 places (>= 150 mm apart), CONFIRMED from 3 places (SetPlacesToConfirm); a confirmed target
//               out of view for 1.5 s is LOST until seen again. Reported centre = truth + (8, -6, 4) mm.
//   dense model target surface samples (10 mm) seen in 2 updates from >= 20 mm apart at incidence <= 60 deg
//               within 2 m become voxels.
// Odometry: true increments with +2 % distance and +1 % yaw scale errors and 0.5 deg/m drift from the start pose;
// head readings = true angle + 0.5 deg bias (the head servos the reading to the command at <= 2 rad/s).
// The world frame is the robot's start pose (the odometry frame), so the room is given in it. 30 Hz frames.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "common/robot_model.h"
#include "common/sensor_data.h"
#include "processes/planner/coverage.h"
#include "processes/planner/occupancy_map.h"
#include "processes/planner/planner.h"

namespace objscan {
namespace toy {

struct Solid {
  enum Kind { kBox, kCylinder } kind = kBox;
  std::string name;
  Eigen::Vector2d centre_mm = Eigen::Vector2d::Zero();  // on the floor
  Eigen::Vector3d size_mm = Eigen::Vector3d::Zero();    // box extents; cylinder (2r, 2r, height)
  double yaw_rad = 0;
  bool drivable = false;  // a rug: no collision, its top counts as floor
  bool textured = true;   // untextured: landmarks on the edges only
  bool invisible = false; // no landmarks at all (a plain object the sparse map never sees): felt, not seen
  bool is_target = false;
};

struct Room {
  std::vector<Solid> solids;  // walls included
  Eigen::Vector2d min_mm, max_mm;  // inner wall faces
};

// Walls around [min, max] (100 mm thick, 1200 mm high).
void AddWalls(Room* room, const Eigen::Vector2d& min_mm, const Eigen::Vector2d& max_mm);
// A 7 x 5 m room with a 160 x 140 x 100 mm box target 4.1 m behind-left of the start (beyond the finder's 3 m), a table, a
// pillar, a crate, a rug and a small untextured cylinder. Without the target when with_target is false.
Room MakeLivingRoom(bool with_target);

class ToyWorld {
 public:
  ToyWorld(const Room& room, const RobotGeometry& robot, uint64_t seed = 7);

  int64_t seq() const { return seq_; }
  int64_t utime() const { return seq_ * 1000000 / 30; }
  const BasePose& truth() const { return base_; }
  double pan() const { return pan_; }
  double tilt() const { return tilt_; }
  Eigen::Isometry3d WorldFromCamera() const;
  OdometryReading Odometry() const;
  CameraPoseEstimate CameraPose() const;  // the truth, status TRACKING
  // Every 6th frame: true with the whole sparse map so far.
  bool Landmarks(std::vector<MapLandmark>* landmarks);
  TargetObservation FindTarget();
  // Every 30th frame: true with the voxel centres so far.
  bool DenseModel(VoxelCloud* voxels);
  // Applies the command held from the previous frame for one frame period, holds `command` for the next.
  void Advance(const PlannerCommand& command);

  bool has_target() const { return target_index_ >= 0; }
  Eigen::Vector3d TargetCentre() const;
  int collisions() const { return collisions_; }
  // Distance (mm) from the robot's centre to the nearest non-drivable solid's surface, minus the footprint.
  double Clearance(const Eigen::Vector2d& p) const;
  // The finder reports SEARCHING from frame `from_seq` on: it dropped the target it had confirmed.
  void ForceDropped(int64_t from_seq) { force_dropped_from_ = from_seq; }
  // The sparse map restarts at frame `at_seq`, as the pose solver's does after a loss it cannot join: the landmark
  // set starts again from nothing (every point must be seen twice more), and the finder forgets a target it has not
  // confirmed until it has been in view kRefindFrames frames again.
  void ForceMapRestart(int64_t at_seq) { force_restart_at_ = at_seq; }
  // Distinct places the finder needs to confirm the target (default 3; a large value: a candidate never confirmed).
  void SetPlacesToConfirm(int places) { places_to_confirm_ = places; }
  // The finder reports LOST for frames in [from, to) (to test re-finding).
  void ForceLost(int64_t from_seq, int64_t to_seq) {
    force_lost_from_ = from_seq;
    force_lost_to_ = to_seq;
  }

 private:
  struct Point {
    Point(const Eigen::Vector3d& p, const Eigen::Vector3d& n, int s) : position(p), normal(n), solid(s) {}
    Eigen::Vector3d position, normal;
    int solid = -1;  // -1 = floor
    int sightings = 0;
    Eigen::Vector3d last_camera = Eigen::Vector3d::Constant(1e9);
    Eigen::Vector3f noisy = Eigen::Vector3f::Zero();
  };
  bool Visible(const Eigen::Isometry3d& camera_from_world, const Eigen::Vector3d& camera, const Point& p,
               double range_mm, double margin_px, double max_incidence_cos) const;
  bool Hidden(const Eigen::Vector3d& from, const Eigen::Vector3d& to, int except_solid) const;

  Room room_;
  RobotGeometry robot_;
  CameraIntrinsics camera_;
  int target_index_ = -1;
  std::vector<Point> points_, target_samples_;
  std::vector<MapLandmark> map_;
  int64_t seq_ = 0;
  BasePose base_;
  double pan_ = 0, tilt_ = 20 * M_PI / 180;
  PlannerCommand held_;
  BasePose odometry_;
  int collisions_ = 0;
  // target finder
  std::vector<Eigen::Vector2d> places_;
  int64_t last_in_view_ = -1;
  int64_t force_dropped_from_ = -1;
  bool confirmed_ = false;
  int places_to_confirm_ = 3;
  int64_t force_lost_from_ = -1, force_lost_to_ = -1;
  int64_t force_restart_at_ = -1;
  static constexpr int kRefindFrames = 240;  // frames (8 s) in view a forgotten target needs after a map restart
  int refind_frames_left_ = 0;
};

}  // namespace toy
}  // namespace objscan

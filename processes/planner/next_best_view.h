// Next-best-view choice from the coverage model, LCM-free.
// Candidates: the robot on rings of radii_mm around the target centre, every azimuth_step_deg, heading along the ring
// (counter-clockwise tangent), the head aimed either at the target centre or at the centroid of the uncovered
// samples (both tried). A candidate needs its cell and a cell capture_arc_deg along its ring (either way) Traversable,
// its cell reachable in the robot's cost field, and head angles within the limits (tilt clamped). Its gain = the
// uncovered samples its camera would see (the capture arc adds the second view); score = gain / (1 + path cost in
// m). The best score with gain >= min_gain wins. Excluded candidates (ring * 1000 + azimuth index, already used)
// are skipped.
#pragma once

#include <Eigen/Core>
#include <set>
#include <vector>

#include "common/robot_model.h"
#include "processes/planner/coverage.h"
#include "processes/planner/occupancy_map.h"
#include "processes/planner/path_search.h"
#include "processes/planner/planner_geometry.h"

namespace objscan {

// The joints' and the base's limits (the robot's, not preferences).
struct RobotLimits {
  double max_speed_mm_s = 400;                 // mm/s
  double max_reverse_mm_s = 100;               // mm/s, backing up (the look-around shuttle only)
  double max_omega_rad_s = M_PI / 2;           // rad/s
  double max_pan_rad = 170 * M_PI / 180;       // rad, |pan| limit
  double min_tilt_rad = 0;                     // rad (positive = down)
  double max_tilt_rad = 60 * M_PI / 180;       // rad
};

struct NextViewOptions {
  std::vector<double> radii_mm = {500, 650, 800, 1000};  // mm, rings around the target centre
  double azimuth_step_deg = 15;                          // deg
  double capture_arc_deg = 10;                           // deg along the ring after arriving
  int min_gain = 3;                                      // samples a view must add
};

struct ViewCandidate {
  int key = -1;                  // ring index * 1000 + azimuth index
  BasePose base;                 // world
  double pan_rad = 0, tilt_rad = 0;
  double radius_mm = 0, azimuth_rad = 0;
  Eigen::Vector3d aim_mm = Eigen::Vector3d::Zero();
  int gain = 0;                  // uncovered samples seen
  double path_mm = 0;            // cost of the path there (mm)
  double score = 0;
};

struct NextViewResult {
  bool found = false;
  ViewCandidate best;
  int candidates = 0;  // evaluated (reachable, within limits)
};

NextViewResult ChooseNextView(const CoverageModel& coverage, const OccupancyMap& map, const CostField& from_robot,
                              const RobotGeometry& robot, const RobotLimits& limits, const NextViewOptions& options,
                              const std::set<int>& excluded);

}  // namespace objscan

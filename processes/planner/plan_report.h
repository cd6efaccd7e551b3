// plan.json: the planner's record of a run (LCM-free).
//   outcome          "modeled" (FINISH reached) | "partial" (FINISH with coverage under min_coverage) | "no_target"
//                    (NO_TARGET) | "stopped" (the stream ended first)
//   phases           [{name, start_utime, end_utime, seconds}] in order (a running phase ends at end_utime)
//   path_length_mm   estimated path of the base; views = frames with a usable camera pose; frames = poses handled
//   orbit_percent    share of the circle's 1-degree bins driven in ORBIT
//   next_views       [{x, y, pan, tilt, radius, azimuth, gain, coverage_before, coverage_after}] (mm, rad, fractions;
//                    coverage_after -1 when the stream ended before the view was evaluated)
//   coverage         final coverage fraction, coverage_samples its sample count
//   disagreement     max odometry-vs-estimate distance (mm) and heading difference (deg)
//   target           confirmed, centre_mm, size_mm, yaw_rad, confirmed_seq
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "processes/planner/planner.h"

namespace objscan {

// Outcome word for a summary: "modeled", "partial", "no_target" or "stopped".
std::string PlanOutcome(const PlanSummary& summary);
std::string PlanJson(const PlanSummary& summary, int64_t end_utime);
// Writes PlanJson to path; false with *error when the file cannot be written.
bool WritePlanJson(const std::string& path, const PlanSummary& summary, int64_t end_utime, std::string* error);
// The planner's own map as a binary PGM (plan_map.pgm; any image viewer), cropped to the known cells plus 1 m:
// free 255, unknown 128, obstacle 0, free but not traversable for the footprint 200, the robot's path (the given
// positions, world mm) 64. One pixel = one cell; image up = world +y. The header's comment line gives the cell size
// and the world position of the top-left pixel. False with *error when it cannot be written.
bool WritePlanMapPgm(const std::string& path, const OccupancyMap& map, const std::vector<Eigen::Vector2d>& path_mm,
                     std::string* error);

}  // namespace objscan

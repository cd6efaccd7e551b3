// The map's consistency around the target, measured on its floor: a textured flat floor seen from poses that agree
// reconstructs as a thin layer of landmarks; where the passes of a run disagree (an unjoined restart rescaled, a
// drift between the exploration and the orbit) the floor around the target comes out as two or more layers some
// millimetres apart, and the model built from those poses is distorted too. LCM-free.
//
// Measured on the simulator's rooms (final map, the final region's floor; docs/benchmarks.md): the floor's thickness
// (p90 - p10 of the floor landmarks' heights, 150-600 mm from the target) was 1.2-3.4 mm in the 14 runs whose model
// held (mesh p90 0.55-2.3 mm on its own frames) and 5.8-26.5 mm in the 9 runs with a distorted or failed model
// (room_05 three times, room_10 twice, room_04 twice, room_09 once: mesh p90 7.6-30 mm or completeness 1-44 %).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/floor_fit.h"

namespace objscan {

struct FloorThicknessOptions {
  double inner_radius_mm = 150;   // mm, horizontal distance from the centre where the floor ring starts (at least:
                                  // the caller passes the target's half-diagonal when larger)
  double ring_width_mm = 450;     // mm, width of the ring
  double band_mm = 25;            // mm, |height| of a landmark counted as floor
  int min_points = 200;           // fewer floor landmarks in the ring: not measured
  double max_thickness_mm = 5.0;  // mm, thicker = the map is inconsistent around the target
};

struct FloorThickness {
  bool measured = false;  // false: fewer than min_points floor landmarks in the ring
  int points = 0;         // floor landmarks in the ring
  double p10_mm = 0;      // mm, heights above the floor plane (10th, 50th, 90th percentile)
  double p50_mm = 0;
  double p90_mm = 0;
  double inner_radius_mm = 0;  // mm, the ring used
  double thickness_mm() const { return p90_mm - p10_mm; }
};

// Floor landmarks (world, mm; non-finite ones skipped) in the horizontal ring [inner, inner + width] around centre,
// with |floor.Height(x)| <= band_mm (common/floor_fit.h: unit normal pointing up); inner is
// max(options.inner_radius_mm, min_inner_radius_mm). Percentiles by nth_element (deterministic). O(landmarks).
FloorThickness MeasureFloorThickness(const std::vector<Eigen::Vector3d>& landmarks, const Eigen::Vector3d& centre,
                                     const FloorPlane& floor,
                                     double min_inner_radius_mm, const FloorThicknessOptions& options);

}  // namespace objscan

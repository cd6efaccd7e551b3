// The map's consistency around the target, measured on its floor: a textured flat floor seen from poses that agree
// reconstructs as a thin layer of landmarks; where the passes of a run disagree (an unjoined restart rescaled, a
// drift between the exploration and the orbit) the floor around the target comes out as two or more layers some
// millimetres apart, and the model built from those poses is distorted too. LCM-free.
//
// Measured on 25 stored room runs (final map, the final region's floor; docs/benchmarks.md): the floor's thickness
// (p90 - p10 of the floor landmarks' heights, 150-650 mm from the target) was above 5 mm in 11 runs, all with a
// distorted or failed model (5.8-26.5 mm; mesh p90 3-30 mm or completeness 1-79 %), and 1.2-4.7 mm in 14 runs, 12 of
// them with a model that held (2 not caught: a map bent away from the target, an older floor-ring bug).
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

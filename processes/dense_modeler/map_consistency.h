// The map's consistency around the target, measured on its floor: a textured flat floor seen from poses that agree
// reconstructs as a thin layer of landmarks; where the passes of a run disagree (an unjoined restart rescaled, a
// drift between the exploration and the orbit) the floor around the target comes out as two or more layers some
// millimetres apart, and the model built from those poses is distorted too. LCM-free.
//
// Two measures: the ring's thickness (p90 - p10 of all its floor landmarks' heights) and the local thickness (the
// median over 50 mm cells of the same within a cell). Layers from poses that disagree overlap in space: both are thick.
// A real step in the floor (a rug's edge, a threshold) or a slightly tilted floor fit thickens the ring but leaves the
// cells thin. Inconsistent = ring thickness > max_thickness_mm and local thickness > max_local_thickness_mm (the
// ring alone when too few cells hold enough points).
//
// Measured on 27 stored room runs (final map, the final region's floor; docs/benchmarks.md): ring / local thickness
// above 5 / 3.5 mm in 12 runs (5.6-26.7 / 4.45-16.4 mm), all with a distorted or failed model (mesh p90 3-30 mm or
// completeness 1-79 %); at most 4.7 / 4.07 mm in 15 runs, 13 of them with a model that held (2 not caught: a map
// bent away from the target, an older floor-ring bug). Good runs' local thickness: 0.9-2.75 mm, room_08's 4.07 mm.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "common/floor_fit.h"

namespace objscan {

struct FloorThicknessOptions {
  double inner_radius_mm = 150;   // mm, horizontal distance from the centre where the floor ring starts (at least:
                                  // the caller passes the target's half-diagonal when larger)
  double ring_width_mm = 450;     // mm, width of the ring
  double band_mm = 25;            // mm, |height| of a landmark counted as floor
  int min_points = 200;           // fewer floor landmarks in the ring: not measured
  double max_thickness_mm = 5.0;        // mm, ring thicker than this ...
  double max_local_thickness_mm = 3.5;  // mm, ... and cells thicker than this = inconsistent
  double cell_mm = 50;                  // mm, cell side of the local measure
  int min_cell_points = 8;              // floor landmarks a cell needs to count
  int min_cells = 20;                   // fewer counted cells: the local measure is not used
};

struct FloorThickness {
  bool measured = false;  // false: fewer than min_points floor landmarks in the ring
  int points = 0;         // floor landmarks in the ring
  double p10_mm = 0;      // mm, heights above the floor plane (10th, 50th, 90th percentile)
  double p50_mm = 0;
  double p90_mm = 0;
  double inner_radius_mm = 0;  // mm, the ring used
  int cells = 0;                    // cells with min_cell_points (the local measure's sample)
  double local_thickness_mm = -1;   // mm, median over those cells of their p90 - p10; -1 with fewer than min_cells
  double thickness_mm() const { return p90_mm - p10_mm; }
  // measured, thicker than max_thickness_mm, and (local measured) locally thicker than max_local_thickness_mm.
  bool Inconsistent(const FloorThicknessOptions& options) const;
};

// Floor landmarks (world, mm; non-finite ones skipped) in the horizontal ring [inner, inner + width] around centre,
// with |floor.Height(x)| <= band_mm (common/floor_fit.h: unit normal pointing up); inner is
// max(options.inner_radius_mm, min_inner_radius_mm); cells on the world's x, y grid. Percentiles by nth_element
// (deterministic). O(landmarks log landmarks).
FloorThickness MeasureFloorThickness(const std::vector<Eigen::Vector3d>& landmarks, const Eigen::Vector3d& centre,
                                     const FloorPlane& floor,
                                     double min_inner_radius_mm, const FloorThicknessOptions& options);

// One map for the model. A pose solver that restarts after a tracking loss and never joins the new map to the old one
// leaves poses in two frames related by the odometry only, centimetres apart after a long run (pose_t.map_start_seq
// tells them apart); a model voted from pairs in both has double walls (room_02 with next views, 7 Dec: a restart at
// frame 3510 never joined, mesh p90 3.09 mm / 67.4 % against 0.69 mm / 92.0 % for the circle's one map). The final
// phase keeps the pairs of one map.
struct PairFrames {
  int64_t seq_a = 0, seq_b = 0;  // the pair's frames
  int64_t matches = 0;           // its pixel matches (the weight of the pair)
};

struct ModelMapChoice {
  int64_t map_start_seq = -1;    // the map kept (the only one when maps == 1); -1: no pair frame has a known map
  int maps = 0;                  // distinct maps among the frames of pairs with a known map
  std::vector<bool> keep;        // per pair: voted into the model
  int64_t pairs_other_map = 0;   // dropped: both frames in another map
  int64_t pairs_across_maps = 0; // dropped: its two frames in two maps
  int64_t matches_kept = 0;      // matches of the kept pairs
  int64_t matches_dropped = 0;   // matches of the dropped ones
};

// map_of: frame seq -> map_start_seq of its final pose (>= 0); a frame missing from it (no final pose: it keeps its
// live pose) or mapped to a negative value has no known map. Keeps the map whose pairs hold the most matches (ties:
// the later map, where the robot ended) and drops every pair with a frame known to lie in another map (both frames
// in two maps: "across"). A pair of two unknown frames is kept. Deterministic; O(pairs).
ModelMapChoice ChooseModelMap(const std::vector<PairFrames>& pairs,
                              const std::unordered_map<int64_t, int64_t>& map_of);

}  // namespace objscan

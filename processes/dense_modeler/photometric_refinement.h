// Multi-view photometric refinement of the final mesh (LCM-free).
// The mesh comes from votes of image *pairs*; where those votes are weak (a shadowed band, a cap seen only at
// grazing angles, bridged holes) the surface can sit a few millimetres off. All the views that see a place together
// pin it far better than any pair: a point off the surface by d along its normal is seen by each camera on a
// different surface point (displaced towards that camera by ~d x cot(elevation)), so its patches disagree.
// RefineMeshPhotometric moves mesh vertices along their normals to the offset where the views agree best:
//  1. Visibility: the mesh's depth is rendered into every view (at most max_views, evenly spread); a vertex is seen
//     by a view when it faces the camera (normal within acos(min_facing_cos) of the ray), projects into the image and
//     is not hidden by the mesh (mesh_visibility.h's test, depth_tolerance_mm).
//  2. Samples: one vertex per sample_spacing_mm cell (the first in mesh order, deterministic). For each offset d in
//     [-search_mm, +search_mm] (step_mm), a (2 patch_half + 1)^2 grid of points on the vertex's tangent plane,
//     patch_spacing_mm apart, at p + d n is projected into up to views_per_sample of its views (evenly spread along the
//     view order, so the widest spread of directions) and sampled bilinearly in gray; the score is the mean NCC over
//     all pairs of those views' patches. The best offset is refined by a parabola through its neighbours. A sample is
//     kept when its best score is at least min_score, beats the score at d = 0 by at least min_gain or lies within
//     one step of 0, is not at either end of the search, and every view's patch has a gray std-dev of at least
//     min_patch_stddev (textureless patches agree at every offset).
//  3. Every vertex moves by the weighted median of the kept samples' offsets within smoothing_radius_mm whose normals
//     are within acos(min_normal_cos) of its own (weights: score x Gaussian of the distance); vertices with fewer than
//     min_neighbour_samples such samples stay. The displacement field is thus piecewise smooth and a single bad
//     sample moves nothing.
// Views must be gray or BGR 8-bit images described by their camera (full resolution is best: the patches are a few
// pixels wide). Units: mm (world), px. Never throws; views with an invalid camera or a mismatched image are skipped.
// Deterministic (single-threaded, fixed order).
// Measured on the four sim orbits (2 Dec, night; exact distances to the rendered surface, defaults below, full-
// resolution gray views): mesh p90 box 0.377 -> 0.230 mm, cylinder 0.310 -> 0.222, but sphere 0.349 -> 0.373 and blob
// 0.384 -> 0.437, and the max rose on sphere (3.49 -> 4.44) and cylinder (3.61 -> 3.81): the photometric optimum is
// noisier (~0.2 mm) than the voted surface where that is well supported, and weak in the shadowed band where the
// votes are weak too. Stricter gates (texture 4-6, score 0.6-0.7, 6 neighbours) kept the max but also most of the
// gain. Hence off by default (enabled = false); --refine-mesh turns it on.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "processes/dense_modeler/marching_cubes.h"
#include "processes/dense_modeler/space_carving.h"

namespace objscan {

struct PhotometricRefinementOptions {
  bool enabled = false;              // refine at all (false: the mesh is unchanged; see the measurements above)
  int max_views = 60;                // views rendered at most, evenly spread over those given (>= 2)
  double min_facing_cos = 0.15;      // cos of the largest angle between a vertex normal and the ray to the camera
  double depth_tolerance_mm = 3.0;   // mm, a vertex this far behind the rendered surface still counts as seen (> 0)
  int views_per_sample = 10;         // views scored per sample at most (>= 2)
  int min_views = 3;                 // samples seen by fewer views are not refined (>= 2)
  double sample_spacing_mm = 2.0;    // mm, one sample vertex per cell of this size (> 0)
  double search_mm = 3.0;            // mm, half range of the search along the normal (> 0)
  double step_mm = 0.25;             // mm, search step (> 0, <= search_mm)
  int patch_half = 3;                // samples each side of the centre of the tangent-plane patch (1..8)
  double patch_spacing_mm = 1.0;     // mm, spacing of the patch's points (> 0)
  double min_score = 0.5;            // mean pairwise NCC a sample's best offset needs, [-1, 1]
  double min_gain = 0.05;            // NCC units the best offset must gain over d = 0 (unless within a step), >= 0
  double min_patch_stddev = 2.0;     // gray levels, every view's patch needs this much texture (>= 0)
  double smoothing_radius_mm = 4.0;  // mm, kept samples within this distance vote on a vertex's offset (> 0)
  double min_normal_cos = 0.8;       // their normals within acos(this) of the vertex's, [-1, 1)
  int min_neighbour_samples = 3;     // vertices with fewer kept samples around stay where they are (>= 1)
};

bool ValidatePhotometricRefinementOptions(const PhotometricRefinementOptions& options, std::string* why);

struct PhotometricRefinementStats {
  int views = 0;                  // views rendered
  int64_t samples = 0;            // sample vertices
  int64_t samples_scored = 0;     // of those, seen by min_views views
  int64_t samples_kept = 0;       // with a trusted best offset
  int64_t vertices_moved = 0;     // vertices whose offset is not zero
  double mean_abs_offset_mm = 0;  // mean |offset| of the moved vertices
  double max_abs_offset_mm = 0;
};

// Refines mesh in place (see the top). Triangles and colours are unchanged.
PhotometricRefinementStats RefineMeshPhotometric(TriangleMesh* mesh, const std::vector<CarvingView>& views,
                                                 const PhotometricRefinementOptions& options);

}  // namespace objscan

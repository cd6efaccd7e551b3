// Weak-vertex refit of the final mesh (LCM-free).
// The mesh's largest errors sit where few dense points voted: a dent where one pair's biased points made the ridge,
// the shadowed junction with the floor. The surface fit before meshing (SmoothSurfacePoints) cannot pull such a spot
// back when most points around it are as weak as it is. RefitWeakMeshVertices looks at the final mesh instead: a
// vertex's support is the votes of the final voxel whose centre is nearest to it, within two voxels (0 when none is:
// the vertex is weak); a vertex with less than relative_votes x the median support is weak. The fits use one strong
// vertex per voxel (the first in vertex order). A weak vertex surrounded by them on the same surface side (normals
// strictly closer than acos(min_normal_cos) to its own, their directions around it in the tangent plane leaving no
// gap wider than max_gap_deg, at least min_neighbours within radius_mm) gets the surface they define: a quadratic
// height field
// h(u, v) = a + b u + c v + d u^2 + e u v + f v^2 over the vertex, in the frame of the strong vertices' mean normal
// (its own normal is as unreliable as its position), weighted by votes x a Gaussian of the distance (sigma
// radius_mm / 2), fitted by least squares. The vertex moves along that normal by h(0, 0) when the fit explains
// the strong vertices (weighted RMS residual <= max_residual_mm) and the move is at most max_move_mm; otherwise it
// stays (a crease, a rim, a piece of surface seen from one side only), and so does one already within min_move_mm
// of it. A weak vertex on an open border that is not surrounded cannot be interpolated; when the extrapolated fit
// (same gates) puts it more than rim_drop_mm off, it is a rim flared off the surface (the shadowed junction with the
// floor) and is removed with its triangles.
// Only weak vertices move, and they are fitted to strong vertices alone, so the result does not depend on their order.
// Vertices that are not finite or lie 2^20 voxels or more from the origin are left as they are and take no part
// (nor do the triangles they belong to in the normals).
// Mesh in mm, world frame; voxel (i, j, k) has its centre at (i + 0.5, j + 0.5, k + 0.5) x voxel_size_mm. Never throws
// beyond std::bad_alloc.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "processes/dense_modeler/marching_cubes.h"
#include "processes/dense_modeler/space_carving.h"

namespace objscan {

struct WeakRefitOptions {
  double relative_votes = 0.1;   // a vertex is weak below this fraction of the median vertex support (0 = off), [0, 1)
  double radius_mm = 25.0;       // mm, strong vertices within this of a weak one fit its surface, >= 1
  int min_neighbours = 20;       // strong vertices (one per voxel) the fit needs at least (>= 6, the height field's
                                 // parameters)
  double min_normal_cos = 0.8;   // strong vertices need normals within acos(this) of the weak one's, [-1, 1)
  double max_gap_deg = 120.0;    // deg, largest angle around the weak vertex (tangent plane) without a strong one:
                                 // a vertex at a rim or a hole's edge is extrapolated, not interpolated, (0, 360]
  double max_residual_mm = 0.3;  // mm, weighted RMS distance of the strong vertices to the fitted surface at most, > 0
  double max_move_mm = 5.0;      // mm, a weak vertex moves at most this far, > 0
  double min_move_mm = 1.0;      // mm, a weak vertex closer than this to the fitted surface stays: it repairs
                                 // outliers, not the fine shape (moving every weak vertex made 3-9 % of those on
                                 // the blob worse by up to 2.5 mm where it curves under), [0, max_move_mm)
  double rim_drop_mm = 1.0;      // mm, a weak vertex on an open border that is not surrounded and lies farther than
                                 // this (and at most max_move_mm) from the extrapolated fit is removed with its
                                 // triangles: a rim flared off the surface (0 = off), [0, max_move_mm)
};

bool ValidateWeakRefitOptions(const WeakRefitOptions& options, std::string* why);

struct WeakRefitStats {
  int64_t vertices = 0;               // mesh vertices used by a triangle
  double median_votes = 0;            // median vertex support (votes of the nearest final voxel)
  int64_t weak = 0;                   // vertices below relative_votes x median_votes
  int64_t few_neighbours = 0;         // weak vertices left: fewer than min_neighbours strong ones near
  int64_t not_surrounded = 0;         // weak vertices left: a gap wider than max_gap_deg around them
  int64_t poor_fit = 0;               // weak vertices left: residual over max_residual_mm (or a degenerate fit)
  int64_t too_far = 0;                // weak vertices left: the move would exceed max_move_mm
  int64_t close = 0;                  // weak vertices left: already within min_move_mm of the fitted surface
  int64_t rim_vertices_dropped = 0;   // weak, unsurrounded border vertices off the extrapolated fit (rim_drop_mm)
  int64_t rim_triangles_dropped = 0;  // their triangles
  int64_t moved = 0;                  // weak vertices moved onto their strong neighbours' surface
  double mean_abs_move_mm = 0;        // mm, over the moved vertices
  double max_abs_move_mm = 0;         // mm
};

// What happened to one vertex (RefitWeakMeshVertices' outcomes, e.g. to colour a mesh for inspection).
enum class WeakRefitOutcome : int8_t {
  kUnused = 0,     // no triangle uses the vertex, or it is not finite (left as it is)
  kStrong,         // support at least relative_votes x the median: never moved
  kFewNeighbours,  // weak, left: fewer than min_neighbours strong vertices near
  kNotSurrounded,  // weak, left: a gap wider than max_gap_deg
  kPoorFit,        // weak, left: residual over max_residual_mm or a degenerate fit
  kTooFar,         // weak, left: the move would exceed max_move_mm
  kClose,          // weak, left: within min_move_mm of the fitted surface
  kRimDropped,     // weak, on a border, not surrounded, off the extrapolated fit: removed (absent from the output)
  kMoved,          // weak, moved onto the strong vertices' surface
};

// Moves the mesh's weak vertices onto the surface of their strong neighbours and removes flared weak rims (see above);
// voxels are the final model's voxels (their votes give the support). Nothing changes when options.relative_votes
// is 0, the mesh has no triangles or voxels is empty (outcomes then say kStrong for every used vertex). outcomes
// (optional) gets one entry per vertex of the output mesh (renumbered as KeepMeshTriangles does when rim triangles
// were removed). Removing a rim vertex's triangles can leave a neighbour with no triangle: it leaves the mesh too,
// uncounted, and may be among those counted as moved.
WeakRefitStats RefitWeakMeshVertices(TriangleMesh* mesh, const std::vector<CarvedVoxel>& voxels, double voxel_size_mm,
                                     const WeakRefitOptions& options,
                                     std::vector<WeakRefitOutcome>* outcomes = nullptr);

}  // namespace objscan

// The object's surface from the vote grid (LCM-free).
// Dense points scatter around the true surface by their matching and pose noise, and each point also votes into
// its neighbours, so the voxels over the vote threshold form a shell 3-5 voxels thick. The surface is the ridge of
// the vote field across that shell. ExtractVoteRidge keeps, for every seed, the voxels whose votes are a local
// maximum along the local surface normal (non-maximum suppression, as in edge detection), and places a sub-voxel
// surface point on the normal through a parabola fit of the votes at -1, 0, +1 voxel. Normals come from the
// principal axes of the vote-weighted seed neighbourhood (the shell is locally a slab; the normal is its thin axis)
// and point outwards: towards the cameras that saw the voxel's points when the grid recorded view directions,
// otherwise away from the seeds' centroid. Small disconnected ridge fragments (stray matches) are dropped: fewer
// than min_component_voxels, or less than min_component_fraction of the largest fragment.
// SmoothSurfacePoints then fits a local surface to the ridge points around each point, weighted by their votes (the
// ridge's weak points, from few and often biased matches - chords of low-texture triangles, the shadowed junction
// with the floor - are pulled onto the surface that the well-supported points around them define) and by a
// Gaussian of their distance: a plane, then a quadratic height field over it (a plane alone would pull every point
// of a curved surface inwards by the sagitta of the neighbourhood); the point moves onto that surface and takes its
// normal (steadier than the vote neighbourhood's thin axis).
// MeshFromSurfacePoints turns the oriented surface points into a mesh through a signed distance field sampled in
// a narrow band around them: the surface has holes where nothing was seen, and the mesh keeps them open rather than
// invent a surface there.
// Voxel (i, j, k) has its centre at (i + 0.5, j + 0.5, k + 0.5) * voxel_size_mm (world, mm). Never throws.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "processes/dense_modeler/marching_cubes.h"
#include "processes/dense_modeler/voxel_votes.h"

namespace objscan {

// Crease sharpening (SharpenCreases): the vote field and the surface fit round a crease (a box's edge, a cylinder's
// rim) into a bevel up to ~4 mm off both faces, or let one face run on past the edge. Where a point's neighbourhood
// holds two faces, it moves onto the wedge those faces' planes bound.
struct CreaseOptions {
  double radius_voxels = 9.0;    // voxels, neighbourhood of a point whose normals are split into two faces (0 =
                                 // off), 0 or [2, 12]; it must reach past the bevel (~4 voxels) well onto both
                                 // faces (7 left the cylinder's rim 3.6 mm round, 9: 2.3 mm)
  double min_angle_deg = 50.0;   // deg, the two faces' mean normals at least this far apart, (0, 180): a smooth
                                 // surface of curvature radius R spreads normals by ~2 x radius / R rad over the
                                 // neighbourhood (21 deg on a 100 mm sphere)
  double core_angle_deg = 10.0;  // deg, neighbours within this of a face's mean normal give its plane; the bevel's
                                 // own points, in between, must not (20 tilted the cylinder's top towards its
                                 // rim by 2.7 mm), (0, 45]
  int min_face_points = 12;      // points each face's plane needs at least (>= 3)
  double max_move_voxels = 3.0;  // voxels, points that would move farther stay where they are (> 0)
};

bool ValidateCreaseOptions(const CreaseOptions& options, std::string* why);

struct RidgeOptions {
  int normal_radius = 2;          // voxels, half-size of the neighbourhood whose votes give the normal (1..4)
  double ridge_tolerance = 1.0;   // keep a voxel when votes >= tolerance x the interpolated votes one voxel along
                                  // +normal and -normal (1 = strict local maximum; < 1 keeps a thicker ridge), (0, 1]
  int min_component_voxels = 30;  // ridge fragments (26-connected) with fewer voxels are dropped (0 = keep all)
  double min_component_fraction = 0.01;  // fragments with fewer voxels than this fraction of the largest one are
                                         // dropped, and after carving mesh pieces with fewer triangles than this
                                         // fraction of the largest (0 = off), [0, 1)
  CurledBorderOptions curled_borders;    // curled rims peeled off the mesh's open borders first (marching_cubes.h)
  int border_rings = 1;                  // rings of triangles peeled off the mesh's open borders, where the surface
                                         // points of a hole's rim bend off the surface (0 = off), 0..10
  double smoothing_radius = 8.0;         // voxels, radius of the vote-weighted local surface fit of SmoothSurfacePoints
                                         // (0 = off), 0 or [1, 12]
  double smoothing_min_normal_cos = 0.9;  // neighbours of the surface fit need normals within acos(this) of the
                                          // point's own: 0.9 (26 deg) keeps the faces of a crease apart (0.5 rounded
                                          // the box's edges over ~6 mm), [-1, 1)
  CreaseOptions creases;                  // crease sharpening after the surface fit (SharpenCreases)
};

bool ValidateRidgeOptions(const RidgeOptions& options, std::string* why);

struct SurfaceVoxel {
  VoxelRecord voxel;                                         // the ridge voxel (votes, colour)
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();         // unit, outwards
  Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();  // mm, sub-voxel surface point (centre + t * normal)
};

struct RidgeStats {
  int64_t seeds = 0;                     // input voxels
  int64_t ridge = 0;                     // local maxima along the normal
  int64_t fragments_dropped = 0;         // voxels in dropped fragments
  int64_t mesh_triangles_dropped = 0;    // triangles of mesh pieces under min_component_fraction of the largest
                                         // (BuildFinalModel, after carving)
  int64_t curled_triangles_dropped = 0;  // triangles of curled rims peeled off the open borders (BuildFinalModel)
  int64_t border_triangles_dropped = 0;  // triangles peeled off the mesh's open borders (BuildFinalModel)
  int64_t crease_points_moved = 0;       // surface points moved onto a crease's faces (BuildFinalModel)
  int64_t kept = 0;
};

// Ridge voxels of the seeds (voxels over the vote threshold; their votes are read from grid), sorted by (k, j, i).
std::vector<SurfaceVoxel> ExtractVoteRidge(const VoxelVoteGrid& grid, const std::vector<VoxelRecord>& seeds,
                                           const RidgeOptions& options, RidgeStats* stats = nullptr);

// Vote-weighted local surface fit (see the top): for every point, the ridge points within radius_voxels whose
// normals agree with its own (cosine >= min_normal_cos; 0.5 = 60 deg), weighted by votes x exp(-d^2 / (2
// (radius/2)^2)), give a weighted centroid and covariance, whose smallest principal axis is the plane normal n; with >=
// 12 neighbours a weighted quadratic height field h(u, v) over the point's tangent plane is fitted and the point moves
// to h(0, 0) along n, taking the field's normal there (else onto the plane, taking n). Normals stay oriented like the
// old ones. Points keep their voxel. radius_voxels <= 0: unchanged.
std::vector<SurfaceVoxel> SmoothSurfacePoints(const std::vector<SurfaceVoxel>& surface, double voxel_size_mm,
                                              double radius_voxels, double min_normal_cos = 0.5);

// Crease sharpening (see CreaseOptions): for every point, the neighbours within radius_voxels have their normals
// split into two groups (2-means, seeded by the two most different normals); when the groups' mean normals are at
// least min_angle_deg apart, each group's core gives a face plane (its vote-weighted centroid and mean normal): the
// normals within core_angle_deg of the group's far side (the 10th percentile of the dot product with the other
// group's mean, off the bevel), or of the group's mean when fewer than min_face_points lie there (a stray far side:
// the underside of a flap). Both cores need min_face_points. A convex crease (each face's centroid behind the other
// face's plane) bounds the solid by the intersection of the two half-spaces, a concave one by their union; the point
// moves to the nearest point of that solid's boundary (onto a face, or onto the edge line) and takes the normal of
// that face (on the edge: of the face nearer its own normal), unless that is farther than max_move_voxels. Points
// with one face around them (almost all on smooth surfaces) are unchanged. Points keep their voxel; radius 0: copy.
std::vector<SurfaceVoxel> SharpenCreases(const std::vector<SurfaceVoxel>& surface, double voxel_size_mm,
                                         const CreaseOptions& options, int64_t* moved = nullptr);

// Mesh through oriented surface points: the signed distance n . (x - p), averaged with Gaussian weights
// (sigma = voxel_size_mm) over the points within 2 voxels, is sampled on a grid of spacing voxel_size_mm; samples
// with no point near stay undefined and cells touching them produce no triangles. Vertex colours come from the
// nearest point. Empty mesh for no points.
TriangleMesh MeshFromSurfacePoints(const std::vector<SurfaceVoxel>& surface, double voxel_size_mm);

}  // namespace objscan

// Iso-surface extraction from a scalar volume and from a voxel occupancy set (LCM-free).
// Implementation: marching tetrahedra — every grid cube is split into the 6 Kuhn tetrahedra around its main
// diagonal (the same split in every cube, so neighbouring cubes agree on their shared faces), which gives a closed,
// consistently oriented mesh without the 256-case cube tables (more triangles than classic marching cubes: ~2x).
// Vertices on the same grid edge are shared. Triangles are oriented with their normal pointing from inside
// (value > iso) to outside.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "processes/dense_modeler/space_carving.h"

namespace objscan {

// Samples on a regular grid: value(x, y, z) lives at origin + (x, y, z) * spacing (world, mm).
struct ScalarVolume {
  int nx = 0, ny = 0, nz = 0;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // mm, world position of sample (0, 0, 0)
  double spacing = 1.0;                              // mm
  std::vector<float> values;                         // nx * ny * nz, x fastest
  std::vector<std::array<uint8_t, 3>> bgr;           // optional colour per sample (empty = grey mesh)
  size_t Index(int x, int y, int z) const { return (static_cast<size_t>(z) * ny + y) * nx + x; }
};

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;    // mm, world
  std::vector<std::array<uint8_t, 3>> bgr;  // per vertex
  std::vector<std::array<int32_t, 3>> triangles;
};

// Iso-surface at `iso` (inside = value > iso). Samples outside the volume count as outside; when the volume has
// no inside sample on its border the mesh is closed. Non-finite samples are undefined: cells with an undefined
// corner produce no triangles (the mesh is open there). Vertex colour = colour of the inside end of its edge.
TriangleMesh ExtractIsosurface(const ScalarVolume& volume, float iso);

// Mesh of a voxel set: occupancy (1 inside, 0 outside) on the voxel centres with a one-voxel empty border plus
// margin, smoothed smoothing_passes times by a separable [1 2 1]/4 filter, extracted at 0.5. Vertex colours are
// the voxel colours (nearest occupied voxel for smoothed-in samples).
TriangleMesh MeshFromVoxels(const std::vector<CarvedVoxel>& voxels, double voxel_size_mm, int smoothing_passes = 1);

// True when every undirected edge is used by exactly two triangles with opposite directions (closed, oriented).
bool IsClosedOrientedMesh(const TriangleMesh& mesh);

// Area-weighted unit vertex normals of the triangles (of those t with (*keep)[t] when keep is given; triangles are
// oriented inside -> outside); zero for vertices no such triangle uses (or whose triangles have zero area).
std::vector<Eigen::Vector3f> VertexNormals(const TriangleMesh& mesh, const std::vector<char>* keep = nullptr);

// border[v] = 1 for the vertices on an edge that exactly one triangle t with keep[t] uses (an open border); returns
// false when there is none.
bool MarkBorderVertices(const TriangleMesh& mesh, const std::vector<char>& keep, std::vector<char>* border);

// Keeps the triangles t with keep[t] (one flag per triangle), in their order, and the vertices they use, renumbered
// in the order the kept triangles first use them. Returns the triangles dropped; the mesh is unchanged when none is.
// new_index (optional) gets, per input vertex, its index in the output mesh (-1: gone; the identity when nothing was
// dropped).
int64_t KeepMeshTriangles(TriangleMesh* mesh, const std::vector<char>& keep, std::vector<int32_t>* new_index = nullptr);

// Clears keep[t] for the triangles t with a vertex v with flagged[v].
void DropTrianglesAt(const TriangleMesh& mesh, const std::vector<char>& flagged, std::vector<char>* keep);

// Drops the connected pieces of the mesh (triangles sharing vertices) with fewer triangles than min_fraction of the
// largest piece. When any is dropped, the vertices are renumbered in the order the kept triangles first use them
// (unused ones dropped). Returns the triangles dropped; min_fraction <= 0: unchanged.
int64_t RemoveSmallMeshPieces(TriangleMesh* mesh, double min_fraction);

// Peels `rings` rings of triangles off the open borders of the mesh (each ring: the triangles touching a vertex on an
// edge used by one triangle), renumbering the vertices like RemoveSmallMeshPieces. A closed mesh is unchanged.
// Returns the triangles dropped; rings <= 0: unchanged.
int64_t TrimMeshBorder(TriangleMesh* mesh, int rings);

// The rim of a hole where the surface points run out often bends off the surface (a flap of a few mm, folded by
// 30-90 deg: the last points' normals are poorly determined). A border triangle (touching a vertex on an edge used
// by one triangle) is curled when (1) no interior vertex (at least interior_rings rings from every border) within
// radius_mm of its centroid has a normal within max_angle_deg of the triangle's, and (2) its centroid lies at least
// min_offset_mm off the tangent plane of the nearest of those interior vertices. A border triangle with no interior
// vertex that near (a strip) is left alone, and so is one of zero area (its neighbours' fate decides; the border
// ring and small-piece filters take what is left). Normals are signed: the mesh must be consistently oriented, and a
// rim folded back by more than 90 deg counts as curled. Triangles, not vertices, are tested so that a crease reaching
// a border (whose vertex normals are the mean of both faces) stays; the offset keeps most of a narrow strip between
// a crease and a hole, which lies near the other face's tangent plane. Rings count mesh edges while radius_mm is a
// length: radius_mm must exceed interior_rings rings at the mesh's edge length (~1 mm at 2 mm voxels).
struct CurledBorderOptions {
  int max_rings = 10;           // passes at most; each drops the curled border triangles (0 = off), 0..50
  double max_angle_deg = 20.0;  // deg, (1): a border triangle's normal farther than this from every interior
                                // normal near it, (0, 90)
  double radius_mm = 16.0;      // mm, interior vertices within this distance of the triangle's centroid count (> 0)
  int interior_rings = 8;       // rings from the border beyond which a vertex is interior: longer than a flap, 2..50
  double min_offset_mm = 1.5;   // mm, (2): the centroid's distance off the nearest interior vertex's tangent plane,
                                // >= 0
};

bool ValidateCurledBorderOptions(const CurledBorderOptions& options, std::string* why);

// Peels curled rims off the open borders (see CurledBorderOptions), pass after pass until no border triangle is
// curled or max_rings passes ran, renumbering the vertices like RemoveSmallMeshPieces. Vertex normals are the
// area-weighted normals of the kept triangles. Returns the triangles dropped; max_rings <= 0 or a closed mesh:
// unchanged.
int64_t TrimCurledBorders(TriangleMesh* mesh, const CurledBorderOptions& options);

}  // namespace objscan

// Occluded-layer removal for the final mesh (LCM-free).
// Dense points from triangles across a crease (a cylinder's rim, a box edge) or seen at grazing angles (the top of an
// object seen from the orbit) can form a second sheet a few millimetres *inside* the object, under the true surface
// that other pairs reconstructed. Such a sheet is hidden from every camera by the model's own surface. The mesh's
// depth is rendered into the views (at most max_views, evenly spread; z-buffer of its triangles, perspective-correct,
// the view's camera as stored, so downsampled carving views work), and a vertex counts as seen by a view when it faces
// the camera (its area-weighted normal within acos(min_facing_cos) of the ray to the camera centre), projects into the
// image and lies no more than depth_tolerance_mm behind the rendered depth around its pixel (the largest depth of the 2
// x 2 pixel centres around it, so a vertex on the surface is never occluded by its own neighbourhood, even at grazing
// angles). A vertex is removed with its triangles when fewer than min_seen_views views see it, or fewer than
// min_seen_fraction of the views it faces (in front, in the image): an inner sheet is seen only through the holes of
// the surface above it. Wrong sheets *in front of* the surface are not found this way (they would hide the surface, not
// be hidden), nor dents where no true surface was built. Units: mm (world), px. Never throws; views with an invalid
// camera are skipped.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "processes/dense_modeler/marching_cubes.h"
#include "processes/dense_modeler/space_carving.h"

namespace objscan {

struct MeshVisibilityOptions {
  int min_seen_views = 2;           // vertices seen by fewer views are removed (0 = off)
  double min_seen_fraction = 0.5;   // vertices seen by fewer than this fraction of the views they face are
                                    // removed (0 = off), [0, 1]
  double depth_tolerance_mm = 3.0;  // mm, a vertex this far behind the rendered surface still counts as seen (> 0)
  double min_facing_cos = 0.05;     // cos of the largest angle between a vertex normal and the ray to the camera
  int max_views = 60;               // views rendered at most, evenly spread over those given (>= 1)
};

bool ValidateMeshVisibilityOptions(const MeshVisibilityOptions& options, std::string* why);

struct MeshVisibilityStats {
  int views = 0;                  // views rendered
  int64_t vertices_removed = 0;   // vertices seen by too few views
  int64_t triangles_removed = 0;  // triangles using a removed vertex
};

struct VertexViews {
  int facing = 0;  // views the vertex faces, in front of the camera and inside the image
  int seen = 0;    // of those, the views in which the mesh does not hide it
};

// The views that face and see each vertex of mesh (see the top), one entry per vertex.
std::vector<VertexViews> CountSeeingViews(const TriangleMesh& mesh, const std::vector<CarvingView>& views,
                                          const MeshVisibilityOptions& options, int* views_used = nullptr);

// The indices (into views, ascending) of the views that see each vertex (with (*wanted)[vertex] when wanted is given,
// one flag per vertex; empty lists for the others), by the test of CountSeeingViews.
std::vector<std::vector<int>> SeeingViews(const TriangleMesh& mesh, const std::vector<CarvingView>& views,
                                          const MeshVisibilityOptions& options,
                                          const std::vector<char>* wanted = nullptr, int* views_used = nullptr);

// Removes the vertices seen by too few views (see the top), the triangles using them and the vertices no kept
// triangle uses (renumbered as KeepMeshTriangles does). No-op when both limits are 0 or there are no views.
MeshVisibilityStats RemoveOccludedMeshParts(TriangleMesh* mesh, const std::vector<CarvingView>& views,
                                            const MeshVisibilityOptions& options);

}  // namespace objscan

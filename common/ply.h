#pragma once
// PLY reading: the one reader of the project's point clouds and meshes (the dense modeler's and the simulator's
// files, and any other program's ASCII or binary_little_endian PLY). No LCM.

#include <string>
#include <vector>

#include <Eigen/Core>

namespace objscan {

// Reads the vertices (x y z) of an ASCII or binary_little_endian PLY (float or double coordinates). With normals
// non-null, also the vertex normals (nx ny nz); false when the file has none. False with *error on an unreadable or
// malformed file.
bool ReadPlyPoints(const std::string& path, std::vector<Eigen::Vector3d>* points, std::string* error,
                   std::vector<Eigen::Vector3d>* normals = nullptr);

// Reads the vertices (x y z) and faces of an ASCII or binary_little_endian PLY: the face element must follow the
// vertex element and hold only a list property vertex_indices (or vertex_index; any integer types); polygons are
// fan-triangulated. False with *error on an unreadable or malformed file or an index out of range.
bool ReadPlyMesh(const std::string& path, std::vector<Eigen::Vector3d>* vertices,
                 std::vector<Eigen::Vector3i>* triangles, std::string* error);

}  // namespace objscan

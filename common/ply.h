#pragma once
// PLY reading: the one reader of the project's point clouds and meshes (the dense modeler's and the simulator's
// files, and any other program's ASCII or binary_little_endian PLY). No LCM.

#include <string>
#include <vector>

#include <Eigen/Core>

namespace objscan {

// What a PLY holds for us: the vertex element's x y z (and nx ny nz when it has them) and the face element's list
// vertex_indices (or vertex_index), polygons fan-triangulated. Other elements and properties are skipped.
struct PlyData {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> normals;     // empty unless has_normals
  std::vector<Eigen::Vector3i> triangles;
  bool has_normals = false;                 // the vertex element has nx ny nz
  bool has_faces = false;                   // a face element with a vertex index list (it may hold no face)
};

// Parses a whole PLY file's bytes: ascii or binary_little_endian, elements in any order, any scalar types. False with
// *error on a malformed header, an unsupported format, truncated data, a list longer than 1000, no vertex element, or
// a face index out of range (of the vertex element before it). Values are not checked for finiteness.
bool ParsePly(const std::string& data, PlyData* out, std::string* error);
// ParsePly on a file; errors start with the path.
bool ReadPlyFile(const std::string& path, PlyData* out, std::string* error);

// Reads the vertices (x y z) of an ASCII or binary_little_endian PLY (float or double coordinates). With normals
// non-null, also the vertex normals (nx ny nz); false when the file has none. False with *error on an unreadable or
// malformed file.
bool ReadPlyPoints(const std::string& path, std::vector<Eigen::Vector3d>* points, std::string* error,
                   std::vector<Eigen::Vector3d>* normals = nullptr);

// Reads the vertices (x y z) and faces of an ASCII or binary_little_endian PLY (ParsePly). False with *error on an
// unreadable or malformed file, an index out of range, or no face element.
bool ReadPlyMesh(const std::string& path, std::vector<Eigen::Vector3d>* vertices,
                 std::vector<Eigen::Vector3i>* triangles, std::string* error);

}  // namespace objscan

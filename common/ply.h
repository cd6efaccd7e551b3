#pragma once
// PLY reading and writing: the one home of the format for the project's point clouds and meshes (the dense
// modeler's, the pose solver's and the simulator's files, and any other program's ASCII or binary_little_endian
// PLY). No LCM.

#include <cstddef>
#include <functional>
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

// Writing. A file is a vertex element with the layout's scalar properties (in order) and, when faces is given, a
// face element (property list uchar int vertex_indices; written even when empty). Values come as doubles, one row
// per vertex from vertex_row(i, values[vertex_properties.size()]), and are stored as the property's type (binary
// float: rounded to float; uchar and int: truncated toward zero after clamping to the type's range, NaN as 0).
// Binary files are little-endian (the host's order on x86 and ARM); ascii files print float values as given with
// ascii_float_format and integers as integers.
enum class PlyScalar { kUChar, kInt, kFloat };
struct PlyVertexProperty {
  std::string name;
  PlyScalar type = PlyScalar::kFloat;
};
struct PlyLayout {
  bool binary = true;                          // binary_little_endian, else ascii
  std::vector<std::string> comments;           // one "comment" header line each (newlines become spaces)
  std::vector<PlyVertexProperty> vertex_properties;
  const char* ascii_float_format = "%.9g";     // printf format of float values in an ascii file
};
using PlyVertexRow = std::function<void(size_t vertex, double* values)>;
// False with *error ("cannot write PATH", "write error on PATH") when the file cannot be written.
bool WritePlyFile(const std::string& path, const PlyLayout& layout, size_t num_vertices, const PlyVertexRow& vertex_row,
                  const std::vector<Eigen::Vector3i>* faces, std::string* error);
// The layout's x y z float properties (the first three of most files).
std::vector<PlyVertexProperty> PlyXyz();

}  // namespace objscan

#include "common/ply.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace objscan {
namespace {

// The PLY reader behind ReadPlyPoints and ReadPlyMesh: the vertex element (x y z, and nx ny nz when normals is
// given) and, when triangles is given, the face element that follows it (a list property vertex_indices or
// vertex_index; polygons fan-triangulated).
bool ReadPly(const std::string& path, std::vector<Eigen::Vector3d>* points, std::string* error,
             std::vector<Eigen::Vector3d>* normals, std::vector<Eigen::Vector3i>* triangles) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = "cannot read " + path;
    return false;
  }
  std::string line, format;
  long vertex_count = -1, face_count = -1;
  bool in_vertex = false, in_face = false, face_before_vertex = false;
  struct Prop {
    std::string name, type;
  };
  std::vector<Prop> props;
  std::string face_count_type, face_index_type;  // the face list's types
  bool face_has_other_properties = false;
  std::getline(in, line);
  if (line.rfind("ply", 0) != 0) {
    *error = path + ": not a PLY file";
    return false;
  }
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ss(line);
    std::string word;
    ss >> word;
    if (word == "format")
      ss >> format;
    else if (word == "element") {
      std::string name;
      long count;
      ss >> name >> count;
      in_vertex = name == "vertex";
      in_face = name == "face";
      if (in_vertex) vertex_count = count;
      if (in_face) {
        face_count = count;
        face_before_vertex = vertex_count < 0;
      }
    } else if (word == "property" && in_face) {
      std::string type, name;
      ss >> type;
      if (type == "list") {
        ss >> face_count_type >> face_index_type >> name;
        if (name != "vertex_indices" && name != "vertex_index") face_has_other_properties = true;
      } else {
        face_has_other_properties = true;
      }
    } else if (word == "property" && in_vertex) {
      Prop p;
      ss >> p.type;
      if (p.type == "list") {
        *error = path + ": list property in vertex element";
        return false;
      }
      ss >> p.name;
      props.push_back(p);
    } else if (word == "end_header") {
      break;
    }
  }
  if (vertex_count < 0) {
    *error = path + ": no vertex element";
    return false;
  }
  auto type_size = [](const std::string& t) -> int {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
    if (t == "double" || t == "float64") return 8;
    return 0;
  };
  int xi = -1, yi = -1, zi = -1;
  for (size_t i = 0; i < props.size(); ++i) {
    if (props[i].name == "x") xi = static_cast<int>(i);
    if (props[i].name == "y") yi = static_cast<int>(i);
    if (props[i].name == "z") zi = static_cast<int>(i);
  }
  if (xi < 0 || yi < 0 || zi < 0) {
    *error = path + ": vertex has no x y z";
    return false;
  }
  int nxi = -1, nyi = -1, nzi = -1;
  for (size_t i = 0; i < props.size(); ++i) {
    if (props[i].name == "nx") nxi = static_cast<int>(i);
    if (props[i].name == "ny") nyi = static_cast<int>(i);
    if (props[i].name == "nz") nzi = static_cast<int>(i);
  }
  if (normals) {
    if (nxi < 0 || nyi < 0 || nzi < 0) {
      *error = path + ": vertex has no nx ny nz";
      return false;
    }
    normals->clear();
  }
  points->clear();
  points->reserve(static_cast<size_t>(vertex_count));
  if (format == "ascii") {
    for (long v = 0; v < vertex_count; ++v) {
      if (!std::getline(in, line)) break;
      std::istringstream ss(line);
      std::vector<double> values(props.size());
      for (auto& value : values) ss >> value;
      if (!ss) {
        *error = path + ": bad vertex line " + std::to_string(v);
        return false;
      }
      points->emplace_back(values[xi], values[yi], values[zi]);
      if (normals) normals->emplace_back(values[nxi], values[nyi], values[nzi]);
    }
  } else if (format == "binary_little_endian") {
    std::vector<int> offsets;
    int stride = 0;
    for (const auto& p : props) {
      const int s = type_size(p.type);
      if (s == 0) {
        *error = path + ": unknown property type " + p.type;
        return false;
      }
      offsets.push_back(stride);
      stride += s;
    }
    std::vector<char> row(stride);
    auto read_value = [&](int i) -> double {
      const char* at = row.data() + offsets[i];
      if (props[i].type == "double" || props[i].type == "float64") {
        double d;
        std::memcpy(&d, at, 8);
        return d;
      }
      float f;
      std::memcpy(&f, at, 4);
      return f;
    };
    for (long v = 0; v < vertex_count; ++v) {
      if (!in.read(row.data(), stride)) break;
      points->emplace_back(read_value(xi), read_value(yi), read_value(zi));
      if (normals) normals->emplace_back(read_value(nxi), read_value(nyi), read_value(nzi));
    }
  } else {
    *error = path + ": unsupported PLY format " + format;
    return false;
  }
  if (static_cast<long>(points->size()) != vertex_count) {
    *error = path + ": file ends after " + std::to_string(points->size()) + " of " + std::to_string(vertex_count) +
             " vertices";
    return false;
  }
  if (!triangles) return true;
  triangles->clear();
  if (face_count < 0 || face_index_type.empty()) {
    *error = path + ": no face element with vertex_indices";
    return false;
  }
  if (face_before_vertex || face_has_other_properties) {
    *error = path + ": only a face element after the vertices, holding only vertex_indices, is supported";
    return false;
  }
  const int count_size = type_size(face_count_type), index_size = type_size(face_index_type);
  if (count_size == 0 || index_size == 0 || index_size == 8) {
    *error = path + ": unsupported face list types " + face_count_type + " " + face_index_type;
    return false;
  }
  std::vector<long> polygon;
  long faces_read = 0;
  for (long f = 0; f < face_count; ++f) {
    polygon.clear();
    if (format == "ascii") {
      if (!std::getline(in, line)) break;
      std::istringstream ss(line);
      long n = 0;
      ss >> n;
      for (long k = 0; k < n && ss; ++k) {
        long index;
        if (ss >> index) polygon.push_back(index);
      }
      if (!ss || n < 3) {
        *error = path + ": bad face line " + std::to_string(f);
        return false;
      }
    } else {
      uint64_t n = 0;
      if (!in.read(reinterpret_cast<char*>(&n), count_size)) break;  // little endian
      if (n < 3 || n > 1000) {
        *error = path + ": face " + std::to_string(f) + " has " + std::to_string(n) + " vertices";
        return false;
      }
      for (uint64_t k = 0; k < n; ++k) {
        int64_t index = 0;
        if (!in.read(reinterpret_cast<char*>(&index), index_size)) break;
        if (index_size < 8 && face_index_type[0] != 'u' && (index >> (8 * index_size - 1)) & 1)
          index -= int64_t{1} << (8 * index_size);  // sign extension
        polygon.push_back(static_cast<long>(index));
      }
      if (!in) break;
    }
    for (long index : polygon)
      if (index < 0 || index >= vertex_count) {
        *error = path + ": face " + std::to_string(f) + " has vertex index " + std::to_string(index) + " out of range";
        return false;
      }
    for (size_t k = 1; k + 1 < polygon.size(); ++k)
      triangles->emplace_back(static_cast<int>(polygon[0]), static_cast<int>(polygon[k]),
                              static_cast<int>(polygon[k + 1]));
    ++faces_read;
  }
  if (faces_read != face_count) {
    *error = path + ": file ends after " + std::to_string(faces_read) + " of " + std::to_string(face_count) + " faces";
    return false;
  }
  return true;
}

}  // namespace

bool ReadPlyPoints(const std::string& path, std::vector<Eigen::Vector3d>* points, std::string* error,
                   std::vector<Eigen::Vector3d>* normals) {
  return ReadPly(path, points, error, normals, nullptr);
}

bool ReadPlyMesh(const std::string& path, std::vector<Eigen::Vector3d>* vertices,
                 std::vector<Eigen::Vector3i>* triangles, std::string* error) {
  return ReadPly(path, vertices, error, nullptr, triangles);
}

}  // namespace objscan

#include "common/ply.h"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

namespace objscan {
namespace {

struct PlyProperty {
  std::string name;
  std::string type;
  bool is_list = false;
  std::string count_type;
};
struct PlyElement {
  std::string name;
  int64_t count = 0;
  std::vector<PlyProperty> properties;
};

int PlyTypeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

template <typename T>
double Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return static_cast<double>(v);
}

double PlyReadBinary(const std::string& t, const uint8_t* p) {
  if (t == "char" || t == "int8") return Load<int8_t>(p);
  if (t == "uchar" || t == "uint8") return Load<uint8_t>(p);
  if (t == "short" || t == "int16") return Load<int16_t>(p);
  if (t == "ushort" || t == "uint16") return Load<uint16_t>(p);
  if (t == "int" || t == "int32") return Load<int32_t>(p);
  if (t == "uint" || t == "uint32") return Load<uint32_t>(p);
  if (t == "float" || t == "float32") return Load<float>(p);
  return Load<double>(p);
}

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r") - a + 1);
}

}  // namespace

bool ParsePly(const std::string& data, PlyData* out, std::string* error) {
  *out = PlyData();
  size_t pos = 0;
  auto next_line = [&](std::string* line) {
    if (pos >= data.size()) return false;
    size_t end = data.find('\n', pos);
    if (end == std::string::npos) end = data.size();
    *line = Trim(data.substr(pos, end - pos));
    pos = end + 1;
    return true;
  };
  std::string line;
  if (!next_line(&line) || line != "ply") {
    *error = "not a PLY file";
    return false;
  }
  std::string format;
  std::vector<PlyElement> elements;
  for (;;) {
    if (!next_line(&line)) {
      *error = "PLY header without end_header";
      return false;
    }
    std::istringstream in(line);
    std::string word;
    in >> word;
    if (word == "end_header") break;
    if (word == "format") {
      in >> format;
    } else if (word == "element") {
      PlyElement e;
      in >> e.name >> e.count;
      if (!in || e.count < 0) {
        *error = "bad PLY element line '" + line + "'";
        return false;
      }
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) {
        *error = "PLY property before element";
        return false;
      }
      PlyProperty p;
      in >> p.type;
      if (p.type == "list") {
        p.is_list = true;
        in >> p.count_type >> p.type;
        if (PlyTypeSize(p.count_type) == 0) {
          *error = "bad PLY list count type '" + p.count_type + "'";
          return false;
        }
      }
      in >> p.name;
      if (PlyTypeSize(p.type) == 0) {
        *error = "unknown PLY property type '" + p.type + "'";
        return false;
      }
      elements.back().properties.push_back(p);
    }
  }
  const bool ascii = format == "ascii";
  if (!ascii && format != "binary_little_endian") {
    *error = "unsupported PLY format '" + format + "' (ascii or binary_little_endian)";
    return false;
  }
  std::istringstream text(ascii ? data.substr(pos) : std::string());
  int64_t num_vertices = -1;
  bool have_vertex = false;
  for (const PlyElement& e : elements) {
    const bool is_vertex = e.name == "vertex";
    const bool is_face = e.name == "face";
    int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, iface = -1;
    for (size_t k = 0; k < e.properties.size(); ++k) {
      const std::string& n = e.properties[k].name;
      const int i = static_cast<int>(k);
      if (e.properties[k].is_list) {
        if (n == "vertex_indices" || n == "vertex_index") iface = i;
        continue;
      }
      if (n == "x") ix = i;
      if (n == "y") iy = i;
      if (n == "z") iz = i;
      if (n == "nx") inx = i;
      if (n == "ny") iny = i;
      if (n == "nz") inz = i;
    }
    if (is_vertex && (ix < 0 || iy < 0 || iz < 0)) {
      *error = "PLY vertex without x, y, z";
      return false;
    }
    const bool with_normals = is_vertex && inx >= 0 && iny >= 0 && inz >= 0;
    if (is_vertex) {
      have_vertex = true;
      num_vertices = e.count;
      out->has_normals = with_normals;
      out->points.reserve(static_cast<size_t>(e.count));
    }
    if (is_face && iface >= 0) out->has_faces = true;
    std::vector<double> values(e.properties.size());
    std::vector<int64_t> poly;
    const auto read_value = [&](const std::string& type, double* v) {
      if (ascii) return static_cast<bool>(text >> *v);
      const size_t s = static_cast<size_t>(PlyTypeSize(type));
      if (pos + s > data.size()) return false;
      *v = PlyReadBinary(type, reinterpret_cast<const uint8_t*>(&data[pos]));
      pos += s;
      return true;
    };
    for (int64_t i = 0; i < e.count; ++i) {
      for (size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& p = e.properties[k];
        if (!p.is_list) {
          if (!read_value(p.type, &values[k])) {
            *error = "PLY data truncated in element '" + e.name + "' " + std::to_string(i) + " of " +
                     std::to_string(e.count);
            return false;
          }
          continue;
        }
        double count = 0;
        if (!read_value(p.count_type, &count)) {
          *error = "PLY data truncated in element '" + e.name + "' " + std::to_string(i);
          return false;
        }
        if (count < 0 || count > 1000) {
          *error = "bad PLY list length " + std::to_string(count);
          return false;
        }
        if (static_cast<int>(k) == iface) poly.clear();
        for (int j = 0; j < static_cast<int>(count); ++j) {
          double v = 0;
          if (!read_value(p.type, &v)) {
            *error = "PLY data truncated in element '" + e.name + "' " + std::to_string(i);
            return false;
          }
          if (static_cast<int>(k) == iface) poly.push_back(static_cast<int64_t>(v));
        }
      }
      if (is_vertex) {
        out->points.emplace_back(values[ix], values[iy], values[iz]);
        if (with_normals) out->normals.emplace_back(values[inx], values[iny], values[inz]);
      }
      if (is_face && iface >= 0) {
        for (int64_t idx : poly)
          if (idx < 0 || idx >= num_vertices) {
            *error = "face " + std::to_string(i) + " has vertex index " + std::to_string(idx) + " out of range" +
                     (have_vertex ? "" : " (no vertex element before the faces)");
            return false;
          }
        for (size_t k = 2; k < poly.size(); ++k)
          out->triangles.emplace_back(static_cast<int>(poly[0]), static_cast<int>(poly[k - 1]),
                                      static_cast<int>(poly[k]));
      }
    }
  }
  if (!have_vertex) {
    *error = "no vertex element";
    return false;
  }
  return true;
}

bool ReadPlyFile(const std::string& path, PlyData* out, std::string* error) {
  std::ifstream file(path, std::ios::binary);
  if (!file) {
    *error = "cannot read " + path;
    return false;
  }
  std::ostringstream buffer;
  buffer << file.rdbuf();
  if (!ParsePly(buffer.str(), out, error)) {
    *error = path + ": " + *error;
    return false;
  }
  return true;
}

bool ReadPlyPoints(const std::string& path, std::vector<Eigen::Vector3d>* points, std::string* error,
                   std::vector<Eigen::Vector3d>* normals) {
  PlyData ply;
  if (!ReadPlyFile(path, &ply, error)) return false;
  if (normals && !ply.has_normals) {
    *error = path + ": vertex has no nx ny nz";
    return false;
  }
  *points = std::move(ply.points);
  if (normals) *normals = std::move(ply.normals);
  return true;
}

bool ReadPlyMesh(const std::string& path, std::vector<Eigen::Vector3d>* vertices,
                 std::vector<Eigen::Vector3i>* triangles, std::string* error) {
  PlyData ply;
  if (!ReadPlyFile(path, &ply, error)) return false;
  if (!ply.has_faces) {
    *error = path + ": no face element with vertex_indices";
    return false;
  }
  *vertices = std::move(ply.points);
  *triangles = std::move(ply.triangles);
  return true;
}

}  // namespace objscan

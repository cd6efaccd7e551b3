#include "common/ply.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

namespace objscan {
namespace {

struct HeaderProperty {
  std::string name;
  std::string type;
  bool is_list = false;
  std::string count_type;
};
struct PlyElement {
  std::string name;
  int64_t count = 0;
  std::vector<HeaderProperty> properties;
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

// The next line of data from *pos (trimmed), advancing *pos past its newline; false at the end of data.
bool NextLine(const std::string& data, size_t* pos, std::string* line) {
  if (*pos >= data.size()) return false;
  size_t end = data.find('\n', *pos);
  if (end == std::string::npos) end = data.size();
  *line = Trim(data.substr(*pos, end - *pos));
  *pos = end + 1;
  return true;
}

// Parses the header from the "ply" line to end_header: the format word and the elements with their properties;
// *pos ends at the first byte of the data. False with *error on a malformed header.
bool ParsePlyHeader(const std::string& data, size_t* pos, std::string* format, std::vector<PlyElement>* elements,
                    std::string* error) {
  std::string line;
  if (!NextLine(data, pos, &line) || line != "ply") {
    *error = "not a PLY file";
    return false;
  }
  for (;;) {
    if (!NextLine(data, pos, &line)) {
      *error = "PLY header without end_header";
      return false;
    }
    std::istringstream in(line);
    std::string word;
    in >> word;
    if (word == "end_header") break;
    if (word == "format") {
      in >> *format;
    } else if (word == "element") {
      PlyElement e;
      in >> e.name >> e.count;
      if (!in || e.count < 0) {
        *error = "bad PLY element line '" + line + "'";
        return false;
      }
      elements->push_back(e);
    } else if (word == "property") {
      if (elements->empty()) {
        *error = "PLY property before element";
        return false;
      }
      HeaderProperty p;
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
      elements->back().properties.push_back(p);
    }
  }
  return true;
}

// Reads the data's scalars one after the other: ascii text after the header, or binary little-endian from data.
class PlyValueReader {
 public:
  // pos: first byte of the data (after end_header).
  PlyValueReader(const std::string& data, size_t pos, bool ascii)
      : data_(data), pos_(pos), ascii_(ascii), text_(ascii ? data.substr(pos) : std::string()) {}

  // The next value, stored as the PLY type `type` (binary); false when the data ends (or is no number, ascii).
  bool Read(const std::string& type, double* v) {
    if (ascii_) return static_cast<bool>(text_ >> *v);
    const size_t s = static_cast<size_t>(PlyTypeSize(type));
    if (pos_ + s > data_.size()) return false;
    *v = PlyReadBinary(type, reinterpret_cast<const uint8_t*>(&data_[pos_]));
    pos_ += s;
    return true;
  }

 private:
  const std::string& data_;
  size_t pos_;
  bool ascii_;
  std::istringstream text_;
};

// Indices in an element's property list of the properties we read (-1 when absent).
struct PlyPropertyIndices {
  int x = -1, y = -1, z = -1, nx = -1, ny = -1, nz = -1;
  int face = -1;  // the list vertex_indices (or vertex_index)
};

// Where x y z, nx ny nz and the face index list are among element e's properties.
PlyPropertyIndices FindPropertyIndices(const PlyElement& e) {
  PlyPropertyIndices idx;
  for (size_t k = 0; k < e.properties.size(); ++k) {
    const std::string& n = e.properties[k].name;
    const int i = static_cast<int>(k);
    if (e.properties[k].is_list) {
      if (n == "vertex_indices" || n == "vertex_index") idx.face = i;
      continue;
    }
    if (n == "x") idx.x = i;
    if (n == "y") idx.y = i;
    if (n == "z") idx.z = i;
    if (n == "nx") idx.nx = i;
    if (n == "ny") idx.ny = i;
    if (n == "nz") idx.nz = i;
  }
  return idx;
}

// Reads row i of element e: its scalar properties into values (by property index) and, when the list property iface
// is read, its entries into *poly. False with *error on truncated data or a list longer than 1000.
bool ReadPlyRow(const PlyElement& e, int64_t i, int iface, PlyValueReader* reader, std::vector<double>* values,
                std::vector<int64_t>* poly, std::string* error) {
  for (size_t k = 0; k < e.properties.size(); ++k) {
    const HeaderProperty& p = e.properties[k];
    if (!p.is_list) {
      if (!reader->Read(p.type, &(*values)[k])) {
        *error =
            "PLY data truncated in element '" + e.name + "' " + std::to_string(i) + " of " + std::to_string(e.count);
        return false;
      }
      continue;
    }
    double count = 0;
    if (!reader->Read(p.count_type, &count)) {
      *error = "PLY data truncated in element '" + e.name + "' " + std::to_string(i);
      return false;
    }
    if (count < 0 || count > 1000) {
      *error = "bad PLY list length " + std::to_string(count);
      return false;
    }
    if (static_cast<int>(k) == iface) poly->clear();
    for (int j = 0; j < static_cast<int>(count); ++j) {
      double v = 0;
      if (!reader->Read(p.type, &v)) {
        *error = "PLY data truncated in element '" + e.name + "' " + std::to_string(i);
        return false;
      }
      if (static_cast<int>(k) == iface) poly->push_back(static_cast<int64_t>(v));
    }
  }
  return true;
}

// Reads all rows of element e into out: a vertex element's points (and normals), a face element's fan-triangulated
// faces (indices checked against *num_vertices, the vertex element's count; -1 before it). Other elements are
// skipped. False with *error on a vertex element without x y z, truncated data or an index out of range.
bool ReadPlyElement(const PlyElement& e, PlyValueReader* reader, int64_t* num_vertices, bool* have_vertex, PlyData* out,
                    std::string* error) {
  const bool is_vertex = e.name == "vertex";
  const bool is_face = e.name == "face";
  const PlyPropertyIndices idx = FindPropertyIndices(e);
  if (is_vertex && (idx.x < 0 || idx.y < 0 || idx.z < 0)) {
    *error = "PLY vertex without x, y, z";
    return false;
  }
  const bool with_normals = is_vertex && idx.nx >= 0 && idx.ny >= 0 && idx.nz >= 0;
  if (is_vertex) {
    *have_vertex = true;
    *num_vertices = e.count;
    out->has_normals = with_normals;
    out->points.reserve(static_cast<size_t>(e.count));
  }
  if (is_face && idx.face >= 0) out->has_faces = true;
  std::vector<double> values(e.properties.size());
  std::vector<int64_t> poly;
  for (int64_t i = 0; i < e.count; ++i) {
    if (!ReadPlyRow(e, i, idx.face, reader, &values, &poly, error)) return false;
    if (is_vertex) {
      out->points.emplace_back(values[idx.x], values[idx.y], values[idx.z]);
      if (with_normals) out->normals.emplace_back(values[idx.nx], values[idx.ny], values[idx.nz]);
    }
    if (is_face && idx.face >= 0) {
      for (int64_t index : poly)
        if (index < 0 || index >= *num_vertices) {
          *error = "face " + std::to_string(i) + " has vertex index " + std::to_string(index) + " out of range" +
                   (*have_vertex ? "" : " (no vertex element before the faces)");
          return false;
        }
      for (size_t k = 2; k < poly.size(); ++k)
        out->triangles.emplace_back(static_cast<int>(poly[0]), static_cast<int>(poly[k - 1]),
                                    static_cast<int>(poly[k]));
    }
  }
  return true;
}

}  // namespace

bool ParsePly(const std::string& data, PlyData* out, std::string* error) {
  *out = PlyData();
  size_t pos = 0;
  std::string format;
  std::vector<PlyElement> elements;
  if (!ParsePlyHeader(data, &pos, &format, &elements, error)) return false;
  const bool ascii = format == "ascii";
  if (!ascii && format != "binary_little_endian") {
    *error = "unsupported PLY format '" + format + "' (ascii or binary_little_endian)";
    return false;
  }
  PlyValueReader reader(data, pos, ascii);
  int64_t num_vertices = -1;
  bool have_vertex = false;
  for (const PlyElement& e : elements)
    if (!ReadPlyElement(e, &reader, &num_vertices, &have_vertex, out, error)) return false;
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

std::vector<PlyVertexProperty> PlyXyz() {
  return {{"x", PlyScalar::kFloat}, {"y", PlyScalar::kFloat}, {"z", PlyScalar::kFloat}};
}

namespace {

template <typename T>
void Append(std::string* buf, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  buf->append(bytes, sizeof(T));
}

template <typename T>
T ClampTo(double v) {
  if (!(v == v)) return 0;  // NaN
  return static_cast<T>(std::clamp(v, static_cast<double>(std::numeric_limits<T>::lowest()),
                                   static_cast<double>(std::numeric_limits<T>::max())));
}

const char* ScalarName(PlyScalar t) {
  switch (t) {
    case PlyScalar::kUChar: return "uchar";
    case PlyScalar::kInt: return "int";
    case PlyScalar::kFloat: return "float";
  }
  return "float";
}

}  // namespace

bool WritePlyFile(const std::string& path, const PlyLayout& layout, size_t num_vertices, const PlyVertexRow& vertex_row,
                  const std::vector<Eigen::Vector3i>* faces, std::string* error) {
  std::string buf = std::string("ply\nformat ") + (layout.binary ? "binary_little_endian" : "ascii") + " 1.0\n";
  for (std::string c : layout.comments) {
    std::replace(c.begin(), c.end(), '\n', ' ');
    std::replace(c.begin(), c.end(), '\r', ' ');
    buf += "comment " + c + "\n";
  }
  buf += "element vertex " + std::to_string(num_vertices) + "\n";
  for (const PlyVertexProperty& p : layout.vertex_properties)
    buf += std::string("property ") + ScalarName(p.type) + " " + p.name + "\n";
  if (faces) buf += "element face " + std::to_string(faces->size()) + "\nproperty list uchar int vertex_indices\n";
  buf += "end_header\n";
  const size_t n = layout.vertex_properties.size();
  std::vector<double> row(n);
  char text[64];
  for (size_t i = 0; i < num_vertices; ++i) {
    std::fill(row.begin(), row.end(), 0.0);
    vertex_row(i, row.data());
    for (size_t k = 0; k < n; ++k) {
      const PlyScalar t = layout.vertex_properties[k].type;
      if (layout.binary) {
        if (t == PlyScalar::kFloat) Append(&buf, static_cast<float>(row[k]));
        else if (t == PlyScalar::kInt) Append(&buf, ClampTo<int32_t>(row[k]));
        else Append(&buf, ClampTo<uint8_t>(row[k]));
      } else {
        if (k) buf += ' ';
        if (t == PlyScalar::kFloat)
          std::snprintf(text, sizeof(text), layout.ascii_float_format, row[k]);  // as given: text keeps it
        else if (t == PlyScalar::kInt)
          std::snprintf(text, sizeof(text), "%d", ClampTo<int32_t>(row[k]));
        else
          std::snprintf(text, sizeof(text), "%d", static_cast<int>(ClampTo<uint8_t>(row[k])));
        buf += text;
      }
    }
    if (!layout.binary) buf += '\n';
  }
  if (faces) {
    for (const Eigen::Vector3i& f : *faces) {
      if (layout.binary) {
        Append(&buf, static_cast<uint8_t>(3));
        for (int k = 0; k < 3; ++k) Append(&buf, static_cast<int32_t>(f[k]));
      } else {
        buf += "3 " + std::to_string(f.x()) + " " + std::to_string(f.y()) + " " + std::to_string(f.z()) + "\n";
      }
    }
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) {
    if (error) *error = "cannot write " + path;
    return false;
  }
  out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  out.close();
  if (!out) {
    if (error) *error = "write error on " + path;
    return false;
  }
  return true;
}

}  // namespace objscan

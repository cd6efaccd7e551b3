#include "processes/dense_modeler/export.h"

#include <octomap/OcTree.h>
#include <cstdint>
#include <cstring>
#include <fstream>

namespace objscan {
namespace {

template <class T>
void Put(std::string* buf, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  buf->append(bytes, sizeof(T));
}

bool WriteFile(const std::string& path, const std::string& data, std::string* error) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) {
    if (error) *error = "cannot open " + path;
    return false;
  }
  f.write(data.data(), static_cast<std::streamsize>(data.size()));
  f.close();
  if (!f) {
    if (error) *error = "write failed: " + path;
    return false;
  }
  return true;
}

}  // namespace

bool WriteVoxelPly(const std::string& path, const std::vector<CarvedVoxel>& voxels, double voxel_size,
                   ScaleSource scale, std::string* error) {
  std::string buf = std::string("ply\nformat binary_little_endian 1.0\ncomment objscan dense_modeler voxel centres, ") +
                    (IsMetric(scale) ? "mm" : "arbitrary unit") + "\ncomment scale: " + ScaleDescription(scale) + "\n";
  buf += "comment voxel_size_mm " + std::to_string(voxel_size) + "\n";
  buf += "element vertex " + std::to_string(voxels.size()) + "\n";
  buf +=
      "property float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nproperty int votes\nproperty int views\nend_header\n";
  for (const CarvedVoxel& v : voxels) {
    for (int k = 0; k < 3; ++k) Put(&buf, static_cast<float>((v.ijk[k] + 0.5) * voxel_size));
    Put(&buf, v.bgr[2]);
    Put(&buf, v.bgr[1]);
    Put(&buf, v.bgr[0]);
    Put(&buf, static_cast<int32_t>(v.votes));
    Put(&buf, static_cast<int32_t>(v.views));
  }
  return WriteFile(path, buf, error);
}

bool WriteMeshPly(const std::string& path, const TriangleMesh& mesh, ScaleSource scale, std::string* error) {
  std::string buf = std::string("ply\nformat binary_little_endian 1.0\ncomment objscan dense_modeler surface, ") +
                    (IsMetric(scale) ? "mm" : "arbitrary unit") + "\ncomment scale: " + ScaleDescription(scale) + "\n";
  buf += "element vertex " + std::to_string(mesh.vertices.size()) + "\n";
  buf +=
      "property float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\n";
  buf += "element face " + std::to_string(mesh.triangles.size()) +
         "\nproperty list uchar int vertex_indices\n"
         "end_header\n";
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (int k = 0; k < 3; ++k) Put(&buf, mesh.vertices[i][k]);
    const std::array<uint8_t, 3> c = i < mesh.bgr.size() ? mesh.bgr[i] : std::array<uint8_t, 3>{{160, 160, 160}};
    Put(&buf, c[2]);
    Put(&buf, c[1]);
    Put(&buf, c[0]);
  }
  for (const auto& t : mesh.triangles) {
    Put(&buf, static_cast<uint8_t>(3));
    for (int k = 0; k < 3; ++k) Put(&buf, t[k]);
  }
  return WriteFile(path, buf, error);
}

bool WriteOctomap(const std::string& path, const std::vector<CarvedVoxel>& voxels, double voxel_size,
                  std::string* error) {
  if (!(voxel_size > 0)) {
    if (error) *error = "voxel size must be > 0";
    return false;
  }
  try {
    const double res_m = voxel_size * 1e-3;
    octomap::OcTree tree(res_m);
    for (const CarvedVoxel& v : voxels) {
      const octomap::point3d p(static_cast<float>((v.ijk.x() + 0.5) * res_m),
                               static_cast<float>((v.ijk.y() + 0.5) * res_m),
                               static_cast<float>((v.ijk.z() + 0.5) * res_m));
      tree.updateNode(p, true);
    }
    tree.updateInnerOccupancy();
    if (!tree.writeBinary(path)) {
      if (error) *error = "cannot write " + path;
      return false;
    }
  } catch (const std::exception& e) {
    if (error) *error = std::string("octomap: ") + e.what();
    return false;
  }
  return true;
}

}  // namespace objscan

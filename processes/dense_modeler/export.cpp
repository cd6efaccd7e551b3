#include "processes/dense_modeler/export.h"

#include <octomap/OcTree.h>

#include <array>
#include <cstdint>

#include "common/ply.h"

namespace objscan {
namespace {

std::vector<std::string> ModelComments(const std::string& what, ScaleSource scale) {
  return {"objscan dense_modeler " + what + ", " + (IsMetric(scale) ? "mm" : "arbitrary unit"),
          std::string("scale: ") + ScaleDescription(scale)};
}

std::vector<PlyVertexProperty> XyzRgb() {
  std::vector<PlyVertexProperty> p = PlyXyz();
  for (const char* c : {"red", "green", "blue"}) p.push_back({c, PlyScalar::kUChar});
  return p;
}

}  // namespace

bool WriteVoxelPly(const std::string& path, const std::vector<CarvedVoxel>& voxels, double voxel_size,
                   ScaleSource scale, std::string* error) {
  PlyLayout layout;
  layout.comments = ModelComments("voxel centres", scale);
  layout.comments.push_back("voxel_size_mm " + std::to_string(voxel_size));
  layout.vertex_properties = XyzRgb();
  layout.vertex_properties.push_back({"votes", PlyScalar::kInt});
  layout.vertex_properties.push_back({"views", PlyScalar::kInt});
  return WritePlyFile(
      path, layout, voxels.size(),
      [&](size_t i, double* row) {
        const CarvedVoxel& v = voxels[i];
        for (int k = 0; k < 3; ++k) row[k] = (v.ijk[k] + 0.5) * voxel_size;
        for (int k = 0; k < 3; ++k) row[3 + k] = v.bgr[2 - k];
        row[6] = v.votes;
        row[7] = v.views;
      },
      nullptr, error);
}

bool WriteMeshPly(const std::string& path, const TriangleMesh& mesh, ScaleSource scale, std::string* error) {
  PlyLayout layout;
  layout.comments = ModelComments("surface", scale);
  layout.vertex_properties = XyzRgb();
  std::vector<Eigen::Vector3i> faces;
  faces.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) faces.emplace_back(t[0], t[1], t[2]);
  return WritePlyFile(
      path, layout, mesh.vertices.size(),
      [&](size_t i, double* row) {
        for (int k = 0; k < 3; ++k) row[k] = mesh.vertices[i][k];
        const std::array<uint8_t, 3> c = i < mesh.bgr.size() ? mesh.bgr[i] : std::array<uint8_t, 3>{{160, 160, 160}};
        for (int k = 0; k < 3; ++k) row[3 + k] = c[2 - k];
      },
      &faces, error);
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

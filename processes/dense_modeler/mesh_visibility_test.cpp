#include "processes/dense_modeler/mesh_visibility.h"

#include <gtest/gtest.h>

#include <cmath>

#include "processes/dense_modeler/synthetic_scene.h"

namespace objscan {
namespace {

// Closed, outward-oriented mesh of a sphere (marching tetrahedra on its signed distance).
TriangleMesh SphereMesh(const Eigen::Vector3d& centre, double radius, double spacing) {
  ScalarVolume vol;
  vol.spacing = spacing;
  vol.nx = vol.ny = vol.nz = static_cast<int>(std::ceil(2 * radius / spacing)) + 6;
  vol.origin = centre - Eigen::Vector3d::Constant(0.5 * (vol.nx - 1) * spacing);
  for (int z = 0; z < vol.nz; ++z)
    for (int y = 0; y < vol.ny; ++y)
      for (int x = 0; x < vol.nx; ++x)
        vol.values.push_back(
            static_cast<float>(radius - (vol.origin + Eigen::Vector3d(x, y, z) * spacing - centre).norm()));
  return ExtractIsosurface(vol, 0.f);
}

// b's vertices and triangles appended to a.
void Append(TriangleMesh* a, const TriangleMesh& b) {
  const int32_t offset = static_cast<int32_t>(a->vertices.size());
  a->vertices.insert(a->vertices.end(), b.vertices.begin(), b.vertices.end());
  for (auto t : b.triangles) a->triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
}

// Views on three rings (below, level with and above the centre) looking at it, at half resolution like the
// carving views (320 x 240, f = 400 px).
std::vector<CarvingView> ViewsAround(const Eigen::Vector3d& centre, double distance) {
  std::vector<CarvingView> views;
  PinholeCamera cam = testing_scene::DefaultCamera();
  cam.width = 320;
  cam.height = 240;
  cam.fx = cam.fy = 400;
  cam.cx = 159.5;
  cam.cy = 119.5;
  for (double elevation_deg : {-40.0, 0.0, 40.0})
    for (int i = 0; i < 12; ++i) {
      const double a = 2 * M_PI * (i + 0.5 * (elevation_deg > 0)) / 12, e = elevation_deg * M_PI / 180;
      const Eigen::Vector3d eye =
          centre + distance * Eigen::Vector3d(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      CarvingView v;
      v.camera = cam;
      v.world_from_camera = testing_scene::LookAt(eye, centre);
      views.push_back(v);
    }
  return views;
}

TEST(MeshVisibility, InnerSheetIsRemovedOuterSurfaceKept) {
  const Eigen::Vector3d centre(5, -3, 100);
  TriangleMesh mesh = SphereMesh(centre, 50, 2.0);
  const size_t outer_vertices = mesh.vertices.size(), outer_triangles = mesh.triangles.size();
  Append(&mesh, SphereMesh(centre, 42, 2.0));  // a second, outward-facing sheet 8 mm inside
  const std::vector<CarvingView> views = ViewsAround(centre, 800);

  MeshVisibilityOptions options;
  const std::vector<VertexViews> counts = CountSeeingViews(mesh, views, options);
  ASSERT_EQ(counts.size(), mesh.vertices.size());
  int outer_rarely_seen = 0, inner_seen = 0;
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    EXPECT_LE(counts[i].seen, counts[i].facing);
    if (i < outer_vertices)
      outer_rarely_seen += counts[i].seen < 5;
    else
      inner_seen += counts[i].seen > 0;
  }
  EXPECT_EQ(outer_rarely_seen, 0);  // every outer vertex faces (and is seen by) several of the 36 views
  EXPECT_EQ(inner_seen, 0);         // the inner sheet faces the views but is always behind the outer one

  const size_t all_vertices = mesh.vertices.size();
  const MeshVisibilityStats stats = RemoveOccludedMeshParts(&mesh, views, options);
  EXPECT_EQ(stats.views, 36);
  EXPECT_EQ(stats.vertices_removed, static_cast<int64_t>(all_vertices - outer_vertices));
  EXPECT_EQ(mesh.vertices.size(), outer_vertices);
  EXPECT_EQ(mesh.triangles.size(), outer_triangles);
  for (const auto& v : mesh.vertices) EXPECT_NEAR((v.cast<double>() - centre).norm(), 50.0, 1.0);
  EXPECT_TRUE(IsClosedOrientedMesh(mesh));
}

TEST(MeshVisibility, SurfaceSeenAtGrazingAnglesIsNotSelfOccluded) {
  // A flat textured top, 100 x 100 mm at z = 250, seen from 800 mm away and 136 mm above: 10 deg over the plane, as
  // the orbit sees a cylinder's top. Rendered at half resolution a pixel spans ~10 mm of depth on it.
  ScalarVolume vol;
  vol.spacing = 2.0;
  vol.nx = vol.ny = 51;
  vol.nz = 5;
  vol.origin = Eigen::Vector3d(-50, -50, 246);
  for (int z = 0; z < vol.nz; ++z)
    for (int y = 0; y < vol.ny; ++y)
      for (int x = 0; x < vol.nx; ++x) vol.values.push_back(static_cast<float>(250.3 - (vol.origin.z() + 2.0 * z)));
  TriangleMesh mesh = ExtractIsosurface(vol, 0.f);
  // Keep the top only (the volume's sides close the slab).
  TriangleMesh top;
  std::vector<int32_t> index(mesh.vertices.size(), -1);
  for (const auto& t : mesh.triangles) {
    bool up = true;
    for (int k = 0; k < 3; ++k) up = up && std::abs(mesh.vertices[t[k]].z() - 250.3f) < 0.01f;
    if (!up) continue;
    std::array<int32_t, 3> u;
    for (int k = 0; k < 3; ++k) {
      if (index[t[k]] < 0) {
        index[t[k]] = static_cast<int32_t>(top.vertices.size());
        top.vertices.push_back(mesh.vertices[t[k]]);
      }
      u[k] = index[t[k]];
    }
    top.triangles.push_back(u);
  }
  ASSERT_GT(top.triangles.size(), 1000u);
  std::vector<CarvingView> views;
  for (const CarvingView& v : ViewsAround(Eigen::Vector3d(0, 0, 250), 800)) {
    CarvingView g = v;
    const Eigen::Vector3d eye = v.world_from_camera.translation();
    if (eye.z() < 250) continue;
    g.world_from_camera = testing_scene::LookAt(Eigen::Vector3d(eye.x(), eye.y(), 386), Eigen::Vector3d(0, 0, 250));
    views.push_back(g);
  }
  const size_t before = top.vertices.size();
  const MeshVisibilityStats stats = RemoveOccludedMeshParts(&top, views, MeshVisibilityOptions());
  EXPECT_EQ(stats.vertices_removed, 0);
  EXPECT_EQ(top.vertices.size(), before);
}

TEST(MeshVisibility, OffAndBadInput) {
  TriangleMesh mesh = SphereMesh(Eigen::Vector3d(0, 0, 100), 30, 2.0);
  Append(&mesh, SphereMesh(Eigen::Vector3d(0, 0, 100), 20, 2.0));
  const size_t n = mesh.vertices.size();
  MeshVisibilityOptions off;
  off.min_seen_views = 0;
  off.min_seen_fraction = 0;
  EXPECT_EQ(RemoveOccludedMeshParts(&mesh, ViewsAround(Eigen::Vector3d(0, 0, 100), 600), off).vertices_removed, 0);
  EXPECT_EQ(RemoveOccludedMeshParts(&mesh, {}, MeshVisibilityOptions()).vertices_removed, 0);
  std::vector<CarvingView> invalid = ViewsAround(Eigen::Vector3d(0, 0, 100), 600);
  for (CarvingView& v : invalid) v.camera.fx = 0;
  EXPECT_EQ(RemoveOccludedMeshParts(&mesh, invalid, MeshVisibilityOptions()).views, 0);
  EXPECT_EQ(mesh.vertices.size(), n);
  TriangleMesh empty;
  EXPECT_EQ(RemoveOccludedMeshParts(&empty, invalid, MeshVisibilityOptions()).vertices_removed, 0);

  std::string why;
  EXPECT_TRUE(ValidateMeshVisibilityOptions(MeshVisibilityOptions(), &why)) << why;
  MeshVisibilityOptions bad;
  bad.min_seen_fraction = 1.5;
  bad.depth_tolerance_mm = 0;
  bad.max_views = 0;
  EXPECT_FALSE(ValidateMeshVisibilityOptions(bad, &why));
  EXPECT_NE(why.find("fraction"), std::string::npos);
  EXPECT_NE(why.find("tolerance"), std::string::npos);
  EXPECT_NE(why.find("max views"), std::string::npos);
}

}  // namespace
}  // namespace objscan

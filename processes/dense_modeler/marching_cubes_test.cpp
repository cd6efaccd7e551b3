#include "processes/dense_modeler/marching_cubes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace objscan {
namespace {

ScalarVolume SphereVolume(int n, double spacing, const Eigen::Vector3d& center, double radius) {
  ScalarVolume vol;
  vol.nx = vol.ny = vol.nz = n;
  vol.spacing = spacing;
  vol.origin = Eigen::Vector3d::Zero();
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const Eigen::Vector3d p = Eigen::Vector3d(x, y, z) * spacing;
        vol.values.push_back(static_cast<float>(radius - (p - center).norm()));  // > 0 inside
        vol.bgr.push_back({{static_cast<uint8_t>(x), static_cast<uint8_t>(y), static_cast<uint8_t>(z)}});
      }
  return vol;
}

TEST(MarchingCubes, AnalyticSphereClosedAndAccurate) {
  const double spacing = 2.0, radius = 25.0;
  const Eigen::Vector3d center(31.3, 30.7, 32.1);
  const ScalarVolume vol = SphereVolume(33, spacing, center, radius);
  const TriangleMesh mesh = ExtractIsosurface(vol, 0.f);
  ASSERT_GT(mesh.triangles.size(), 100u);
  EXPECT_TRUE(IsClosedOrientedMesh(mesh));
  double worst = 0;
  for (const auto& v : mesh.vertices) worst = std::max(worst, std::abs((v.cast<double>() - center).norm() - radius));
  EXPECT_LT(worst, 0.5 * spacing);
  // Outward orientation: signed volume positive and close to the sphere volume.
  double volume = 0;
  for (const auto& t : mesh.triangles)
    volume += mesh.vertices[t[0]].cast<double>().dot(
                  mesh.vertices[t[1]].cast<double>().cross(mesh.vertices[t[2]].cast<double>())) /
              6.0;
  EXPECT_NEAR(volume, 4.0 / 3.0 * M_PI * radius * radius * radius, 0.03 * 4.0 / 3.0 * M_PI * std::pow(radius, 3));
  ASSERT_EQ(mesh.bgr.size(), mesh.vertices.size());
}

TEST(MarchingCubes, UndefinedSamplesLeaveTheMeshOpen) {
  const double spacing = 2.0, radius = 25.0;
  const Eigen::Vector3d center(31.3, 30.7, 32.1);
  ScalarVolume vol = SphereVolume(33, spacing, center, radius);
  const size_t full = ExtractIsosurface(vol, 0.f).triangles.size();
  // Undefine every sample below the sphere's centre plane: that half gets no triangles.
  for (int z = 0; z < vol.nz; ++z)
    for (int y = 0; y < vol.ny; ++y)
      for (int x = 0; x < vol.nx; ++x)
        if (z * spacing < center.z()) vol.values[vol.Index(x, y, z)] = std::numeric_limits<float>::quiet_NaN();
  const TriangleMesh mesh = ExtractIsosurface(vol, 0.f);
  ASSERT_GT(mesh.triangles.size(), full / 4);
  EXPECT_LT(mesh.triangles.size(), full * 3 / 5);
  EXPECT_FALSE(IsClosedOrientedMesh(mesh));
  for (const auto& v : mesh.vertices) EXPECT_GE(v.z(), center.z() - spacing);
}

TEST(MarchingCubes, VoxelisedSphereClosedWithinHalfVoxel) {
  const double size = 2.0, radius = 30.0;
  const Eigen::Vector3d center(1.1, -0.7, 40.3);
  std::vector<CarvedVoxel> voxels;
  for (int k = -5; k < 45; ++k)
    for (int j = -25; j < 25; ++j)
      for (int i = -25; i < 25; ++i) {
        const Eigen::Vector3d c = (Eigen::Vector3d(i, j, k) + Eigen::Vector3d::Constant(0.5)) * size;
        if ((c - center).norm() > radius) continue;
        CarvedVoxel v;
        v.ijk = Eigen::Vector3i(i, j, k);
        v.bgr = {{10, 20, 30}};
        voxels.push_back(v);
      }
  const TriangleMesh mesh = MeshFromVoxels(voxels, size, 1);
  ASSERT_GT(mesh.triangles.size(), 100u);
  EXPECT_TRUE(IsClosedOrientedMesh(mesh));
  double worst = 0, sum = 0;
  for (const auto& v : mesh.vertices) {
    const double d = std::abs((v.cast<double>() - center).norm() - radius);
    worst = std::max(worst, d);
    sum += d;
  }
  std::printf("voxelised sphere: %zu vertices, mean |d| %.3f mm, max %.3f mm (voxel %.1f)\n", mesh.vertices.size(),
              sum / mesh.vertices.size(), worst, size);
  EXPECT_LT(worst, 0.5 * size);
  for (const auto& c : mesh.bgr) EXPECT_EQ(c[2], 30);
}

// A large sphere and a small one far from it in one mesh: the small piece (< 1 % of the large one's triangles) goes,
// the large one stays whole and closed, with its vertices renumbered consistently.
TEST(MarchingCubes, SmallMeshPiecesRemoved) {
  TriangleMesh big = ExtractIsosurface(SphereVolume(40, 1.0, Eigen::Vector3d(20, 20, 20), 15), 0.f);
  const TriangleMesh small = ExtractIsosurface(SphereVolume(8, 1.0, Eigen::Vector3d(3.5, 3.5, 3.5), 1.6), 0.f);
  ASSERT_GT(small.triangles.size(), 0u);
  ASSERT_LT(small.triangles.size() * 100, big.triangles.size());
  const size_t big_triangles = big.triangles.size(), big_vertices = big.vertices.size();
  TriangleMesh both = big;
  const int32_t offset = static_cast<int32_t>(both.vertices.size());
  for (size_t i = 0; i < small.vertices.size(); ++i) {
    both.vertices.push_back(small.vertices[i] + Eigen::Vector3f(100, 0, 0));
    both.bgr.push_back(small.bgr[i]);
  }
  for (const auto& t : small.triangles) both.triangles.push_back({{t[0] + offset, t[1] + offset, t[2] + offset}});
  TriangleMesh unchanged = both;
  EXPECT_EQ(RemoveSmallMeshPieces(&unchanged, 0.0), 0);
  EXPECT_EQ(unchanged.triangles.size(), both.triangles.size());
  EXPECT_EQ(RemoveSmallMeshPieces(&both, 0.01), static_cast<int64_t>(small.triangles.size()));
  EXPECT_EQ(both.triangles.size(), big_triangles);
  EXPECT_EQ(both.vertices.size(), big_vertices);
  EXPECT_EQ(both.bgr.size(), both.vertices.size());
  EXPECT_TRUE(IsClosedOrientedMesh(both));
  for (const auto& v : both.vertices) EXPECT_LT(v.x(), 50.f);  // none of the small sphere's
  // Both pieces kept when the small one is above the fraction.
  TriangleMesh again = big;
  for (const auto& v : small.vertices) again.vertices.push_back(v + Eigen::Vector3f(100, 0, 0));
  again.bgr.resize(again.vertices.size());
  for (const auto& t : small.triangles) again.triangles.push_back({{t[0] + offset, t[1] + offset, t[2] + offset}});
  EXPECT_EQ(RemoveSmallMeshPieces(&again, 1e-4), 0);
}

// The upper half of a sphere (open along its equator): each ring peeled off its border lowers the rim by about a
// triangle; a closed sphere has no border and stays as it is.
TEST(MarchingCubes, KeepMeshTrianglesReportsWhereVerticesWent) {
  TriangleMesh mesh = ExtractIsosurface(SphereVolume(20, 1.0, Eigen::Vector3d(10, 10, 10), 6), 0.f);
  const TriangleMesh before = mesh;
  std::vector<char> keep(mesh.triangles.size(), 1);
  std::vector<int32_t> new_index;
  EXPECT_EQ(KeepMeshTriangles(&mesh, keep, &new_index), 0);
  ASSERT_EQ(new_index.size(), before.vertices.size());
  for (size_t i = 0; i < new_index.size(); ++i) EXPECT_EQ(new_index[i], static_cast<int32_t>(i));
  for (size_t t = 0; t < keep.size(); t += 2) keep[t] = 0;
  const int64_t dropped = KeepMeshTriangles(&mesh, keep, &new_index);
  EXPECT_EQ(dropped, static_cast<int64_t>((keep.size() + 1) / 2));
  ASSERT_EQ(new_index.size(), before.vertices.size());
  size_t kept = 0;
  for (size_t i = 0; i < new_index.size(); ++i) {
    if (new_index[i] < 0) continue;
    ++kept;
    ASSERT_LT(new_index[i], static_cast<int32_t>(mesh.vertices.size()));
    EXPECT_EQ(mesh.vertices[new_index[i]], before.vertices[i]) << "vertex " << i;
  }
  EXPECT_EQ(kept, mesh.vertices.size());
}

TEST(MarchingCubes, TrimMeshBorderPeelsRingsOffOpenBordersOnly) {
  const double spacing = 2.0, radius = 25.0;
  const Eigen::Vector3d center(31.3, 30.7, 32.1);
  ScalarVolume vol = SphereVolume(33, spacing, center, radius);
  TriangleMesh closed = ExtractIsosurface(vol, 0.f);
  const size_t closed_triangles = closed.triangles.size();
  EXPECT_EQ(TrimMeshBorder(&closed, 3), 0);
  EXPECT_EQ(closed.triangles.size(), closed_triangles);
  for (int z = 0; z < vol.nz; ++z)
    for (int y = 0; y < vol.ny; ++y)
      for (int x = 0; x < vol.nx; ++x)
        if (z * spacing < center.z()) vol.values[vol.Index(x, y, z)] = std::numeric_limits<float>::quiet_NaN();
  const TriangleMesh open = ExtractIsosurface(vol, 0.f);
  auto lowest = [](const TriangleMesh& m) {
    float z = 1e9f;
    for (const auto& v : m.vertices) z = std::min(z, v.z());
    return z;
  };
  TriangleMesh one = open, three = open;
  const int64_t dropped_one = TrimMeshBorder(&one, 1), dropped_three = TrimMeshBorder(&three, 3);
  EXPECT_GT(dropped_one, 0);
  EXPECT_GT(dropped_three, 2 * dropped_one);
  EXPECT_EQ(one.triangles.size() + static_cast<size_t>(dropped_one), open.triangles.size());
  EXPECT_GT(lowest(one), lowest(open));
  EXPECT_GT(lowest(three), lowest(one) + 1.0f);
  EXPECT_EQ(one.bgr.size(), one.vertices.size());
  for (const auto& t : three.triangles)
    for (int k = 0; k < 3; ++k) ASSERT_LT(static_cast<size_t>(t[k]), three.vertices.size());
  TriangleMesh untouched = open;
  EXPECT_EQ(TrimMeshBorder(&untouched, 0), 0);
  EXPECT_EQ(untouched.triangles.size(), open.triangles.size());
}

// A sheet over a (columns + 1) x (rows + 1) grid of 1 mm steps, vertex (i, j) at place(i, j); triangles oriented
// like the +z normal of a flat sheet in the xy plane.
template <class Place>
TriangleMesh GridSheet(int columns, int rows, Place place) {
  TriangleMesh m;
  for (int j = 0; j <= rows; ++j)
    for (int i = 0; i <= columns; ++i) {
      m.vertices.push_back(place(i, j).template cast<float>());
      m.bgr.push_back({{100, 100, 100}});
    }
  auto at = [columns](int i, int j) { return j * (columns + 1) + i; };
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < columns; ++i) {
      m.triangles.push_back({{at(i, j), at(i + 1, j), at(i + 1, j + 1)}});
      m.triangles.push_back({{at(i, j), at(i + 1, j + 1), at(i, j + 1)}});
    }
  return m;
}

// A flat 40 x 40 mm sheet in the xy plane whose last 8 mm (x > 40) fold down by fold_deg.
TriangleMesh FoldedSheet(double fold_deg) {
  const double fold = fold_deg * M_PI / 180;
  return GridSheet(48, 40, [fold](int i, int j) {
    const double s = std::max(0, i - 40);
    return Eigen::Vector3d(std::min(i, 40) + s * std::cos(fold), j, -s * std::sin(fold));
  });
}

// The lowest z of the mesh and its vertices on the flat part up to 2 mm from the fold.
void Inspect(const TriangleMesh& m, float* lowest, int* flat_kept) {
  *lowest = 0;
  *flat_kept = 0;
  for (const Eigen::Vector3f& v : m.vertices) {
    *lowest = std::min(*lowest, v.z());
    *flat_kept += v.z() == 0 && v.x() <= 38;
  }
}

// The last 8 mm of a sheet folded down by 60 deg (the curled rim of a hole) go, the flat part stays; a flat sheet and
// a 90 deg crease reaching the border (an L of two wide faces) lose nothing. Both tests of a curled triangle are
// pinned: with the offset test, the last ~1.7 mm of the flap (within 1.5 mm of the fold's tangent plane) stay;
// with the angle test alone (offset 0) the whole flap goes, while the flat sheet, the crease (its border vertices'
// normals are the mean of both faces: a per-vertex test would eat it) and a gentle 15 deg fold keep everything.
TEST(MarchingCubes, TrimCurledBordersPeelsFlapsOnly) {
  const CurledBorderOptions o;  // defaults: 20 deg, 1.5 mm off the tangent plane, 10 passes, 8 interior rings
  std::string why;
  ASSERT_TRUE(ValidateCurledBorderOptions(o, &why)) << why;
  TriangleMesh flap = FoldedSheet(60);
  const size_t before = flap.triangles.size();
  const int64_t dropped = TrimCurledBorders(&flap, o);
  EXPECT_EQ(flap.triangles.size() + static_cast<size_t>(dropped), before);
  float lowest = 0;
  int flat_kept = 0;
  Inspect(flap, &lowest, &flat_kept);
  EXPECT_GT(lowest, -2.0f);        // the flap reached 6.9 mm down
  EXPECT_LT(lowest, -1.0f);        // the offset test keeps its first ~1.7 mm
  EXPECT_EQ(flat_kept, 39 * 41);   // every vertex of the flat part up to 2 mm from the fold
  EXPECT_GE(dropped, 2 * 40 * 6);  // at least six of the flap's eight rows of cells
  for (const auto& t : flap.triangles)
    for (int k = 0; k < 3; ++k) ASSERT_LT(static_cast<size_t>(t[k]), flap.vertices.size());

  auto flat = [] { return GridSheet(40, 40, [](int i, int j) { return Eigen::Vector3d(i, j, 0); }); };
  auto crease = [] {
    return GridSheet(
        80, 40, [](int i, int j) { return i <= 40 ? Eigen::Vector3d(i, j, 0) : Eigen::Vector3d(40, j, -(i - 40)); });
  };
  TriangleMesh m = flat();
  EXPECT_EQ(TrimCurledBorders(&m, o), 0);
  m = crease();
  EXPECT_EQ(TrimCurledBorders(&m, o), 0);

  CurledBorderOptions angle_only = o;
  angle_only.min_offset_mm = 0;
  m = FoldedSheet(60);
  EXPECT_GT(TrimCurledBorders(&m, angle_only), 0);
  Inspect(m, &lowest, &flat_kept);
  EXPECT_EQ(lowest, 0.0f);  // all of the flap
  EXPECT_EQ(flat_kept, 39 * 41);
  m = flat();
  EXPECT_EQ(TrimCurledBorders(&m, angle_only), 0);
  m = crease();
  EXPECT_EQ(TrimCurledBorders(&m, angle_only), 0);
  m = FoldedSheet(15);
  EXPECT_EQ(TrimCurledBorders(&m, angle_only), 0);

  CurledBorderOptions none = o;
  none.max_rings = 0;
  m = FoldedSheet(60);
  EXPECT_EQ(TrimCurledBorders(&m, none), 0);

  CurledBorderOptions bad = o;
  bad.max_rings = 51;
  bad.max_angle_deg = 90;
  bad.radius_mm = 0;
  bad.interior_rings = 1;
  bad.min_offset_mm = -1;
  EXPECT_FALSE(ValidateCurledBorderOptions(bad, &why));
  for (const char* field : {"max_rings", "max_angle_deg", "radius_mm", "interior_rings", "min_offset_mm"})
    EXPECT_NE(why.find(field), std::string::npos) << why;
}

TEST(MarchingCubes, EmptyAndDegenerateInput) {
  EXPECT_TRUE(MeshFromVoxels({}, 2.0).triangles.empty());
  ScalarVolume bad;
  bad.nx = bad.ny = bad.nz = 3;  // no values
  EXPECT_TRUE(ExtractIsosurface(bad, 0.f).triangles.empty());
  EXPECT_FALSE(IsClosedOrientedMesh(TriangleMesh{}));
}

}  // namespace
}  // namespace objscan

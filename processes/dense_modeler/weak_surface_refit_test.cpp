#include "processes/dense_modeler/weak_surface_refit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>

#include "processes/dense_modeler/voxel_votes.h"

namespace objscan {
namespace {

constexpr double kVoxel = 2.0;     // mm
constexpr double kRadius = 100.0;  // mm, the sim sphere's radius
const Eigen::Vector3d kCentre(110.3, 109.7, 110.9);

// Closed mesh of the sphere (marching cubes of its exact signed distance, 2 mm samples).
TriangleMesh SphereMesh() {
  ScalarVolume vol;
  vol.nx = vol.ny = vol.nz = 111;
  vol.spacing = kVoxel;
  vol.origin = Eigen::Vector3d(0.37, 0.61, 0.83);  // samples off the voxel faces: every vertex has one nearest voxel
  for (int z = 0; z < vol.nz; ++z)
    for (int y = 0; y < vol.ny; ++y)
      for (int x = 0; x < vol.nx; ++x) {
        vol.values.push_back(
            static_cast<float>(kRadius - (vol.origin + Eigen::Vector3d(x, y, z) * kVoxel - kCentre).norm()));
        vol.bgr.push_back({{128, 128, 128}});
      }
  return ExtractIsosurface(vol, 0.f);
}

double RadialError(const Eigen::Vector3f& v) { return (v.cast<double>() - kCentre).norm() - kRadius; }

Eigen::Vector3i CellOf(const Eigen::Vector3f& p) { return VoxelIndexOf(p.cast<double>(), kVoxel); }

// The vertices whose voxel holds a vertex of `patch`: they are the weak ones for the voxels of WeakVoxels (a
// vertex's nearest voxel centre is its own cell's).
std::vector<char> WeakCells(const TriangleMesh& mesh, const std::vector<char>& patch) {
  std::set<uint64_t> weak;
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    if (patch[i]) weak.insert(VoxelKey(CellOf(mesh.vertices[i])));
  std::vector<char> flags(mesh.vertices.size(), 0);
  for (size_t i = 0; i < mesh.vertices.size(); ++i) flags[i] = weak.count(VoxelKey(CellOf(mesh.vertices[i]))) > 0;
  return flags;
}

// One voxel per cell holding a mesh vertex: 3 votes where a vertex of `patch` is, 200 elsewhere.
std::vector<CarvedVoxel> WeakVoxels(const TriangleMesh& mesh, const std::vector<char>& patch) {
  std::map<uint64_t, CarvedVoxel> cells;  // by key: a fixed order
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3i ijk = CellOf(mesh.vertices[i]);
    auto [it, added] = cells.emplace(VoxelKey(ijk), CarvedVoxel());
    if (added) it->second.ijk = ijk, it->second.votes = 200;
    if (patch[i]) it->second.votes = 3;
  }
  std::vector<CarvedVoxel> voxels;
  for (const auto& [key, v] : cells) voxels.push_back(v);
  return voxels;
}

// Vertices within `reach` mm of the sphere's point in direction `dir` (unit).
std::vector<char> Patch(const TriangleMesh& mesh, const Eigen::Vector3d& dir, double reach) {
  const Eigen::Vector3d pole = kCentre + kRadius * dir;
  std::vector<char> in(mesh.vertices.size(), 0);
  for (size_t i = 0; i < mesh.vertices.size(); ++i) in[i] = (mesh.vertices[i].cast<double>() - pole).norm() < reach;
  return in;
}

// Moves the flagged vertices radially by offset(vertex) mm (negative: inwards).
template <class Offset>
void Displace(TriangleMesh* mesh, const std::vector<char>& flagged, Offset offset) {
  for (size_t i = 0; i < mesh->vertices.size(); ++i)
    if (flagged[i]) {
      const Eigen::Vector3d d = (mesh->vertices[i].cast<double>() - kCentre).normalized();
      const double by = offset(mesh->vertices[i].cast<double>());
      mesh->vertices[i] += (d * by).cast<float>();
    }
}

// A smooth dent, depth mm at the sphere's point in direction dir, zero at reach mm from it.
auto Dent(const Eigen::Vector3d& dir, double depth, double reach) {
  const Eigen::Vector3d pole = kCentre + kRadius * dir;
  return [=](const Eigen::Vector3d& p) {
    const double d = std::min((p - pole).norm(), reach);
    return -depth * 0.5 * (1 + std::cos(M_PI * d / reach));
  };
}

TEST(WeakSurfaceRefit, WeakDentPulledOntoTheStrongSurfaceAround) {
  TriangleMesh mesh = SphereMesh();
  ASSERT_GT(mesh.vertices.size(), 10000u);
  const Eigen::Vector3d dir = Eigen::Vector3d(1, 0.5, 0.7).normalized();
  const std::vector<char> patch = Patch(mesh, dir, 10.0);
  Displace(&mesh, patch, Dent(dir, 3.0, 10.0));
  // The voxels under the dented mesh, weak where the dent is; the weak vertices share their voxels.
  const std::vector<char> weak = WeakCells(mesh, patch);
  const std::vector<CarvedVoxel> voxels = WeakVoxels(mesh, patch);
  const TriangleMesh before = mesh;
  WeakRefitOptions every;  // every weak vertex moves, however close it already is
  every.min_move_mm = 0;
  const WeakRefitStats s = RefitWeakMeshVertices(&mesh, voxels, kVoxel, every);

  int64_t n_weak = 0;
  double worst_weak_before = 0, worst_weak = 0, worst_strong = 0;
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (weak[i]) {
      ++n_weak;
      worst_weak_before = std::max(worst_weak_before, std::abs(RadialError(before.vertices[i])));
      worst_weak = std::max(worst_weak, std::abs(RadialError(mesh.vertices[i])));
    } else {
      worst_strong = std::max(worst_strong, std::abs(RadialError(before.vertices[i])));
      EXPECT_EQ(mesh.vertices[i], before.vertices[i]) << "strong vertex " << i << " moved";
    }
  }
  ASSERT_GT(n_weak, 100);
  EXPECT_GT(worst_weak_before, 2.5);
  EXPECT_DOUBLE_EQ(s.median_votes, 200);
  EXPECT_EQ(s.weak, n_weak);
  EXPECT_EQ(s.moved, s.weak);
  EXPECT_GT(s.max_abs_move_mm, 2.5);
  EXPECT_LT(s.max_abs_move_mm, 3.5);
  // Back on the sphere (3 mm off before): within the marching cubes' own error (0.015 mm) plus the quadratic's
  // (the sphere is not one); measured 0.010 mm.
  EXPECT_LT(worst_weak, 0.05);

  // Default: only vertices more than min_move_mm (1 mm) off the fit move; the dent's shallow rim stays.
  TriangleMesh outliers = before;
  std::vector<WeakRefitOutcome> outcome;
  const WeakRefitStats d = RefitWeakMeshVertices(&outliers, voxels, kVoxel, WeakRefitOptions(), &outcome);
  ASSERT_EQ(outcome.size(), outliers.vertices.size());
  EXPECT_GT(d.moved, 0);
  EXPECT_GT(d.close, 0);
  EXPECT_EQ(d.moved + d.close, d.weak);
  for (size_t i = 0; i < outliers.vertices.size(); ++i) {
    const double was = std::abs(RadialError(before.vertices[i])), now = std::abs(RadialError(outliers.vertices[i]));
    if (outcome[i] == WeakRefitOutcome::kMoved) {
      EXPECT_GT(was, 0.9) << "vertex " << i;
      EXPECT_LT(now, 0.05) << "vertex " << i;
    } else {
      EXPECT_EQ(outliers.vertices[i], before.vertices[i]) << "vertex " << i;
      EXPECT_LT(now, 1.1) << "vertex " << i;
    }
  }
}

TEST(WeakSurfaceRefit, OffOrNothingWeakLeavesTheMeshIdentical) {
  TriangleMesh mesh = SphereMesh();
  const std::vector<char> patch = Patch(mesh, Eigen::Vector3d::UnitX(), 8.0);
  const std::vector<CarvedVoxel> voxels = WeakVoxels(mesh, patch);
  Displace(&mesh, WeakCells(mesh, patch), Dent(Eigen::Vector3d::UnitX(), 3.0, 10.0));
  const TriangleMesh before = mesh;
  WeakRefitOptions off;
  off.relative_votes = 0;
  WeakRefitStats s = RefitWeakMeshVertices(&mesh, voxels, kVoxel, off);
  EXPECT_EQ(s.weak, 0);
  EXPECT_EQ(mesh.vertices, before.vertices);
  // Uniform votes: nothing is weak.
  s = RefitWeakMeshVertices(&mesh, WeakVoxels(mesh, std::vector<char>(mesh.vertices.size(), 0)), kVoxel,
                            WeakRefitOptions());
  EXPECT_EQ(s.weak, 0);
  EXPECT_EQ(mesh.vertices, before.vertices);
  // A NaN vertex (in the dent) is left alone and does not disturb the others.
  TriangleMesh with_nan = before;
  size_t bad = 0;
  while (!patch[bad]) ++bad;
  with_nan.vertices[bad] = Eigen::Vector3f::Constant(std::nanf(""));
  std::vector<WeakRefitOutcome> outcome;
  s = RefitWeakMeshVertices(&with_nan, voxels, kVoxel, WeakRefitOptions(), &outcome);
  EXPECT_GT(s.moved, 0);
  EXPECT_EQ(outcome[bad], WeakRefitOutcome::kUnused);
  EXPECT_TRUE(std::isnan(with_nan.vertices[bad].x()));
  for (size_t i = 0; i < with_nan.vertices.size(); ++i)
    if (i != bad) {
      EXPECT_TRUE(with_nan.vertices[i].allFinite()) << "vertex " << i;
    }
  // No voxels, no triangles.
  s = RefitWeakMeshVertices(&mesh, {}, kVoxel, WeakRefitOptions(), &outcome);
  EXPECT_EQ(s.weak, 0);
  EXPECT_EQ(mesh.vertices, before.vertices);
  EXPECT_EQ(mesh.triangles, before.triangles);
  EXPECT_EQ(outcome, std::vector<WeakRefitOutcome>(mesh.vertices.size(), WeakRefitOutcome::kStrong));
  TriangleMesh empty;
  EXPECT_EQ(RefitWeakMeshVertices(&empty, voxels, kVoxel, WeakRefitOptions()).weak, 0);
}

// The upper half of the sphere, weak along its open rim (within 3 mm of the cut): strong vertices lie on one side
// of the rim's vertices only, so they are extrapolated, never moved.
TriangleMesh UpperHalf(std::vector<char>* rim) {
  TriangleMesh mesh = SphereMesh();
  std::vector<char> keep(mesh.triangles.size(), 0);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    float z = 0;
    for (int k = 0; k < 3; ++k) z += mesh.vertices[mesh.triangles[t][k]].z() / 3;
    keep[t] = z > kCentre.z();
  }
  KeepMeshTriangles(&mesh, keep);
  rim->assign(mesh.vertices.size(), 0);
  for (size_t i = 0; i < mesh.vertices.size(); ++i) (*rim)[i] = mesh.vertices[i].z() < kCentre.z() + 3;
  return mesh;
}

TEST(WeakSurfaceRefit, WeakRimStaysOnTheSurfaceAndIsDroppedOffIt) {
  std::vector<char> rim;
  TriangleMesh mesh = UpperHalf(&rim);
  const std::vector<char> weak = WeakCells(mesh, rim);
  const std::vector<CarvedVoxel> voxels = WeakVoxels(mesh, rim);
  std::vector<char> border;
  ASSERT_TRUE(MarkBorderVertices(mesh, std::vector<char>(mesh.triangles.size(), 1), &border));

  // On the surface: nothing moves, nothing is dropped.
  TriangleMesh kept = mesh;
  WeakRefitStats s = RefitWeakMeshVertices(&kept, voxels, kVoxel, WeakRefitOptions());
  EXPECT_GT(s.weak, 100);
  EXPECT_EQ(s.moved, 0);
  EXPECT_EQ(s.rim_vertices_dropped, 0);
  EXPECT_EQ(kept.vertices, mesh.vertices);
  EXPECT_EQ(kept.triangles, mesh.triangles);

  // The rim flared 2 mm outwards, the voxels under the flared mesh (weak where a rim vertex is): still never moved;
  // with rim_drop_mm off nothing changes, by default the border's flared vertices (2 mm off the extrapolated fit)
  // go with their triangles.
  Displace(&mesh, rim, [](const Eigen::Vector3d&) { return 2.0; });
  const std::vector<char> weak_flared = WeakCells(mesh, rim);
  const std::vector<CarvedVoxel> voxels_flared = WeakVoxels(mesh, rim);
  TriangleMesh flared = mesh;
  WeakRefitOptions no_drop;
  no_drop.rim_drop_mm = 0;
  s = RefitWeakMeshVertices(&flared, voxels_flared, kVoxel, no_drop);
  EXPECT_EQ(s.moved, 0);
  EXPECT_EQ(s.not_surrounded, s.weak);
  EXPECT_EQ(flared.vertices, mesh.vertices);

  std::vector<WeakRefitOutcome> outcome;
  s = RefitWeakMeshVertices(&flared, voxels_flared, kVoxel, WeakRefitOptions(), &outcome);
  int64_t flared_border = 0;
  for (size_t i = 0; i < mesh.vertices.size(); ++i) flared_border += rim[i] && border[i];
  EXPECT_EQ(s.moved, 0);
  EXPECT_EQ(s.rim_vertices_dropped, flared_border);
  EXPECT_GT(s.rim_triangles_dropped, flared_border);
  EXPECT_EQ(static_cast<int64_t>(flared.triangles.size()),
            static_cast<int64_t>(mesh.triangles.size()) - s.rim_triangles_dropped);
  // The surviving vertices are the input's, unmoved (found by position), and the outcomes follow the renumbering:
  // weak ones (the inner rows of the flared band, and unflared vertices sharing their voxels) not surrounded, the
  // others strong.
  std::map<std::array<float, 3>, size_t> input_index;
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    input_index[{{mesh.vertices[i].x(), mesh.vertices[i].y(), mesh.vertices[i].z()}}] = i;
  ASSERT_EQ(outcome.size(), flared.vertices.size());
  int64_t strong = 0, flared_left = 0;
  for (size_t i = 0; i < flared.vertices.size(); ++i) {
    const auto it = input_index.find({{flared.vertices[i].x(), flared.vertices[i].y(), flared.vertices[i].z()}});
    ASSERT_NE(it, input_index.end()) << "vertex " << i << " moved";
    const size_t j = it->second;
    EXPECT_FALSE(rim[j] && border[j]) << "flared border vertex " << j << " kept";
    EXPECT_EQ(outcome[i], weak_flared[j] ? WeakRefitOutcome::kNotSurrounded : WeakRefitOutcome::kStrong)
        << "vertex " << i;
    strong += !weak_flared[j];
    flared_left += rim[j];
  }
  EXPECT_GT(strong, 1000);
  EXPECT_GT(flared_left, 100);
}

TEST(WeakSurfaceRefit, NoisyOrSparseStrongSurfaceLeavesTheWeakVertex) {
  const Eigen::Vector3d dir = Eigen::Vector3d(0.2, -1, 0.4).normalized();
  {
    // Strong vertices 1 mm rough (uniform +-1.7 mm along the radius): the fit does not explain them.
    TriangleMesh mesh = SphereMesh();
    const std::vector<char> patch = Patch(mesh, dir, 8.0), weak = WeakCells(mesh, patch);
    const std::vector<CarvedVoxel> voxels = WeakVoxels(mesh, patch);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> noise(-1.7, 1.7);
    Displace(&mesh, std::vector<char>(mesh.vertices.size(), 1), [&](const Eigen::Vector3d&) { return noise(rng); });
    const TriangleMesh before = mesh;
    const WeakRefitStats s = RefitWeakMeshVertices(&mesh, voxels, kVoxel, WeakRefitOptions());
    EXPECT_GT(s.weak, 20);
    EXPECT_EQ(s.moved, 0);
    EXPECT_GT(s.poor_fit, s.weak * 9 / 10);
    EXPECT_EQ(mesh.vertices, before.vertices);
  }
  {
    // A weak patch wider than the fit's radius: its middle has too few strong vertices near and stays.
    TriangleMesh mesh = SphereMesh();
    const std::vector<char> patch = Patch(mesh, dir, 40.0);
    const std::vector<CarvedVoxel> voxels = WeakVoxels(mesh, patch);
    Displace(&mesh, WeakCells(mesh, patch), Dent(dir, 3.0, 45.0));
    const TriangleMesh before = mesh;
    const WeakRefitStats s = RefitWeakMeshVertices(&mesh, voxels, kVoxel, WeakRefitOptions());
    EXPECT_GT(s.few_neighbours, 100);
    EXPECT_LT(s.moved, s.weak);
    const Eigen::Vector3d pole = kCentre + kRadius * dir;
    for (size_t i = 0; i < mesh.vertices.size(); ++i)
      if ((before.vertices[i].cast<double>() - pole).norm() < 15) {
        EXPECT_EQ(mesh.vertices[i], before.vertices[i]) << "vertex " << i << " in the patch's middle moved";
      }
  }
}

TEST(WeakSurfaceRefit, MoveLimitKeepsFarVertices) {
  TriangleMesh mesh = SphereMesh();
  const Eigen::Vector3d dir = Eigen::Vector3d::UnitY();
  const std::vector<char> patch = Patch(mesh, dir, 6.0);
  const std::vector<CarvedVoxel> voxels = WeakVoxels(mesh, patch);
  Displace(&mesh, WeakCells(mesh, patch), Dent(dir, 3.0, 8.0));
  WeakRefitOptions o;
  o.max_move_mm = 1.0;
  o.min_move_mm = 0;
  o.rim_drop_mm = 0;
  const WeakRefitStats s = RefitWeakMeshVertices(&mesh, voxels, kVoxel, o);
  EXPECT_GT(s.too_far, 10);
  EXPECT_GT(s.moved, 0);  // the dent's shallow edge
  EXPECT_LE(s.max_abs_move_mm, 1.0);
}

TEST(WeakSurfaceRefit, OptionsValidated) {
  std::string why;
  EXPECT_TRUE(ValidateWeakRefitOptions(WeakRefitOptions(), &why)) << why;
  // One bad field each, on top of the defaults; first: the field the message must name ("" = not checked).
  const std::vector<std::pair<std::string, std::function<void(WeakRefitOptions*)>>> bad = {
      {"relative_votes", [](WeakRefitOptions* o) { o->relative_votes = 1.0; }},
      {"", [](WeakRefitOptions* o) { o->min_neighbours = 5; }},
      {"", [](WeakRefitOptions* o) { o->max_gap_deg = 0; }},
      {"", [](WeakRefitOptions* o) { o->min_move_mm = o->max_move_mm; }},
      {"", [](WeakRefitOptions* o) { o->rim_drop_mm = -1; }},
      {"", [](WeakRefitOptions* o) { o->rim_drop_mm = o->max_move_mm; }},
      {"", [](WeakRefitOptions* o) { o->radius_mm = 0.5; }},
      {"", [](WeakRefitOptions* o) { o->min_normal_cos = 1; }},
      {"", [](WeakRefitOptions* o) { o->max_move_mm = std::numeric_limits<double>::infinity(); }},
      {"", [](WeakRefitOptions* o) { o->max_residual_mm = std::nan(""); }},
  };
  for (size_t k = 0; k < bad.size(); ++k) {
    WeakRefitOptions o;
    bad[k].second(&o);
    EXPECT_FALSE(ValidateWeakRefitOptions(o, &why)) << "case " << k;
    if (!bad[k].first.empty()) {
      EXPECT_NE(why.find(bad[k].first), std::string::npos) << why;
    }
    EXPECT_NE(why.substr(why.size() - 2), "; ") << why;  // no trailing separator
  }
}

}  // namespace
}  // namespace objscan

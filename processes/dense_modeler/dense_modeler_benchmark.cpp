// Speed figures: one dense pair at 640x480, voting one pair, carving ~60 000 voxels x 200 views, the final phase's
// surface steps and the hidden-part removal of the final mesh.
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>
#include <random>

#include "processes/dense_modeler/dense_model.h"
#include "processes/dense_modeler/synthetic_scene.h"

namespace objscan {
namespace {

using testing_scene::SphereScene;

struct PairData {
  DenseView a, b;
  std::vector<PointMatch> matches;
};

const PairData& SpherePair() {
  static const PairData data = [] {
    SphereScene scene;
    PairData d;
    const auto features = scene.SurfacePoints(2500);
    for (int k = 0; k < 2; ++k) {
      DenseView& v = k == 0 ? d.a : d.b;
      const Eigen::Isometry3d pose = scene.RingPose(k * 2, 48);  // 15 degrees apart
      v.camera = scene.camera;
      v.world_from_camera = pose;
      v.image = scene.Render(pose);
    }
    d.matches =
        MatchTracks(scene.Tracks(d.a.world_from_camera, features, 0), scene.Tracks(d.b.world_from_camera, features, 1));
    return d;
  }();
  return data;
}

void BM_DensePairSphere(benchmark::State& state) {
  const PairData& d = SpherePair();
  AffineDenseOptions o;
  o.refine_along_epipolar = state.range(0) != 0;
  DensePairStats st;
  for (auto _ : state) benchmark::DoNotOptimize(ComputeDensePair(d.a, d.b, d.matches, o, &st));
  state.counters["pixels"] = static_cast<double>(st.pixels);
  state.counters["points"] = static_cast<double>(st.accepted);
}
BENCHMARK(BM_DensePairSphere)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The same pair into one output buffer kept from call to call, as the node does (no allocation, no page faults).
// Arg: 0 = the method's pair, 1 = with the default refinement, 2 = with the refinement scoring every step at once
// (refine_first_steps = 0: the default before 3 Dec). full_searches: refined pixels that scored every step.
void BM_DensePairSphereReusedOutput(benchmark::State& state) {
  const PairData& d = SpherePair();
  AffineDenseOptions o;
  o.refine_along_epipolar = state.range(0) != 0;
  if (state.range(0) == 2) o.refine_first_steps = 0;
  DensePairStats st;
  std::vector<DensePoint> points;
  for (auto _ : state) {
    ComputeDensePair(d.a, d.b, d.matches, o, &points, &st);
    benchmark::DoNotOptimize(points.data());
  }
  state.counters["pixels"] = static_cast<double>(st.pixels);
  state.counters["points"] = static_cast<double>(st.accepted);
  state.counters["full_searches"] = static_cast<double>(st.refine_full_searches);
}
BENCHMARK(BM_DensePairSphereReusedOutput)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// The pair's own matches (pair_matches.h) with the tracker's matches left of the image centre removed: corner
// detection and LK both ways for the bare half.
void BM_AddPairMatches(benchmark::State& state) {
  const PairData& d = SpherePair();
  std::vector<PointMatch> tracked;
  for (const PointMatch& m : d.matches)
    if (m.a.x() >= d.a.camera.cx) tracked.push_back(m);
  PairMatchStats st;
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);  // one core, as the node runs it (--threads 1)
  for (auto _ : state)
    benchmark::DoNotOptimize(
        AddPairMatches(d.a, d.b, tracked, cv::Rect(), RegionOfInterest(), PairMatchOptions(), &st));
  state.counters["corners"] = static_cast<double>(st.corners);
  state.counters["added"] = static_cast<double>(st.added);
  cv::setNumThreads(threads);
}
BENCHMARK(BM_AddPairMatches)->Unit(benchmark::kMillisecond);

// The refinement with each implementation of the window NCCs (AffineDenseOptions::refine_kernel; all bit-identical):
// 1 = one window NCC per search step (reference), 2 = portable, steps batched, 3 = AVX2, steps batched.
void BM_DensePairSphereRefineKernel(benchmark::State& state) {
  const PairData& d = SpherePair();
  AffineDenseOptions o;
  o.refine_kernel = static_cast<int>(state.range(0));
  DensePairStats st;
  for (auto _ : state) benchmark::DoNotOptimize(ComputeDensePair(d.a, d.b, d.matches, o, &st));
  state.counters["pixels"] = static_cast<double>(st.pixels);
  state.counters["points"] = static_cast<double>(st.accepted);
}
BENCHMARK(BM_DensePairSphereRefineKernel)->DenseRange(1, 3)->Unit(benchmark::kMillisecond);

// The final phase's re-triangulation of one pair's kept matches with other poses (here: the same ones).
void BM_TriangulateDenseMatchesPair(benchmark::State& state) {
  const PairData& d = SpherePair();
  const AffineDenseOptions o;
  const std::vector<DenseMatch> matches = DenseMatchesOf(ComputeDensePair(d.a, d.b, d.matches, o));
  size_t points = 0;
  for (auto _ : state)
    points = TriangulateDenseMatches(d.a.camera, d.a.world_from_camera, d.b.camera, d.b.world_from_camera, matches, o)
                 .size();
  state.counters["matches"] = static_cast<double>(matches.size());
  state.counters["points"] = static_cast<double>(points);
}
BENCHMARK(BM_TriangulateDenseMatchesPair)->Unit(benchmark::kMillisecond);

void BM_VotePair(benchmark::State& state) {
  const PairData& d = SpherePair();
  const auto points = ComputeDensePair(d.a, d.b, d.matches, AffineDenseOptions());
  VoxelVoteGrid grid;
  for (auto _ : state) grid.AddPoints(points);
  state.counters["points"] = static_cast<double>(points.size());
  state.counters["voxels"] = static_cast<double>(grid.num_voxels());
}
BENCHMARK(BM_VotePair)->Unit(benchmark::kMillisecond);

// 200 views of the sphere on the 800 mm ring, downsampled by 2 like the node's carving views.
const std::vector<CarvingView>& RingCarvingViews() {
  static const std::vector<CarvingView> views = [] {
    SphereScene scene;
    std::vector<CarvingView> v;
    for (int i = 0; i < 200; ++i) {
      const Eigen::Isometry3d pose = scene.RingPose(i, 200);
      v.push_back(MakeCarvingView(scene.camera, pose, scene.Render(pose), 2));
    }
    return v;
  }();
  return views;
}

void BM_Carve60kVoxels200Views(benchmark::State& state) {
  const std::vector<CarvingView>& views = RingCarvingViews();
  SphereScene scene;
  std::vector<VoxelRecord> seeds;
  const double size = 2.0;
  for (int k = -2; k < 103; ++k)
    for (int j = -52; j < 52; ++j)
      for (int i = -52; i < 52; ++i) {
        const Eigen::Vector3d c = (Eigen::Vector3d(i, j, k) + Eigen::Vector3d::Constant(0.5)) * size;
        const double r = (c - scene.center).norm();
        if (r > scene.radius - 3.0 && r <= scene.radius + 0.5) {
          VoxelRecord rec;
          rec.ijk = Eigen::Vector3i(i, j, k);
          rec.votes = 20;
          seeds.push_back(rec);
        }
      }
  SpaceCarvingStats st;
  for (auto _ : state) benchmark::DoNotOptimize(CarveVoxels(seeds, size, views, SpaceCarvingOptions(), &st));
  state.counters["voxels"] = static_cast<double>(seeds.size());
  state.counters["views"] = static_cast<double>(views.size());
  state.counters["passes"] = st.iterations;
  state.counters["removed"] = static_cast<double>(st.removed);
}
BENCHMARK(BM_Carve60kVoxels200Views)->Unit(benchmark::kMillisecond)->Iterations(2);

// The final phase's surface steps on a sphere of radius 100 mm voted like the sim orbit (2 mm voxels, points
// scattered 0.8 mm along the normal): vote ridge from ~130 000 seeds, then the mesh through its points.
const VoxelVoteGrid& NoisySphereGrid() {
  static const VoxelVoteGrid grid = [] {
    VoxelVoteGrid g;
    std::mt19937 rng(7);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int i = 0; i < 3000000; ++i) {
      Eigen::Vector3d n(gauss(rng), gauss(rng), gauss(rng));
      n.normalize();
      g.AddPoint(Eigen::Vector3d(0, 0, 100) + (100.0 + 0.8 * gauss(rng)) * n, {{128, 128, 128}}, n.cast<float>());
    }
    return g;
  }();
  return grid;
}

void BM_VoteRidge(benchmark::State& state) {
  const VoxelVoteGrid& grid = NoisySphereGrid();
  const std::vector<VoxelRecord> seeds = grid.Extract(16);
  RidgeStats st;
  for (auto _ : state) benchmark::DoNotOptimize(ExtractVoteRidge(grid, seeds, RidgeOptions(), &st));
  state.counters["seeds"] = static_cast<double>(seeds.size());
  state.counters["ridge"] = static_cast<double>(st.kept);
}
BENCHMARK(BM_VoteRidge)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_MeshFromSurfacePoints(benchmark::State& state) {
  const VoxelVoteGrid& grid = NoisySphereGrid();
  const std::vector<SurfaceVoxel> ridge = ExtractVoteRidge(grid, grid.Extract(16), RidgeOptions());
  size_t triangles = 0;
  for (auto _ : state) triangles = MeshFromSurfacePoints(ridge, grid.voxel_size()).triangles.size();
  state.counters["points"] = static_cast<double>(ridge.size());
  state.counters["triangles"] = static_cast<double>(triangles);
}
BENCHMARK(BM_MeshFromSurfacePoints)->Unit(benchmark::kMillisecond)->Iterations(3);

// The final mesh's hidden-part removal (mesh_visibility.h) as the node runs it: the sphere's mesh through its vote
// ridge (~120 000 vertices, like the sim orbit's) against 50 of the 200 ring views.
void BM_MeshVisibility(benchmark::State& state) {
  const VoxelVoteGrid& grid = NoisySphereGrid();
  const TriangleMesh mesh =
      MeshFromSurfacePoints(ExtractVoteRidge(grid, grid.Extract(16), RidgeOptions()), grid.voxel_size());
  const std::vector<CarvingView>& views = RingCarvingViews();
  MeshVisibilityStats st;
  for (auto _ : state) {
    TriangleMesh copy = mesh;
    st = RemoveOccludedMeshParts(&copy, views, MeshVisibilityOptions());
  }
  state.counters["vertices"] = static_cast<double>(mesh.vertices.size());
  state.counters["views"] = st.views;
  state.counters["removed"] = static_cast<double>(st.vertices_removed);
}
BENCHMARK(BM_MeshVisibility)->Unit(benchmark::kMillisecond)->Iterations(3);

// Curled-rim peeling (marching_cubes.h) on the sphere's mesh with 80 holes of 4-8 mm punched into it and its lower
// quarter cut off: the border test, the rings, the interior grid and the normal test of every border triangle,
// pass after pass until none is curled (holes punched into a smooth surface have few curled triangles, so this is
// close to the cost of the first passes; the sim orbit's meshes need up to 10).
void BM_TrimCurledBorders(benchmark::State& state) {
  const VoxelVoteGrid& grid = NoisySphereGrid();
  TriangleMesh mesh =
      MeshFromSurfacePoints(ExtractVoteRidge(grid, grid.Extract(16), RidgeOptions()), grid.voxel_size());
  std::mt19937 rng(7);
  std::uniform_int_distribution<size_t> pick(0, mesh.vertices.size() - 1);
  std::uniform_real_distribution<float> radius(4.f, 8.f);
  std::vector<std::pair<Eigen::Vector3f, float>> holes;
  for (int i = 0; i < 80; ++i) holes.emplace_back(mesh.vertices[pick(rng)], radius(rng));
  std::vector<char> keep(mesh.triangles.size(), 1);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3f c = (mesh.vertices[mesh.triangles[t][0]] + mesh.vertices[mesh.triangles[t][1]] +
                               mesh.vertices[mesh.triangles[t][2]]) /
                              3.f;
    if (c.z() < 50) keep[t] = 0;
    for (const auto& [centre, r] : holes)
      if ((c - centre).norm() < r) keep[t] = 0;
  }
  KeepMeshTriangles(&mesh, keep);
  int64_t dropped = 0;
  for (auto _ : state) {
    TriangleMesh copy = mesh;
    dropped = TrimCurledBorders(&copy, CurledBorderOptions());
  }
  state.counters["vertices"] = static_cast<double>(mesh.vertices.size());
  state.counters["dropped"] = static_cast<double>(dropped);
}
BENCHMARK(BM_TrimCurledBorders)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace objscan

BENCHMARK_MAIN();

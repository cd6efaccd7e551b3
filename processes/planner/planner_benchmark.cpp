// Speed of the planner's decisions (Google Benchmark): the next-view choice (target <= 200 ms), with and without a
// rebuild of the coverage samples from a dense voxel model, the map update after a landmark set, and the average and
// worst per-frame decision over a whole toy-world mission (explore, orbit, next views).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "processes/planner/next_best_view.h"
#include "processes/planner/planner.h"
#include "processes/planner/toy_world.h"

namespace objscan {
namespace {

struct MissionState {
  Planner planner{PlannerOptions{}};
  std::vector<MapLandmark> landmarks;
  double step_ms_sum = 0, step_ms_max = 0;
  int64_t frames = 0;
};

// Runs the toy mission (default options, 16 m map) to its end, or until NEXT_VIEWS has begun.
void RunToyMission(MissionState* s, bool stop_at_next_views) {
  toy::ToyWorld world(toy::MakeLivingRoom(true), RobotGeometry{});
  VoxelCloud voxels;
  for (int i = 0; i < 30 * 900; ++i) {
    s->planner.AddOdometry(world.Odometry());
    if (world.Landmarks(&s->landmarks)) s->planner.SetLandmarks(s->landmarks);
    s->planner.SetTarget(world.FindTarget());
    if (world.DenseModel(&voxels)) s->planner.SetVoxels(voxels);
    const PlannerCommand c = s->planner.Step(world.CameraPose());
    s->step_ms_sum += s->planner.last_step_ms();
    s->step_ms_max = std::max(s->step_ms_max, s->planner.last_step_ms());
    ++s->frames;
    s->planner.TakeEvents();
    if (s->planner.done() || (stop_at_next_views && s->planner.phase() == Phase::kNextViews)) break;
    world.Advance(c);
  }
}

const MissionState& AtNextViews() {
  static MissionState* state = [] {
    auto* s = new MissionState;
    RunToyMission(s, true);
    return s;
  }();
  return *state;
}

// A dense model of a 300 mm sphere at 2 mm voxels (~70 000 voxels) at the toy target's place.
VoxelCloud DenseSphere(const Eigen::Vector3d& centre) {
  VoxelCloud v;
  v.voxel_size_mm = 2;
  const double r = 150;
  for (double z = -r; z <= r; z += 2)
    for (double y = -r; y <= r; y += 2)
      for (double x = -r; x <= r; x += 2) {
        const double d = std::sqrt(x * x + y * y + z * z);
        if (std::abs(d - r) < 1.0) v.centres_mm.push_back(centre + Eigen::Vector3d(x, y, z + r));
      }
  return v;
}

void BM_NextViewChoice(benchmark::State& state) {
  const MissionState& m = AtNextViews();
  CoverageModel coverage = m.planner.coverage_model();
  coverage.Update();
  const OccupancyMap& map = m.planner.map();
  const PlannerOptions& o = m.planner.options();
  for (auto _ : state) {
    CostField field;
    field.Compute(map, m.planner.estimate().position());
    const NextViewResult r = ChooseNextView(coverage, map, field, o.robot, o.limits, o.next_view, {});
    benchmark::DoNotOptimize(r.best.score);
  }
  state.counters["samples"] = coverage.num_samples();
  state.counters["views"] = coverage.num_views();
  state.counters["map_cells"] = map.num_cells();
}
BENCHMARK(BM_NextViewChoice)->Unit(benchmark::kMillisecond);

void BM_NextViewChoiceAfterDenseModelUpdate(benchmark::State& state) {
  const MissionState& m = AtNextViews();
  const OccupancyMap& map = m.planner.map();
  const PlannerOptions& o = m.planner.options();
  const VoxelCloud dense = DenseSphere(m.planner.coverage_model().target().centre_mm -
                                       Eigen::Vector3d(0, 0, m.planner.coverage_model().target().centre_mm.z()));
  int samples = 0;
  for (auto _ : state) {
    CoverageModel coverage = m.planner.coverage_model();
    coverage.SetVoxels(dense);
    coverage.Update();  // samples rebuilt (PCA normals) and every kept view counted again
    CostField field;
    field.Compute(map, m.planner.estimate().position());
    const NextViewResult r = ChooseNextView(coverage, map, field, o.robot, o.limits, o.next_view, {});
    benchmark::DoNotOptimize(r.best.score);
    samples = coverage.num_samples();
  }
  state.counters["voxels"] = static_cast<double>(dense.centres_mm.size());
  state.counters["samples"] = samples;
  state.counters["views"] = m.planner.coverage_model().num_views();
}
BENCHMARK(BM_NextViewChoiceAfterDenseModelUpdate)->Unit(benchmark::kMillisecond);

void BM_MapUpdateAfterLandmarks(benchmark::State& state) {
  const MissionState& m = AtNextViews();
  OccupancyMap map = m.planner.map();
  for (auto _ : state) {
    map.SetLandmarks(m.landmarks);
    map.Update();
    benchmark::DoNotOptimize(map.free_cells());
  }
  state.counters["landmarks"] = static_cast<double>(m.landmarks.size());
  state.counters["map_cells"] = map.num_cells();
}
BENCHMARK(BM_MapUpdateAfterLandmarks)->Unit(benchmark::kMillisecond);

void BM_WholeToyMission(benchmark::State& state) {
  MissionState last;
  for (auto _ : state) {
    MissionState s;
    RunToyMission(&s, false);
    last.frames = s.frames;
    last.step_ms_sum = s.step_ms_sum;
    last.step_ms_max = s.step_ms_max;
  }
  state.counters["frames"] = static_cast<double>(last.frames);
  state.counters["step_ms_mean"] = last.step_ms_sum / std::max<int64_t>(1, last.frames);
  state.counters["step_ms_max"] = last.step_ms_max;
}
BENCHMARK(BM_WholeToyMission)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace objscan

BENCHMARK_MAIN();

// Cost of one ObjectFinder::Update on a ~5 000-landmark room map (object_finder.h promises <= 5 ms).
#include <benchmark/benchmark.h>

#include <vector>

#include "processes/object_finder/object_finder.h"
#include "processes/object_finder/synthetic_room.h"

namespace objscan {
namespace {

using testing_support::SyntheticRoom;

// The test room with a denser floor: 16 keyframes around the target, about 5 000 landmarks in the full map.
std::vector<FinderInput> RoomMaps(int* landmarks) {
  SyntheticRoom room;
  room.AddFloor(3000, 4400, 2.0);
  room.AddBox("box", Eigen::Vector2d(0, 0), Eigen::Vector3d(150, 120, 140), 0.35, 12);
  room.AddSphere("sphere", Eigen::Vector2d(2300, 600), 200, 12);
  room.AddWall("wall", Eigen::Vector2d(-2800, -1500), Eigen::Vector2d(-2800, 1500), 1000, 3);
  room.AddBox("table", Eigen::Vector2d(500, 2600), Eigen::Vector3d(900, 600, 700), 0, 3);
  room.AddCylinder("pillar", Eigen::Vector2d(600, -2500), 150, 1400, 3);
  room.AddPhantoms(40, 2500, 100, 1200);
  std::vector<FinderInput> maps;
  for (int k = 0; k < 16; ++k)
    maps.push_back(
        room.Observe(room.OnCircle(Eigen::Vector2d(0, 0), 1300, k * 22.5 - 90, Eigen::Vector3d(0, 0, 70)), k));
  *landmarks = static_cast<int>(maps.back().landmarks.size());
  return maps;
}

// Steady state: the full map (last keyframe) again and again, with moving camera poses.
void BM_UpdateFullMap(benchmark::State& state) {
  int landmarks = 0;
  std::vector<FinderInput> maps = RoomMaps(&landmarks);
  ObjectFinder finder;
  for (const auto& m : maps) finder.Update(m);
  FinderInput input = maps.back();
  int64_t seq = 100;
  for (auto _ : state) {
    input.seq = seq;
    input.world_from_camera = maps[seq % maps.size()].world_from_camera;
    ++seq;
    finder.Update(input);
    benchmark::DoNotOptimize(finder.result().box);
  }
  state.counters["landmarks"] = landmarks;
  state.counters["clusters"] = static_cast<double>(finder.result().clusters.size());
  state.counters["points_used"] = finder.result().points_used;
}
BENCHMARK(BM_UpdateFullMap)->Unit(benchmark::kMillisecond);

// A whole session: 16 growing maps on a fresh finder (floor found, target confirmed on the way).
void BM_Session16Keyframes(benchmark::State& state) {
  int landmarks = 0;
  const std::vector<FinderInput> maps = RoomMaps(&landmarks);
  for (auto _ : state) {
    ObjectFinder finder;
    for (const auto& m : maps) finder.Update(m);
    benchmark::DoNotOptimize(finder.result().box);
  }
  state.counters["updates"] = static_cast<double>(maps.size());
}
BENCHMARK(BM_Session16Keyframes)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace objscan

BENCHMARK_MAIN();

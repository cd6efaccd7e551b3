// Speed of the robot_sim CPU renderer at 640x480 (one core). Target: >= 60 frames/s for the default scene.
#include <benchmark/benchmark.h>

#include <cmath>

#include "common/robot_model.h"
#include "drivers/robot_sim/renderer.h"
#include "drivers/robot_sim/robot_sim.h"
#include "drivers/robot_sim/scene.h"

namespace objscan {
namespace {

void RenderScene(benchmark::State& state, const char* scene_name, bool trilinear) {
  const Scene scene = LoadScene(std::string(OBJSCAN_ROBOT_SIM_SCENES_DIR) + "/" + scene_name);
  RenderOptions options;
  options.trilinear = trilinear;
  Renderer renderer(scene, options);
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 800;
  camera.cx = 319.5;
  camera.cy = 239.5;
  RobotSimOptions sim_options;
  sim_options.frames = 200;
  RobotSimulator sim(scene, sim_options);
  std::vector<Eigen::Isometry3d> poses;
  while (!sim.Done()) poses.push_back(sim.Step().world_from_camera);
  RenderOutput out;
  size_t i = 0;
  for (auto _ : state) {
    renderer.Render(camera, poses[i % poses.size()], &out, i);
    benchmark::DoNotOptimize(out.rgb.data);
    ++i;
  }
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_RenderSphere(benchmark::State& state) { RenderScene(state, "sphere.scene", false); }
void BM_RenderSphereTrilinear(benchmark::State& state) { RenderScene(state, "sphere.scene", true); }
void BM_RenderCluttered(benchmark::State& state) { RenderScene(state, "cluttered.scene", false); }
void BM_RenderMesh(benchmark::State& state) { RenderScene(state, "mesh.scene", false); }
// A room (walls, table, pillar, rug, ...) seen from the 800 mm orbit around its target.
void BM_RenderRoom(benchmark::State& state) { RenderScene(state, "rooms/room_01.scene", false); }
BENCHMARK(BM_RenderSphere)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RenderSphereTrilinear)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RenderCluttered)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RenderMesh)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RenderRoom)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace objscan

BENCHMARK_MAIN();

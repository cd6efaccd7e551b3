// Speed of the camera driver on the Middlebury temple set (640x480 PNG): decoding a frame, and decoding +
// encoding + publishing it over memq:// per --encoding.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

#include "common/bus.h"
#include "common/log.h"
#include "common/test_data.h"
#include "drivers/camera/camera_node.h"

namespace objscan {
namespace {

std::string TempleDir() { return SharedDataPath("middlebury_templeSparseRing"); }

void BM_ReadFrame(benchmark::State& state) {
  FrameSourceOptions options;
  options.path = TempleDir();
  options.rotate_180 = state.range(0) ? "all" : "";
  std::string error;
  auto source = OpenFrameSource(options, &error);
  if (!source) {
    state.SkipWithError(error.c_str());
    return;
  }
  SourceFrame frame;
  std::string reason, detail;
  for (auto _ : state) {
    if (source->Next(&frame, &reason, &detail) == ReadResult::kEnd) {
      source->Rewind();
      source->Next(&frame, &reason, &detail);
    }
    benchmark::DoNotOptimize(frame.image.data);
  }
}
BENCHMARK(BM_ReadFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_PublishFrame(benchmark::State& state) {
  static const char* kEncodings[] = {"rgb8", "gray8", "jpeg"};
  SetLogLevel(LogLevel::kWarning);
  auto bus = MakeLcmBus("memq://");
  CameraNodeOptions options;
  options.source = TempleDir();
  options.rate_hz = 10000;  // one frame per 100 µs Tick below
  options.loop = true;
  options.encoding = kEncodings[state.range(0)];
  std::unique_ptr<CameraNode> node;
  try {
    node = std::make_unique<CameraNode>(*bus, options);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  int64_t wall = 0;
  for (auto _ : state) {
    node->Tick(wall += 100);
  }
  state.SetLabel(options.encoding);
}
BENCHMARK(BM_PublishFrame)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace objscan

BENCHMARK_MAIN();

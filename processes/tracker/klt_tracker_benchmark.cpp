// Speed of KltTracker::Track on 640x480 textured frames with realistic motion (about 3 px/frame translation,
// slow rotation and zoom, sensor noise sigma 2), one OpenCV thread, max_tracks 1000.
// Counters: median_ms (per frame), p90_ms, live (mean live tracks), born (mean new tracks per frame).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/time.h"
#include "processes/tracker/klt_tracker.h"
#include "processes/tracker/synthetic_sequence.h"

namespace objscan {
namespace {

const std::vector<cv::Mat>& Frames() {
  static const std::vector<cv::Mat> frames = [] {
    const testing_support::SyntheticSequence seq(640, 480, 220, 99);
    std::vector<cv::Mat> forward;
    for (int k = 0; k < 60; ++k) {
      const double wobble = 1.5 * std::sin(0.3 * k);
      forward.push_back(seq.Render(seq.Motion(3.0 * k + wobble, 1.2 * k - wobble, 0.002 * k, 1.0 + 0.001 * k), 2.0,
                                   static_cast<uint64_t>(k)));
    }
    std::vector<cv::Mat> all = forward;  // ping-pong so that the motion stays continuous when looping
    for (int k = 58; k >= 1; --k) all.push_back(forward[static_cast<size_t>(k)]);
    return all;
  }();
  return frames;
}

void Run(benchmark::State& state, const KltTrackerOptions& options) {
  const std::vector<cv::Mat>& frames = Frames();
  KltTracker tracker(options);
  std::vector<double> ms;
  double live = 0, born = 0;
  int64_t seq = 0;
  // Warm up past the first (detection-only) frame.
  ImageFrame frame;
  frame.image = frames[0];
  tracker.Track(frame);
  for (auto _ : state) {
    frame.seq = ++seq;
    frame.image = frames[static_cast<size_t>(seq) % frames.size()];
    const int64_t t0 = MonotonicMicros();
    const TrackFrame out = tracker.Track(frame);
    ms.push_back((MonotonicMicros() - t0) * 1e-3);
    benchmark::DoNotOptimize(out.features.data());
    live += static_cast<double>(out.features.size());
    born += tracker.last_stats().born;
  }
  std::sort(ms.begin(), ms.end());
  const double n = static_cast<double>(std::max<size_t>(ms.size(), 1));
  state.counters["median_ms"] = ms.empty() ? 0 : ms[ms.size() / 2];
  state.counters["p90_ms"] = ms.empty() ? 0 : ms[ms.size() * 9 / 10];
  state.counters["live"] = live / n;
  state.counters["born"] = born / n;
}

void BM_Default(benchmark::State& state) { Run(state, KltTrackerOptions()); }

void BM_Win15(benchmark::State& state) {
  KltTrackerOptions o;
  o.win_size = 15;
  Run(state, o);
}

void BM_Win15Level2(benchmark::State& state) {
  KltTrackerOptions o;
  o.win_size = 15;
  o.max_level = 2;
  Run(state, o);
}

void BM_DetectEvery3(benchmark::State& state) {
  KltTrackerOptions o;
  o.detect_interval = 3;
  Run(state, o);
}

void BM_NoForwardBackward(benchmark::State& state) {
  KltTrackerOptions o;
  o.forward_backward_check = false;
  Run(state, o);
}

void BM_Win15NoFb(benchmark::State& state) {
  KltTrackerOptions o;
  o.win_size = 15;
  o.forward_backward_check = false;
  Run(state, o);
}

void BM_Iter10(benchmark::State& state) {
  KltTrackerOptions o;
  o.max_iterations = 10;
  Run(state, o);
}

void BM_Iter10FbLevel1(benchmark::State& state) {
  KltTrackerOptions o;
  o.max_iterations = 10;
  o.fb_max_level = 1;
  Run(state, o);
}

void BM_Win15Iter10FbLevel1(benchmark::State& state) {
  KltTrackerOptions o;
  o.win_size = 15;
  o.max_iterations = 10;
  o.fb_max_level = 1;
  Run(state, o);
}

BENCHMARK(BM_Iter10)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_Iter10FbLevel1)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_Win15Iter10FbLevel1)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_Default)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_Win15)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_Win15Level2)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_DetectEvery3)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_NoForwardBackward)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_Win15NoFb)->Unit(benchmark::kMillisecond)->Iterations(400);

}  // namespace
}  // namespace objscan

BENCHMARK_MAIN();

// Speed of KltTracker::Track on 640x480 textured frames with realistic motion (about 3 px/frame translation,
// slow rotation and zoom, sensor noise sigma 2), one OpenCV thread, max_tracks 1000.
// Counters: median_ms (thread CPU time per frame, so other load on the machine matters less), p90_ms, live (mean live
// tracks), born (mean new tracks per frame), align_iter (mean anchor alignment iterations per aligned track), and per
// stage (KltTrackStats) the mean ms per frame: pyramid_ms (gray + pyramid), lk_ms (Lucas-Kanade passes and culling,
// without the refinement), refine_ms (anchor template alignment), detect_ms (corner detection and replenishment). The
// stats are wall clock; to make them comparable with median_ms on a loaded machine each frame's stage times are scaled
// by that frame's CPU / wall-clock ratio.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "processes/tracker/klt_tracker.h"
#include "processes/tracker/synthetic_sequence.h"

namespace objscan {
namespace {

// CPU time of this thread (ms): the per-frame figure should not depend on the other processes on the machine.
double ThreadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

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
  double live = 0, born = 0, aligned = 0, align_iterations = 0, refine = 0, lk = 0, detect = 0, pyramid = 0;
  int64_t seq = 0;
  // Warm up past the first (detection-only) frame.
  ImageFrame frame;
  frame.image = frames[0];
  tracker.Track(frame);
  for (auto _ : state) {
    frame.seq = ++seq;
    frame.image = frames[static_cast<size_t>(seq) % frames.size()];
    const double t0 = ThreadCpuMs();
    const auto w0 = std::chrono::steady_clock::now();
    const TrackFrame out = tracker.Track(frame);
    const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - w0).count();
    ms.push_back(ThreadCpuMs() - t0);
    benchmark::DoNotOptimize(out.features.data());
    live += static_cast<double>(out.features.size());
    const KltTrackStats& s = tracker.last_stats();
    born += s.born;
    aligned += s.anchor_aligned;
    align_iterations += s.anchor_iterations;
    const double cpu_per_wall = wall > 0 ? std::min(1.0, ms.back() / wall) : 1.0;
    refine += s.refine_ms * cpu_per_wall;
    lk += (s.lk_ms - s.refine_ms) * cpu_per_wall;
    detect += s.detect_ms * cpu_per_wall;
    pyramid += s.pyramid_ms * cpu_per_wall;
  }
  std::sort(ms.begin(), ms.end());
  const double n = static_cast<double>(std::max<size_t>(ms.size(), 1));
  state.counters["median_ms"] = ms.empty() ? 0 : ms[ms.size() / 2];
  state.counters["p90_ms"] = ms.empty() ? 0 : ms[ms.size() * 9 / 10];
  state.counters["live"] = live / n;
  state.counters["born"] = born / n;
  state.counters["refine_ms"] = refine / n;
  state.counters["align_iter"] = aligned > 0 ? align_iterations / aligned : 0;
  state.counters["lk_ms"] = lk / n;
  state.counters["detect_ms"] = detect / n;
  state.counters["pyramid_ms"] = pyramid / n;
}

void BM_Default(benchmark::State& state) { Run(state, KltTrackerOptions()); }

// Variants: (window, pyramid levels above the base, coarse window (0 = the window on every level), level on which
// LK stops, forward-backward check on/off).
void BM_Config(benchmark::State& state) {
  KltTrackerOptions o;
  o.win_size = static_cast<int>(state.range(0));
  o.max_level = static_cast<int>(state.range(1));
  o.coarse_win_size = static_cast<int>(state.range(2));
  o.lk_stop_level = static_cast<int>(state.range(3));
  o.forward_backward_check = state.range(4) != 0;
  Run(state, o);
}

// Without the anchor epsilon relaxation of the defaults (more alignment iterations).
void BM_AnchorEpsilon005(benchmark::State& state) {
  KltTrackerOptions o;
  o.anchor_epsilon = 0.005;
  Run(state, o);
}

// The alignment's portable code path (what a CPU without AVX2 runs; identical results).
void BM_NoAvx2(benchmark::State& state) {
  KltTrackerOptions o;
  o.use_avx2 = false;
  Run(state, o);
}

// Without the anchor template alignment (frame-to-frame LK only, as before it existed).
void BM_NoAnchorRefine(benchmark::State& state) {
  KltTrackerOptions o;
  o.anchor_refine = false;
  Run(state, o);
}

// Anchor template half window (the alignment cost grows with its area).
void BM_AnchorHalfWindow(benchmark::State& state) {
  KltTrackerOptions o;
  o.anchor_half_window = static_cast<int>(state.range(0));
  Run(state, o);
}

void BM_DetectEvery3HalfFill(benchmark::State& state) {
  KltTrackerOptions o;
  o.detect_interval = 3;
  o.min_cell_fill = 0.5;
  Run(state, o);
}

// Reference for the machine's speed: one plain cv::calcOpticalFlowPyrLK call (1000 points, window 21, 3 levels
// above the base, pyramids prebuilt) between two benchmark frames, as most KLT trackers run it (forward only).
void BM_ReferenceOpenCvLkForwardOnly(benchmark::State& state) {
  const std::vector<cv::Mat>& frames = Frames();
  std::vector<cv::Point2f> pts;
  cv::goodFeaturesToTrack(frames[10], pts, 1000, 0.001, 8);
  std::vector<cv::Mat> a, b;
  cv::buildOpticalFlowPyramid(frames[10], a, cv::Size(21, 21), 3, true);
  cv::buildOpticalFlowPyramid(frames[11], b, cv::Size(21, 21), 3, true);
  std::vector<cv::Point2f> out;
  std::vector<uchar> status;
  std::vector<float> err;
  std::vector<double> ms;
  cv::setNumThreads(1);
  for (auto _ : state) {
    const double t0 = ThreadCpuMs();
    cv::calcOpticalFlowPyrLK(a, b, pts, out, status, err, cv::Size(21, 21), 3);
    ms.push_back(ThreadCpuMs() - t0);
  }
  std::sort(ms.begin(), ms.end());
  state.counters["median_ms"] = ms.empty() ? 0 : ms[ms.size() / 2];
  state.counters["points"] = static_cast<double>(pts.size());
}

BENCHMARK(BM_ReferenceOpenCvLkForwardOnly)->Unit(benchmark::kMillisecond)->Iterations(200);
BENCHMARK(BM_Default)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_Config)
    ->ArgNames({"win", "levels", "coarse_win", "stop", "fb"})
    ->Args({21, 3, 9, 0, 1})  // the former defaults (LK to the base level with a 21 px window, forward-backward)
    ->Args({9, 2, 7, 0, 0})   // LK to the base level with a small window
    ->Args({9, 2, 7, 1, 0})   // LK stops on level 1
    ->Args({9, 3, 7, 2, 0})   // one more level above
    ->Args({9, 2, 7, 2, 1})   // defaults with the forward-backward check
    ->Unit(benchmark::kMillisecond)
    ->Iterations(400);
BENCHMARK(BM_AnchorEpsilon005)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_NoAvx2)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_NoAnchorRefine)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_AnchorHalfWindow)->ArgName("half")->Arg(5)->Arg(9)->Unit(benchmark::kMillisecond)->Iterations(400);
BENCHMARK(BM_DetectEvery3HalfFill)->Unit(benchmark::kMillisecond)->Iterations(400);

}  // namespace
}  // namespace objscan

BENCHMARK_MAIN();

// Speed of the pose estimator on one core: a 200-frame synthetic orbit with about 1000 live tracks per frame.
// Counters: seq_ms_per_frame (sequential phase: AddFrame after initialization, keyframe work included; mean),
// seq_median_ms (its median: a plain frame), seq_max_ms (all thread CPU time), init_ms (the span factorization +
// BA), final_ms (Finish: registration + global BA + scale), tracks, estimator_kb (PoseEstimator::ApproxMemoryBytes
// before Finish) and kb_per_frame (its growth per frame over the second half of the stream).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <vector>

#include <ctime>
#include "processes/pose_solver/pose_estimator.h"
#include "processes/pose_solver/synthetic_orbit.h"

namespace objscan {
namespace {

// Thread CPU time (µs): the figures are for one core and do not depend on the load of the shared machine.
int64_t CpuMicros() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

// About 1000 live tracks per frame.
SyntheticOrbitOptions SceneOptions() {
  SyntheticOrbitOptions o;
  o.num_sphere_points = 1100;
  o.num_floor_points = 1000;
  o.floor_max_radius_mm = 420;
  return o;
}

const SyntheticOrbit& Scene() {
  static const SyntheticOrbit s = MakeSyntheticOrbit(SceneOptions());
  return s;
}

void RunEstimator(benchmark::State& state, MotionModel model, int observations_kept_frames = -1,
                  int max_active_keyframes = -1) {
  const SyntheticOrbit& s = Scene();
  double tracks = 0;
  for (const auto& f : s.frames) tracks += f.features.size();
  tracks /= s.frames.size();
  for (auto _ : state) {
    PoseEstimatorOptions o;
    o.model = model;
    if (observations_kept_frames >= 0) o.observations_kept_frames = observations_kept_frames;
    if (max_active_keyframes >= 0) o.max_active_keyframes = max_active_keyframes;
    PoseEstimator est(s.camera, o);
    const size_t half = s.frames.size() / 2;
    size_t bytes_half = 0;
    double seq_ms = 0, seq_max = 0;
    int seq_frames = 0;
    std::vector<double> seq_each;
    for (size_t f = 0; f < s.frames.size(); ++f) {
      const bool was_initialized = est.initialized();
      const int64_t t0 = CpuMicros();
      est.AddFrame(s.frames[f], &s.odometry[f]);
      const double ms = (CpuMicros() - t0) * 1e-3;
      if (was_initialized) {
        seq_ms += ms;
        seq_max = std::max(seq_max, ms);
        seq_each.push_back(ms);
        ++seq_frames;
      }
      if (f == half) bytes_half = est.ApproxMemoryBytes();
    }
    const size_t bytes_end = est.ApproxMemoryBytes();
    state.counters["estimator_kb"] = bytes_end / 1024.0;
    state.counters["kb_per_frame"] =
        (static_cast<double>(bytes_end) - static_cast<double>(bytes_half)) / 1024.0 / (s.frames.size() - 1 - half);
    est.Finish();
    state.counters["seq_ms_per_frame"] = seq_frames > 0 ? seq_ms / seq_frames : 0;
    state.counters["seq_max_ms"] = seq_max;
    if (!seq_each.empty()) {
      std::nth_element(seq_each.begin(), seq_each.begin() + seq_each.size() / 2, seq_each.end());
      state.counters["seq_median_ms"] = seq_each[seq_each.size() / 2];
    }
    state.counters["init_ms"] = est.init_ms();
    state.counters["final_ms"] = est.final_ba_ms();
    state.counters["tracks"] = tracks;
    state.counters["keyframes"] = est.num_keyframes();
    state.counters["pnp_ms_per_frame"] = seq_frames > 0 ? est.pnp_ms_total() / seq_frames : 0;
    state.counters["tri_ms_per_frame"] = seq_frames > 0 ? est.triangulation_ms_total() / seq_frames : 0;
    state.counters["lba_ms_per_frame"] = seq_frames > 0 ? est.local_ba_ms_total() / seq_frames : 0;
  }
}

void BM_SixDof(benchmark::State& state) { RunEstimator(state, MotionModel::kSixDof); }
void BM_FourDof(benchmark::State& state) { RunEstimator(state, MotionModel::kFourDof); }
// Every frame's observations kept until Finish (observations_kept_frames = max_active_keyframes = 0): the memory it
// costs.
void BM_SixDofKeepAllObservations(benchmark::State& state) { RunEstimator(state, MotionModel::kSixDof, 0, 0); }
// 12 active keyframes (the orbit has 40): memory per frame once keyframes are frozen.
void BM_SixDofTwelveActiveKeyframes(benchmark::State& state) { RunEstimator(state, MotionModel::kSixDof, -1, 12); }
// One blank frame (80), then every track is new: the estimator relocalizes by position. Counters:
// reloc_attempts, relocalizations, reloc_ms_per_attempt (CPU), seq_ms_per_frame as above.
void BM_SixDofLostAndRelocalized(benchmark::State& state) {
  static const SyntheticOrbit s = [] {
    SyntheticOrbitOptions o = SceneOptions();
    o.lost_begin = 80;
    o.lost_end = 81;  // every track ends at once: relocalized in the tracking step
    return MakeSyntheticOrbit(o);
  }();
  for (auto _ : state) {
    PoseEstimator est(s.camera, PoseEstimatorOptions());
    for (size_t f = 0; f < s.frames.size(); ++f) est.AddFrame(s.frames[f], &s.odometry[f]);
    state.counters["reloc_attempts"] = est.relocalization_attempts();
    state.counters["relocalizations"] = est.relocalizations();
    state.counters["reloc_ms_per_attempt"] =
        est.relocalization_attempts() > 0 ? est.relocalization_ms_total() / est.relocalization_attempts() : 0;
  }
}

// The preliminary phase's span reconstruction alone (ReconstructSpan: factorization, both depth-reversal candidates,
// 6-DOF BA) on a span as long as the closed loop's first one (room_10: 60 frames x 360 tracks, 4.7-5.0 s before a
// clearly worse candidate was dropped after 10 iterations). Counters: rms_px of the kept candidate.
void BM_ReconstructSpan60x360(benchmark::State& state) {
  static const SyntheticOrbit s = [] {
    SyntheticOrbitOptions o = SceneOptions();
    o.dropout_per_frame = 0;
    o.orbit_fraction = 0.25;  // 60 of 200 frames: 27 degrees of the orbit
    return MakeSyntheticOrbit(o);
  }();
  constexpr int kFrames = 60, kTracks = 360;
  std::vector<int64_t> common;
  for (const TrackedFeature& t : s.frames[0].features) {
    bool everywhere = true;
    for (int f = 1; f < kFrames && everywhere; ++f)
      everywhere = std::any_of(s.frames[f].features.begin(), s.frames[f].features.end(),
                               [&](const TrackedFeature& g) { return g.id == t.id; });
    if (everywhere) common.push_back(t.id);
    if (static_cast<int>(common.size()) == kTracks) break;
  }
  std::vector<std::vector<Eigen::Vector2d>> meas(kFrames);
  for (int f = 0; f < kFrames; ++f)
    for (int64_t id : common)
      for (const TrackedFeature& g : s.frames[f].features)
        if (g.id == id) meas[f].emplace_back(g.u, g.v);
  BaOptions bo;
  bo.max_iterations = PoseEstimatorOptions().init_ba_iterations;
  for (auto _ : state) {
    BaProblem out;
    double rms = 0;
    std::string why;
    if (!ReconstructSpan(s.camera, meas, bo, &out, &rms, &why)) state.SkipWithError(why.c_str());
    state.counters["rms_px"] = rms;
    state.counters["tracks"] = static_cast<double>(common.size());
  }
}

BENCHMARK(BM_ReconstructSpan60x360)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SixDof)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SixDofLostAndRelocalized)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FourDof)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SixDofKeepAllObservations)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SixDofTwelveActiveKeyframes)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace objscan

BENCHMARK_MAIN();

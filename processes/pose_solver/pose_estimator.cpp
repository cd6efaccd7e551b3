#include "processes/pose_solver/pose_estimator.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <unordered_set>

#include <ctime>

#include "common/floor_fit.h"
#include "common/geometry.h"
#include "common/point_grid.h"

namespace objscan {

namespace {
// CPU time of the calling thread (µs): timing figures that do not depend on machine load.
int64_t MonotonicMicros() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}
// While a restart after a loss waits for its new map, each frame up to this many after the last pose tries to find
// the old map again by position (RelocalizeByProjection): 15 s at 30 Hz, the odometry's drift stays within the search.
constexpr int kRelocalizeDuringRestartFrames = 450;
// ... once the restart waited this long for its new map (1.5 s at 30 Hz): a new map joined to the old one by their
// common landmarks is the more accurate (rendered sphere orbit, 20 grey frames: final ATE 0.42 mm joined, 2.4 mm
// relocalized: the merged tracks tie the two sides at one place only), relocalization the fallback when none starts.
constexpr int kRelocalizeAfterWaitFrames = 45;
// In the tracking step, relocalization by position is tried only this soon after the last pose (µs).
constexpr int64_t kRelocalizeInTrackingMaxGapUs = 500000;
}  // namespace

// ---------------------------------------------------------------------------------------------------------------
bool ValidatePoseEstimatorOptions(const PoseEstimatorOptions& o, std::string* why) {
  std::ostringstream e;
  std::string robot_why;
  if (!o.robot.IsValid(&robot_why)) e << robot_why << "; ";
  if (o.start_span.min_common_tracks < 6) e << "start span min common tracks must be >= 6; ";
  if (o.start_span.min_frames < 3) e << "start span min frames must be >= 3; ";
  if (o.start_span.max_frames < o.start_span.min_frames) e << "start span max frames must be >= min frames; ";
  if (!(o.start_span.min_rotation_deg > 0)) e << "start span min rotation must be > 0; ";
  if (!(o.min_span_baseline_mm >= 0)) e << "min span baseline must be >= 0 mm; ";
  if (o.pnp.min_inliers < 6) e << "pnp min inliers must be >= 6; ";
  if (!(o.pnp.ransac_threshold_px > 0) || !(o.pnp.inlier_threshold_px > 0)) e << "pnp thresholds must be > 0; ";
  if (o.pnp.ransac_iterations < 1) e << "pnp ransac iterations must be >= 1; ";
  if (o.min_triangulation_views < 2) e << "min triangulation views must be >= 2; ";
  if (o.max_triangulation_views < o.min_triangulation_views) e << "max triangulation views must be >= min; ";
  if (!(o.triangulation.max_reprojection_px > 0)) e << "triangulation max reprojection must be > 0; ";
  if (o.keyframe_interval < 1) e << "keyframe interval must be >= 1; ";
  if (!(o.keyframe_track_ratio >= 0 && o.keyframe_track_ratio <= 1)) e << "keyframe track ratio must be in [0, 1]; ";
  if (o.local_window_keyframes < 2) e << "local window keyframes must be >= 2; ";
  if (o.local_fixed_keyframes < 1) e << "local fixed keyframes must be >= 1; ";
  if (o.local_ba_iterations < 0 || o.global_ba_iterations < 0 || o.init_ba_iterations < 1)
    e << "BA iterations must be >= 0 (init >= 1); ";
  if (!(o.global_ba_function_tolerance > 0 && o.global_ba_function_tolerance < 1))
    e << "global BA function tolerance must be in (0, 1); ";
  if (o.ba_loss != "huber" && o.ba_loss != "cauchy") e << "ba loss must be huber or cauchy; ";
  if (!(o.ba_loss_px > 0)) e << "ba loss scale must be > 0; ";
  if (!(o.max_landmark_error_px > 0)) e << "max landmark error must be > 0; ";
  if (!(o.floor_tolerance_mm > 0)) e << "floor tolerance must be > 0; ";
  if (o.min_floor_points < 3) e << "min floor points must be >= 3; ";
  if (o.online_scale_frames < 0) e << "online scale frames must be >= 0; ";
  if (o.relocalize_after_lost_frames < 1) e << "relocalize after lost frames must be >= 1; ";
  if (!(o.fuse_search_mm > 0)) e << "fuse search mm must be > 0; ";
  if (!(o.fuse_max_px > 0)) e << "fuse max px must be > 0; ";
  if (!(o.fuse_min_parallax_deg >= 0)) e << "fuse min parallax deg must be >= 0; ";
  if (!(o.join_search_mm >= 0)) e << "join search mm must be >= 0; ";
  if (o.join_search_mm > 0 && o.join_search_mm < 8) e << "join search mm must be 0 or >= 8; ";
  if (o.join_search_mm > 0 && !(o.join_max_mm > 0 && o.join_max_mm <= 2.5)) e << "join max mm must be in (0, 2.5]; ";
  if (!(o.relocalize_search_px >= 0) || o.relocalize_search_px > 200) e << "relocalize search must be in [0, 200] px; ";
  if (o.join_search_mm > 0 && o.join_min_landmarks < 3) e << "join min landmarks must be >= 3; ";
  if (o.observations_kept_frames < 0) e << "observations kept frames must be >= 0; ";
  if (o.max_active_keyframes < 0 ||
      (o.max_active_keyframes > 0 &&
       o.max_active_keyframes < std::max(10, o.local_window_keyframes + o.local_fixed_keyframes)))
    e << "max active keyframes must be 0 or >= max(10, local window + local fixed keyframes); ";
  if (o.global_ba_all_frames && (o.observations_kept_frames != 0 || o.max_active_keyframes != 0))
    e << "global BA over all frames needs observations kept frames = 0 and max active keyframes = 0 (every frame's "
         "observations); ";
  if (o.two_view_min_matches != 0 && o.two_view_min_matches < 8) e << "two view min matches must be 0 or >= 8; ";
  if (o.two_view_min_landmarks < 2) e << "two view min landmarks must be >= 2; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

// ---------------------------------------------------------------------------------------------------------------
bool OdometryBuffer::Add(const OdometryReading& r) {
  if (!readings_.empty() && r.utime <= readings_.back().utime) return false;
  readings_.push_back(r);
  while (readings_.size() > capacity_) readings_.pop_front();
  return true;
}

bool OdometryBuffer::At(int64_t utime, OdometryReading* out, int64_t max_gap_us) const {
  if (readings_.empty()) return false;
  if (utime <= readings_.front().utime) {
    if (readings_.front().utime - utime > max_gap_us) return false;
    *out = readings_.front();
    out->utime = utime;
    return true;
  }
  if (utime >= readings_.back().utime) {
    if (utime - readings_.back().utime > max_gap_us) return false;
    *out = readings_.back();
    out->utime = utime;
    return true;
  }
  const auto it = std::lower_bound(readings_.begin(), readings_.end(), utime,
                                   [](const OdometryReading& r, int64_t t) { return r.utime < t; });
  const OdometryReading& b = *it;
  const OdometryReading& a = *(it - 1);
  const double w = static_cast<double>(utime - a.utime) / static_cast<double>(b.utime - a.utime);
  auto lerp = [w](double x, double y) { return x + w * (y - x); };
  OdometryReading r = a;
  r.utime = utime;
  r.x_mm = lerp(a.x_mm, b.x_mm);
  r.y_mm = lerp(a.y_mm, b.y_mm);
  r.theta_rad = a.theta_rad + w * std::remainder(b.theta_rad - a.theta_rad, 2 * M_PI);
  r.pan_rad = lerp(a.pan_rad, b.pan_rad);
  r.tilt_rad = lerp(a.tilt_rad, b.tilt_rad);
  r.v_mm_s = lerp(a.v_mm_s, b.v_mm_s);
  r.omega_rad_s = lerp(a.omega_rad_s, b.omega_rad_s);
  *out = r;
  return true;
}

// ---------------------------------------------------------------------------------------------------------------
int PoseEstimator::Frame::Find(int64_t id) const {
  const auto it = std::lower_bound(ids.begin(), ids.end(), id);
  return it != ids.end() && *it == id ? static_cast<int>(it - ids.begin()) : -1;
}

PoseEstimator::PoseEstimator(const PinholeCamera& camera, const PoseEstimatorOptions& options)
    : camera_(camera), options_(options) {
  std::string why;
  if (!camera_.IsValid(&why)) throw std::invalid_argument("pose estimator: " + why);
  if (!ValidatePoseEstimatorOptions(options_, &why)) throw std::invalid_argument("pose estimator: " + why);
  options_.pnp.model = options_.model;
}

int PoseEstimator::num_keyframes() const {
  int n = 0;
  for (const auto& f : frames_) n += f.keyframe ? 1 : 0;
  return n;
}

size_t PoseEstimator::ApproxMemoryBytes() const {
  constexpr size_t kNodeOverhead = 32;  // bytes per map / hash node beyond its value (pointers, hash, colour)
  size_t bytes = frames_.capacity() * sizeof(Frame);
  for (const Frame& fr : frames_)
    bytes +=
        fr.ids.capacity() * sizeof(int64_t) + fr.pixels.capacity() * sizeof(Eigen::Vector2d) + fr.outlier.capacity();
  bytes += points_.size() * (sizeof(std::pair<const int64_t, Point>) + kNodeOverhead);
  for (const auto& [id, list] : track_frames_)
    bytes += sizeof(id) + sizeof(list) + kNodeOverhead + list.capacity() * sizeof(int);
  bytes += alias_.size() * (sizeof(std::pair<const int64_t, Alias>) + kNodeOverhead);
  bytes += fused_tracks_.capacity() * sizeof(fused_tracks_[0]) + fuse_pending_.capacity() * sizeof(int64_t);
  return bytes;
}

BaOptions PoseEstimator::MakeBaOptions(int iterations) const {
  BaOptions b;
  b.model = options_.model;
  b.loss = options_.ba_loss;
  b.loss_scale_px = options_.ba_loss_px;
  b.max_iterations = iterations;
  b.num_threads = 1;
  return b;
}

CameraPoseEstimate PoseEstimator::Estimate(int f) const {
  const Frame& fr = frames_[f];
  CameraPoseEstimate p;
  p.utime = fr.utime;
  p.seq = fr.seq;
  p.world_from_camera = fr.world_from_camera;
  p.status = fr.status;
  p.scale_source = fr.posed ? scale_source_ : ScaleSource::kNone;
  p.num_inliers = fr.posed ? fr.inliers : 0;
  p.reprojection_rms_px = fr.posed ? fr.rms : 0.0;
  p.map_start_seq = fr.posed ? fr.map_start_seq : -1;
  return p;
}

FrameResult PoseEstimator::AddFrame(const TrackFrame& input, const OdometryReading* odometry) {
  const int f = static_cast<int>(frames_.size());
  Frame fr;
  fr.utime = input.utime;
  fr.seq = input.seq;
  std::vector<std::pair<int64_t, Eigen::Vector2d>> feats;
  feats.reserve(input.features.size());
  for (const auto& t : input.features) {
    if (!std::isfinite(t.u) || !std::isfinite(t.v)) continue;
    int64_t id = t.id;
    if (!alias_.empty()) {  // a fused track observes its landmark
      auto a = alias_.find(id);
      if (a != alias_.end()) {
        id = a->second.landmark;
        a->second.last_frame = f;
      }
    }
    feats.emplace_back(id, UndistortPixel(camera_, Eigen::Vector2d(t.u, t.v)));
  }
  // Tracks that ended: KLT ids do not come back; a few frames of grace cover frames lost on the way.
  if (f % 16 == 0)
    for (auto a = alias_.begin(); a != alias_.end();) a = f - a->second.last_frame > 8 ? alias_.erase(a) : std::next(a);
  std::sort(feats.begin(), feats.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  feats.erase(std::unique(feats.begin(), feats.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
              feats.end());
  for (const auto& [id, px] : feats) {
    fr.ids.push_back(id);
    fr.pixels.push_back(px);
    track_frames_[id].push_back(f);
  }
  fr.outlier.assign(fr.ids.size(), 0);
  if (odometry) {
    fr.has_odometry = true;
    fr.odometry_base_mm = Eigen::Vector2d(odometry->x_mm, odometry->y_mm);
    fr.odometry_world_from_camera = WorldFromCamera(options_.robot, odometry->x_mm, odometry->y_mm, odometry->theta_rad,
                                                    odometry->pan_rad, odometry->tilt_rad);
  }
  // Until posed: initializing frames carry the odometry pose (or identity), lost ones the last good pose.
  fr.status = recovering_ ? PoseStatus::kLost : PoseStatus::kInitializing;
  if (recovering_ && last_good_ >= 0)
    fr.world_from_camera = frames_[last_good_].world_from_camera;
  else if (fr.has_odometry)
    fr.world_from_camera = fr.odometry_world_from_camera;
  frames_.push_back(std::move(fr));

  FrameResult result;
  std::string reloc_why;
  if (phase_ == Phase::kInitializing && recovering_ && last_good_ >= 0 && f - init_start_ >= kRelocalizeAfterWaitFrames &&
      f - last_good_ <= kRelocalizeDuringRestartFrames && RelocalizeByProjectionTimed(f, PredictFromLastGood(f), &reloc_why)) {
    // The old map is seen again before the new one started: it goes on (the restart is dropped).
    frames_[f].status = PoseStatus::kRelocalized;
    phase_ = Phase::kTracking;
    recovering_ = false;
    lost_count_ = 0;
    last_good_ = f;
  } else if (phase_ == Phase::kInitializing) {
    const int window_start = init_start_;
    if (TryInitialize(f)) {
      result.initialized_now = true;
      result.keyframe = true;
      // Frames of the preliminary window before the span: PnP against the new map, nearest first.
      for (int g = span_first_ - 1; g >= window_start; --g)
        if (!frames_[g].posed && frames_[g + 1].posed && RegisterAgainstMap(g, frames_[g + 1].world_from_camera))
          frames_[g].status = frames_[span_first_].status;
      for (int g = window_start; g < f; ++g)
        if (frames_[g].posed) result.late_poses.push_back(Estimate(g));
    }
  } else if ([&] {
               const int64_t t0 = MonotonicMicros();
               const bool ok = Track(f, &result);
               pnp_ms_ += (MonotonicMicros() - t0) * 1e-3;
               return ok;
             }()) {
    lost_count_ = 0;
    const int tracked = frames_[f].inliers;
    if (f - last_keyframe_ >= options_.keyframe_interval ||
        tracked < options_.keyframe_track_ratio * last_keyframe_inliers_) {
      AddKeyframe(f);
      result.keyframe = true;
    }
  } else {
    ++lost_count_;
    if (lost_count_ >= options_.relocalize_after_lost_frames) {
      phase_ = Phase::kInitializing;
      recovering_ = true;
      fuse_pending_.clear();
      init_start_ = f + 1;
      const std::string why = last_message_;
      last_message_ = "lost: restarting the preliminary phase at frame " + std::to_string(f + 1);
      notice_ = "pose lost at frame " + std::to_string(frames_[f].seq) + " after " + std::to_string(lost_count_) +
                " frames without one (" + (why.empty() ? std::string("no reason given") : why) + ", " +
                std::to_string(frames_[f].ids.size()) + " tracks): a new map starts" +
                (options_.relocalize_search_px > 0 ? " (the old one is looked for by position meanwhile)" : "");
    }
  }
  result.pose = Estimate(f);
  if (options_.observations_kept_frames > 0) CompactOldFrames(f);
  return result;
}

void PoseEstimator::CompactOldFrames(int newest) {
  for (; compaction_cursor_ <= newest - options_.observations_kept_frames; ++compaction_cursor_)
    old_uncompacted_.push_back(compaction_cursor_);
  // Frames posed late (preliminary window) are compacted once they are posed; unposed ones (lost stretches) keep
  // their observations for the registration at Finish.
  size_t kept = 0;
  for (int g : old_uncompacted_) {
    if (frames_[g].posed)
      CompactFrame(g);
    else
      old_uncompacted_[kept++] = g;
  }
  old_uncompacted_.resize(kept);
}

void PoseEstimator::CompactFrame(int f) {
  Frame& fr = frames_[f];
  if (!fr.posed || fr.keyframe || fr.compacted || f == gauge_frame_ || f == gauge_frame_b_) return;
  // Its pose against the map as the windowed adjustments left it around the frame: from now on the frame only
  // follows its keyframes (FollowKeyframes), so its pose relative to them should be the best one available now.
  RefitPose(f);
  DropObservations(f);
  fr.compacted = true;
}

void PoseEstimator::FreezeKeyframe(int f) {
  Frame& fr = frames_[f];
  if (!fr.keyframe || fr.frozen || f == gauge_frame_ || f == gauge_frame_b_) return;
  DropObservations(f);
  fr.frozen = true;
}

void PoseEstimator::DropObservations(int f) {
  Frame& fr = frames_[f];
  const Eigen::Isometry3d camera_from_world = fr.world_from_camera.inverse();
  for (size_t i = 0; i < fr.ids.size(); ++i) {
    const int64_t id = fr.ids[i];
    auto point = points_.find(id);
    Eigen::Vector2d uv;
    if (fr.posed && !fr.outlier[i] && point != points_.end() &&
        ProjectIdeal(camera_, camera_from_world * point->second.x, &uv)) {
      ++point->second.dropped_observations;
      point->second.dropped_sq_error += (uv - fr.pixels[i]).squaredNorm();
    }
    auto it = track_frames_.find(id);
    if (it == track_frames_.end()) continue;
    std::vector<int>& list = it->second;  // ascending frame indices
    const auto pos = std::lower_bound(list.begin(), list.end(), f);
    if (pos != list.end() && *pos == f) list.erase(pos);
    if (list.empty()) track_frames_.erase(it);
  }
  std::vector<int64_t>().swap(fr.ids);
  std::vector<Eigen::Vector2d>().swap(fr.pixels);
  std::vector<uint8_t>().swap(fr.outlier);
}

void PoseEstimator::FollowKeyframes(const std::vector<Eigen::Isometry3d>& old_world_from_camera) {
  const int n = static_cast<int>(frames_.size());
  int previous = -1;  // last keyframe before the frame being visited
  for (int g = 0; g < n; ++g) {
    if (frames_[g].keyframe && frames_[g].posed) {
      previous = g;
      continue;
    }
    if (!frames_[g].compacted) continue;
    int next = g + 1;
    while (next < n && !(frames_[next].keyframe && frames_[next].posed)) ++next;
    // The frame carried rigidly by keyframe k: new_k * old_k^-1 * old_g.
    auto carried = [&](int k) {
      return Eigen::Isometry3d(frames_[k].world_from_camera * old_world_from_camera[static_cast<size_t>(k)].inverse() *
                               old_world_from_camera[static_cast<size_t>(g)]);
    };
    if (previous < 0 && next >= n) continue;  // no keyframe at all: nothing moved it
    if (previous < 0 || next >= n) {
      frames_[g].world_from_camera = carried(previous < 0 ? next : previous);
      continue;
    }
    const Eigen::Isometry3d a = carried(previous), b = carried(next);
    const double t = static_cast<double>(g - previous) / static_cast<double>(next - previous);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::Quaterniond(a.linear()).slerp(t, Eigen::Quaterniond(b.linear())).toRotationMatrix();
    pose.translation() = (1.0 - t) * a.translation() + t * b.translation();
    frames_[g].world_from_camera = pose;
  }
}

bool PoseEstimator::TryInitialize(int newest) {
  constexpr int kRetryFramesAfterDisagreement = 15;
  if (newest < init_retry_frame_) return false;  // init_wait_reason_ still says why
  int first_considered = std::max(init_start_, newest - options_.start_span.max_frames + 1);
  // With odometry, the span starts after the base last stood still or turned in place (synthetic: a span of 57
  // turning and 10 orbit frames initialised at ATE 335 mm, scale 0.67; room_03: a restart on 8 turning frames, map
  // 1.3x off).
  constexpr double kStillBaseSpeedMmS = 20;
  for (int f = newest; f > first_considered; --f) {
    const Frame& a = frames_[f - 1];
    const Frame& b = frames_[f];
    if (!a.has_odometry || !b.has_odometry) continue;
    const double dt_s = std::max(1e-3, (b.utime - a.utime) * 1e-6);
    if ((b.odometry_base_mm - a.odometry_base_mm).norm() / dt_s < kStillBaseSpeedMmS) {
      first_considered = f;
      break;
    }
  }
  if (newest - first_considered + 1 < options_.start_span.min_frames) {
    init_wait_reason_ = std::to_string(newest - first_considered + 1) + " frames since the base last stood still";
    return false;
  }
  std::vector<TrackList> lists(newest - first_considered + 1);
  for (int f = first_considered; f <= newest; ++f) {
    lists[f - first_considered].ids = frames_[f].ids;
    lists[f - first_considered].pixels = frames_[f].pixels;
  }
  int first = 0, last = 0;
  std::vector<int64_t> common;
  if (!SelectStartSpan(lists, options_.start_span, &first, &last, &common, &init_wait_reason_)) return false;
  // A span turned in place (the robot turning on the spot after a loss) has rotation but no depth: its structure and
  // odometry scale are noise (room_03: a restart on 8 frames of turning gave a map 1.3x off). Wait for travel.
  double travel_mm = 0;
  bool all_odometry = true;
  const Frame& start = frames_[first + first_considered];
  for (int f = first + first_considered; f <= last + first_considered; ++f) {
    all_odometry = all_odometry && frames_[f].has_odometry;
    if (all_odometry)
      travel_mm = std::max(travel_mm, (frames_[f].odometry_world_from_camera.translation() -
                                       start.odometry_world_from_camera.translation()).norm());
  }
  if (all_odometry && travel_mm < options_.min_span_baseline_mm) {
    std::ostringstream m;
    m << "initialization: the span " << frames_[first + first_considered].seq << ".."
      << frames_[last + first_considered].seq << " travelled " << travel_mm << " mm by the odometry (< "
      << options_.min_span_baseline_mm << " mm); waiting for travel";
    last_message_ = m.str();
    init_wait_reason_ = m.str();
    return false;
  }
  const int64_t start_us = MonotonicMicros();
  const bool ok = InitializeSpan(first + first_considered, last + first_considered, common);
  if (ok) span_first_ = first + first_considered;
  else init_wait_reason_ = last_message_;
  if (!ok && span_refused_by_odometry_) {
    init_retry_frame_ = newest + kRetryFramesAfterDisagreement;
    init_wait_reason_ += "; next try at frame " + std::to_string(frames_[newest].seq + kRetryFramesAfterDisagreement);
  }
  init_ms_ = (MonotonicMicros() - start_us) * 1e-3;
  if (ok) last_message_ += " (" + std::to_string(static_cast<int>(init_ms_)) + " ms)";
  return ok;
}

void PoseEstimator::ApplySimilarity(double scale, const Eigen::Isometry3d& t, int first_frame, int last_frame,
                                    const std::vector<int64_t>& point_ids) {
  for (int f = first_frame; f <= last_frame; ++f) {
    Frame& fr = frames_[f];
    if (!fr.posed) continue;
    Eigen::Isometry3d scaled = fr.world_from_camera;
    scaled.translation() *= scale;
    fr.world_from_camera = t * scaled;
  }
  for (int64_t id : point_ids) {
    auto it = points_.find(id);
    if (it != points_.end()) it->second.x = t * (scale * it->second.x);
  }
}

bool PoseEstimator::ReconstructSpanFromTracks(int first, int last, const std::vector<int64_t>& common,
                                              BaProblem* best_out, double* best_rms_out) {
  const int nf = last - first + 1;
  const int np = static_cast<int>(common.size());
  std::vector<std::vector<Eigen::Vector2d>> meas(nf, std::vector<Eigen::Vector2d>(np));
  for (int f = 0; f < nf; ++f)
    for (int p = 0; p < np; ++p) meas[f][p] = frames_[first + f].pixels[frames_[first + f].Find(common[p])];
  BaProblem& best = *best_out;
  double& best_rms = *best_rms_out;
  best_rms = std::numeric_limits<double>::infinity();
  // The reconstruction's motion against the odometry's (SpanMotionAgreesWithOdometry), when every frame has it.
  std::vector<Eigen::Isometry3d> odometry;
  for (int f = first; f <= last && frames_[f].has_odometry; ++f)
    odometry.push_back(frames_[f].odometry_world_from_camera);
  SpanCheck agrees;
  span_refused_by_odometry_ = false;
  if (static_cast<int>(odometry.size()) == nf)
    agrees = [this, &odometry](const BaProblem& candidate, std::string* why) {
      if (SpanMotionAgreesWithOdometry(candidate.world_from_camera, odometry, why)) return true;
      *why = "initialization: " + *why;
      span_refused_by_odometry_ = true;
      return false;
    };
  if (!ReconstructSpan(camera_, meas, MakeBaOptions(options_.init_ba_iterations), &best, &best_rms, &last_message_,
                       agrees))
    return false;
  span_refused_by_odometry_ = false;  // a candidate agreed
  if (!(best_rms < 2.0 * options_.max_landmark_error_px)) {
    last_message_ = "initialization: span BA RMS " + std::to_string(best_rms) + " px too large";
    return false;
  }
  return true;
}

std::vector<int64_t> PoseEstimator::CommitSpan(int first, int last, const std::vector<int64_t>& common,
                                               const BaProblem& best) {
  const int nf = last - first + 1;
  const int np = static_cast<int>(common.size());
  // Commit the span.
  std::vector<int64_t> new_points;
  for (int f = 0; f < nf; ++f) {
    Frame& fr = frames_[first + f];
    fr.posed = true;
    fr.world_from_camera = best.world_from_camera[f];
    fr.keyframe = (f % options_.keyframe_interval == 0) || f == nf - 1;
    if (fr.keyframe) NoteActiveKeyframe(first + f);
  }
  for (int p = 0; p < np; ++p) {
    points_[common[p]] = Point{best.points[p], false};
    new_points.push_back(common[p]);
  }
  std::sort(new_points.begin(), new_points.end());
  std::set<int64_t> existing;
  for (const auto& kv : points_) existing.insert(kv.first);
  TriangulateNew(last);
  for (const auto& kv : points_)
    if (!existing.count(kv.first)) new_points.push_back(kv.first);
  return new_points;
}

PoseEstimator::SpanPlacement PoseEstimator::PlaceSpanByOdometry(int first, int last,
                                                                const std::vector<int64_t>& new_points) {
  // Metric scale and world frame from odometry. Scale: median over the span's steps of odometry / visual step
  // length (robust to a time-stamping offset of the odometry, which corrupts the steps next to a clamped reading).
  const Frame& a = frames_[first];
  double odo_scale = 0;
  const bool have_odometry = a.has_odometry && OdometryStepScale(first, last, &odo_scale);
  Eigen::Isometry3d anchor = Eigen::Isometry3d::Identity();  // desired world_from_camera of frame `first`
  bool have_anchor = false;
  if (recovering_ && last_good_ >= 0 && a.has_odometry && frames_[last_good_].has_odometry) {
    anchor = frames_[last_good_].world_from_camera * frames_[last_good_].odometry_world_from_camera.inverse() *
             a.odometry_world_from_camera;
    have_anchor = true;
  } else if (a.has_odometry) {
    anchor = a.odometry_world_from_camera;
    have_anchor = true;
  }
  const double scale = have_odometry ? odo_scale : 1.0;
  const ScaleSource scale_source_before = scale_source_;
  scale_source_ = have_odometry ? ScaleSource::kOdometry : ScaleSource::kNone;
  {
    Eigen::Isometry3d scaled = a.world_from_camera;
    scaled.translation() *= scale;
    const Eigen::Isometry3d t = (have_anchor ? anchor : a.world_from_camera) * scaled.inverse();
    ApplySimilarity(scale, t, first, last, new_points);
  }
  return SpanPlacement{anchor, have_anchor, scale_source_before};
}

void PoseEstimator::LevelAndScaleSpanByFloor(int first, int last, const std::vector<int64_t>& new_points,
                                             const SpanPlacement& placement) {
  const Eigen::Isometry3d& anchor = placement.anchor;
  const bool have_anchor = placement.have_anchor;
  // kSixDof: the camera height above a floor plane seen in the span fixes the scale far better than the odometry
  // over a short span (about the first camera: the anchor is kept).
  segment_floor_first_ = -1;
  segment_floor_points_.clear();
  if (options_.model == MotionModel::kSixDof && options_.use_floor_for_scale &&
      !RescaleToFloorHeight(first, last, new_points, first) && recovering_) {
    segment_floor_first_ = first;  // AddKeyframe looks for the floor again
    segment_floor_points_ = new_points;
  }
  if (options_.model == MotionModel::kFourDof) {
    std::vector<int64_t> floor_ids;
    FloorPlane plane;
    if (options_.use_floor_for_scale && DetectFloor(new_points, &floor_ids, &plane)) {
      // Level: plane normal -> +z, plane -> z = 0.
      Eigen::Vector3d n = plane.normal;
      double d = plane.offset_mm;
      if (n.dot(frames_[first].world_from_camera.translation()) + d < 0) {
        n = -n;
        d = -d;
      }
      Eigen::Isometry3d level = Eigen::Isometry3d::Identity();
      level.linear() = Eigen::Quaterniond::FromTwoVectors(n, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      level.translation() = Eigen::Vector3d(0, 0, d);
      ApplySimilarity(1.0, level, first, last, new_points);
      // Scale: cameras at the model height for their tilt.
      double measured = 0, expected = 0;
      for (int f = first; f <= last; ++f) {
        const Eigen::Isometry3d& w = frames_[f].world_from_camera;
        measured += w.translation().z();
        expected +=
            WorldFromCameraFloor(options_.robot, FloorPoseFromWorldFromCamera(options_.robot, w)).translation().z();
      }
      if (measured > 1e-6) {
        ApplySimilarity(expected / measured, Eigen::Isometry3d::Identity(), first, last, new_points);
        scale_source_ = ScaleSource::kCameraHeight;
        for (int64_t id : floor_ids) points_[id].on_floor = true;
        for (int64_t id : new_points)
          if (std::abs(points_[id].x.z()) < options_.floor_tolerance_mm) points_[id].on_floor = true;
      }
    }
    // Re-anchor in the floor plane: frame `first` at the anchor's (x, y, yaw).
    if (have_anchor) {
      const FloorPose cur = FloorPoseFromWorldFromCamera(options_.robot, frames_[first].world_from_camera);
      const FloorPose want = FloorPoseFromWorldFromCamera(options_.robot, anchor);
      Eigen::Isometry3d planar = Eigen::Isometry3d::Identity();
      planar.linear() = Eigen::AngleAxisd(want.yaw_rad - cur.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const Eigen::Vector3d moved = planar.linear() * Eigen::Vector3d(cur.x_mm, cur.y_mm, 0);
      planar.translation() = Eigen::Vector3d(want.x_mm - moved.x(), want.y_mm - moved.y(), 0);
      ApplySimilarity(1.0, planar, first, last, new_points);
    }
    if (scale_source_ != ScaleSource::kCameraHeight) {
      // No floor: lift the map so that the first camera sits at the model height (odometry scale kept).
      const Eigen::Isometry3d& w = frames_[first].world_from_camera;
      const double h =
          WorldFromCameraFloor(options_.robot, FloorPoseFromWorldFromCamera(options_.robot, w)).translation().z();
      Eigen::Isometry3d lift = Eigen::Isometry3d::Identity();
      lift.translation() = Eigen::Vector3d(0, 0, h - w.translation().z());
      ApplySimilarity(1.0, lift, first, last, new_points);
    }
  }
}

bool PoseEstimator::InitializeSpan(int first, int last, const std::vector<int64_t>& common) {
  // The span's reconstruction, committed; its metric frame from the odometry, then from the floor.
  BaProblem best;
  double best_rms = 0;
  if (!ReconstructSpanFromTracks(first, last, common, &best, &best_rms)) return false;
  const int np = static_cast<int>(common.size());
  std::vector<int64_t> new_points = CommitSpan(first, last, common, best);
  const SpanPlacement placement = PlaceSpanByOdometry(first, last, new_points);
  const ScaleSource scale_source_before = placement.scale_source_before;
  LevelAndScaleSpanByFloor(first, last, new_points, placement);
  const bool was_recovering = recovering_;
  gauge_frame_ = gauge_frame_ < 0 ? first : gauge_frame_;
  if (gauge_frame_b_ < 0) gauge_frame_b_ = last;
  for (int f = first; f <= last; ++f) {
    frames_[f].status = recovering_ ? PoseStatus::kRelocalized : PoseStatus::kTracking;
  }
  map_initialized_ = true;
  phase_ = Phase::kTracking;
  recovering_ = false;
  lost_count_ = 0;
  last_good_ = last;
  last_keyframe_ = last;
  // Span BA in the final model (4-DOF projects the poses onto the robot model here).
  LocalBundleAdjustment(last);
  // After a loss the odometry chaining above is only a start: the new map, adjusted in the final model, is joined
  // to the old one through the landmarks both saw (Sim(3)), and those landmarks are fused.
  std::string join_message;
  if (unjoined_first_ >= 0) unjoined_restart_seqs_.push_back(frames_[unjoined_first_].seq);  // never joined
  unjoined_first_ = -1;
  unjoined_points_.clear();
  if (was_recovering) {
    int pairs = 0;
    // By the landmarks both maps hold; else by position: the old landmarks projected from the span's last pose
    // (chained through the odometry over the short gap) paired with its tracks.
    if ((options_.join_search_mm > 0 && JoinToOldMap(first, last, new_points, &pairs, &join_message)) ||
        JoinByProjection(first, last, new_points, &join_message)) {
      scale_source_ = scale_source_before;
      segment_floor_first_ = -1;  // joined: the old map's scale
      segment_floor_points_.clear();
      join_first_frame_ = first;
      const int fused = FuseLandmarks(last, new_points);
      join_message += ", " + std::to_string(fused) + " landmarks fused, " + std::to_string(fuse_pending_.size()) +
                      " waiting for parallax";
    } else {
      unjoined_first_ = first;
      unjoined_points_ = new_points;
      unjoined_tried_size_ = new_points.size();
      unjoined_tried_frame_ = last;
    }
  }
  // The map the span's frames lie in: the first map (from the stream's first frame: frames before the span are
  // registered into it at the end), the old one when joined, else a new one from the span's first frame.
  if (!was_recovering) {
    if (current_map_start_ < 0) current_map_start_ = frames_.front().seq;
  } else if (unjoined_first_ == first) {
    map_before_restart_ = current_map_start_;
    current_map_start_ = frames_[first].seq;
  }
  for (int f = first; f <= last; ++f) frames_[f].map_start_seq = current_map_start_;
  // Per-frame statistics.
  for (int f = first; f <= last; ++f) UpdateFrameStatistics(&frames_[f]);
  last_keyframe_inliers_ = frames_[last].inliers;
  std::ostringstream m;
  m << "initialized on frames " << frames_[first].seq << ".." << frames_[last].seq << " with " << np
    << " common tracks, " << points_.size() << " landmarks, span RMS " << best_rms << " px, scale source "
    << static_cast<int>(scale_source_);
  if (!join_message.empty()) m << "; " << join_message;
  last_message_ = m.str();
  return true;
}

bool ReconstructSpan(const PinholeCamera& camera, const std::vector<std::vector<Eigen::Vector2d>>& meas,
                     const BaOptions& ba_options, BaProblem* out, double* rms_px, std::string* why,
                     const SpanCheck& acceptable) {
  FactorizationResult fact;
  if (!FactorizeWeakPerspective(meas, &fact, why)) return false;
  const int nf = static_cast<int>(meas.size());
  const int np = static_cast<int>(meas[0].size());
  // Perspective upgrade of both depth-reversal candidates and 6-DOF BA; keep the better. Both are first adjusted
  // for a few iterations; the better is adjusted to the end and, when it is accepted, the other is dropped if it is
  // already clearly worse (a wrong reversal does not converge: room_10, 60 frames x 360 points, it ran all 50
  // iterations to 0.79 px in 3.1 s while the right one converged to 0.075 px in 7 iterations, 0.5 s; the whole
  // initialization took 5 s, longer than the simulator's lockstep wait).
  const double depth = 1000.0;  // arbitrary working unit until the scale is fixed by the caller
  const Eigen::Matrix3d k_inv = camera.K().inverse();
  constexpr int kProbeIterations = 10;
  struct Candidate {
    BaProblem start;  // the upgraded factorization, before any adjustment
    BaProblem bp;
    BaSummary summary;
    double probe_rms_px = std::numeric_limits<double>::infinity();  // after the probe (infinite when it failed)
    bool done = false;  // adjusted to the end (converged or all iterations used)
  };
  Candidate cand[2];
  for (int candidate = 0; candidate < 2; ++candidate) {
    const FactorizationResult fr = candidate == 0 ? fact : fact.Mirrored();
    BaProblem& bp = cand[candidate].start;
    for (int f = 0; f < nf; ++f) {
      Eigen::Isometry3d cw = Eigen::Isometry3d::Identity();
      cw.linear() = fr.camera_from_model[f];
      const double z = depth / std::max(fr.scale[f], 1e-3);
      cw.translation() = z * (k_inv * fr.centroid_px[f].homogeneous());
      bp.world_from_camera.push_back(cw.inverse());
    }
    for (int p = 0; p < np; ++p) bp.points.push_back(fr.shape.col(p) * depth / camera.fx);
    for (int f = 0; f < nf; ++f)
      for (int p = 0; p < np; ++p) bp.observations.push_back({f, p, meas[f][p]});
    bp.frame_fix.assign(nf, FrameFix::kFree);
    bp.frame_fix[0] = FrameFix::kFixed;
    bp.distance_frame_a = 0;
    bp.distance_frame_b = nf - 1;
    bp.distance_mm = (bp.world_from_camera[0].translation() - bp.world_from_camera[nf - 1].translation()).norm();
    BaOptions bo = ba_options;
    bo.model = MotionModel::kSixDof;
    bo.max_iterations = std::min(kProbeIterations, ba_options.max_iterations);
    cand[candidate].bp = bp;
    cand[candidate].summary = RunBundleAdjustment(camera, RobotGeometry(), bo, &cand[candidate].bp);
    if (cand[candidate].summary.ok) cand[candidate].probe_rms_px = cand[candidate].summary.final_rms_px;
    cand[candidate].done = !cand[candidate].summary.ok || cand[candidate].summary.converged ||
                           bo.max_iterations >= ba_options.max_iterations;
  }
  // The better after the probe first.
  const bool second_first = cand[1].probe_rms_px < cand[0].probe_rms_px;
  const int order[2] = {second_first ? 1 : 0, second_first ? 0 : 1};
  double best_rms = std::numeric_limits<double>::infinity();
  std::string refused;
  for (int candidate : order) {
    Candidate& c = cand[candidate];
    // Clearly worse after the probe than the accepted one after its full adjustment: not worth the iterations.
    if (std::isfinite(best_rms) && c.probe_rms_px > 1.5 * best_rms + 0.05) continue;
    if (!c.done) {  // adjusted again from the start: the same result as without the probe
      BaOptions bo = ba_options;
      bo.model = MotionModel::kSixDof;
      c.bp = c.start;
      c.summary = RunBundleAdjustment(camera, RobotGeometry(), bo, &c.bp);
    }
    const BaSummary& s = c.summary;
    if (s.ok && s.final_rms_px < best_rms && acceptable && !acceptable(c.bp, &refused)) continue;
    if (s.ok && s.final_rms_px < best_rms) {
      best_rms = s.final_rms_px;
      *out = std::move(c.bp);
    }
  }
  *rms_px = best_rms;
  if (!std::isfinite(best_rms)) {
    if (why) *why = refused.empty() ? "span BA failed" : refused;
    return false;
  }
  return true;
}

// A restarted map scaled by the floor later (AddKeyframe) is changed by at most this factor: the odometry's scale
// over a short span is off by tens of percent, not by 2x (room_06: a 2.23x "correction" from a plane that was no
// floor, on a span of RMS 0.77 px, put the rest of the run 1.27x off).
constexpr double kMaxLateFloorRescale = 1.5;

// Share of the points that may lie more than 3 floor tolerances under a plane taken for the floor (noise, outliers).
constexpr double kMaxBelowFloorFraction = 0.05;

bool PoseEstimator::DetectFloor(const std::vector<int64_t>& candidates, std::vector<int64_t>* inlier_ids,
                                FloorPlane* plane) const {
  std::vector<int64_t> ids;
  std::vector<Eigen::Vector3d> xs;
  for (int64_t id : candidates) {
    auto it = points_.find(id);
    if (it == points_.end()) continue;
    ids.push_back(id);
    xs.push_back(it->second.x);
  }
  const int n = static_cast<int>(xs.size());
  if (n < options_.min_floor_points) return false;
  // Which way is up. With odometry the world is the odometry's frame: z is up, and the floor's normal is within
  // 20 deg of it. Images only: the world is the first camera's frame, so z is that camera's optical axis (a plane
  // facing the camera was taken for the floor: image-only sphere orbit, "metric" scale 1.62x off). Up is then taken
  // from the cameras themselves: a camera on a pan-tilt head has no roll and looks down by its tilt, so the floor's
  // normal lies within the tilt range (up to 70 deg) of the mean image-up direction (-y) of the posed cameras.
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double max_angle_deg = 20.0;
  if (std::none_of(frames_.begin(), frames_.end(), [](const Frame& fr) { return fr.has_odometry; })) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Frame& fr : frames_)
      if (fr.posed) sum += fr.world_from_camera.linear() * Eigen::Vector3d(0, -1, 0);
    if (sum.norm() < 1e-9) return false;
    up = sum.normalized();
    max_angle_deg = 70.0;
  }
  PlaneSampling sampling;
  sampling.up = up;
  sampling.max_tilt_deg = max_angle_deg;
  sampling.iterations = 300;
  sampling.sequence = SampleIndexSequence::kMt19937Uniform;
  sampling.seed = static_cast<uint32_t>(options_.seed);
  const double tolerance = options_.floor_tolerance_mm;
  // The floor has (almost) nothing beneath it: a flat patch higher up (the top of an object, a table) has the
  // floor and the object's sides below it (a restart's span on a sphere took its top cap for the floor).
  const auto nothing_beneath = [&](const FloorPlane& hypothesis) {
    return CountPointsBelow(xs, hypothesis, 3 * tolerance) <= kMaxBelowFloorFraction * n;
  };
  const PlaneSupport best = MostSupportedPlane(xs, sampling, tolerance, nullptr, nothing_beneath);
  if (best.inliers < options_.min_floor_points) return false;
  inlier_ids->clear();
  for (int i = 0; i < n; ++i)
    if (std::abs(best.plane.Height(xs[i])) <= tolerance) inlier_ids->push_back(ids[i]);
  // Least-squares refit on the inliers (at least min_floor_points of them).
  *plane = best.plane;
  RefitPlaneToInliers(xs, tolerance, up, plane);
  return true;
}

bool PoseEstimator::Track(int f, FrameResult* result) {
  (void)result;
  Frame& fr = frames_[f];
  // Prior: constant-velocity extrapolation from the two previous frames when both are posed, else the last pose.
  Eigen::Isometry3d prior = last_good_ >= 0 ? frames_[last_good_].world_from_camera : Eigen::Isometry3d::Identity();
  if (last_good_ == f - 1 && f >= 2 && frames_[f - 2].posed) {
    const Eigen::Isometry3d& a = frames_[f - 2].world_from_camera;
    const Eigen::Isometry3d& b = frames_[f - 1].world_from_camera;
    prior = b * (a.inverse() * b);
  }
  std::string pnp_why;
  if (!PoseFromMap(f, last_good_ >= 0 ? &prior : nullptr, &pnp_why)) {
    last_message_ = "PnP: " + pnp_why;
    if (TwoViewPose(f)) return true;
    if (last_message_.rfind("PnP: ", 0) != 0) last_message_ = "PnP: " + pnp_why + "; " + last_message_;
    // Relocalization by position right after all tracks ended at once (a fast motion, room_03: 17 times in 8 263
    // frames); after a longer gap the restarted map joined by its landmarks is the more accurate (a tracker restarted
    // by procman, 1 s: relocalized 3.6 mm, joined 0.9-1.9 mm, procman_restart_test).
    std::string reloc_why;
    if (last_good_ >= 0 && fr.utime - frames_[last_good_].utime <= kRelocalizeInTrackingMaxGapUs &&
        RelocalizeByProjectionTimed(f, PredictFromLastGood(f), &reloc_why)) {
      fr.status = PoseStatus::kRelocalized;
      phase_ = Phase::kTracking;
      last_good_ = f;
      return true;
    }
    if (!reloc_why.empty()) last_message_ += "; " + reloc_why;
    fr.status = PoseStatus::kLost;
    if (last_good_ >= 0) fr.world_from_camera = frames_[last_good_].world_from_camera;
    phase_ = Phase::kLost;
    return false;
  }
  fr.status = phase_ == Phase::kLost ? PoseStatus::kRelocalized : PoseStatus::kTracking;
  phase_ = Phase::kTracking;
  last_good_ = f;
  return true;
}

bool PoseEstimator::PoseFromMap(int f, const Eigen::Isometry3d* prior, std::string* why) {
  Frame& fr = frames_[f];
  std::vector<Eigen::Vector3d> pts;
  std::vector<Eigen::Vector2d> px;
  std::vector<int> feature_index;
  for (size_t i = 0; i < fr.ids.size(); ++i) {
    auto it = points_.find(fr.ids[i]);
    if (it == points_.end()) continue;
    pts.push_back(it->second.x);
    px.push_back(fr.pixels[i]);
    feature_index.push_back(static_cast<int>(i));
  }
  PnpOptions po = options_.pnp;
  po.seed = static_cast<uint64_t>(options_.seed) + static_cast<uint64_t>(f);
  PnpResult r;
  if (static_cast<int>(pts.size()) < po.min_inliers) {
    if (why)
      *why = std::to_string(pts.size()) + " of " + std::to_string(fr.ids.size()) + " tracks on landmarks (need " +
             std::to_string(po.min_inliers) + ")";
    return false;
  }
  if (!SolvePnp(camera_, options_.robot, pts, px, prior, po, &r, why)) return false;
  std::fill(fr.outlier.begin(), fr.outlier.end(), 0);
  std::vector<uint8_t> is_inlier(pts.size(), 0);
  for (int i : r.inliers) is_inlier[i] = 1;
  for (size_t c = 0; c < pts.size(); ++c)
    if (!is_inlier[c]) fr.outlier[feature_index[c]] = 1;
  fr.posed = true;
  fr.map_start_seq = current_map_start_;
  fr.world_from_camera = r.world_from_camera;
  fr.inliers = static_cast<int>(r.inliers.size());
  fr.rms = r.rms_px;
  return true;
}

Eigen::Isometry3d PoseEstimator::PredictFromLastGood(int f) const {
  const Frame& good = frames_[last_good_];
  const Frame& fr = frames_[f];
  if (!good.has_odometry || !fr.has_odometry) return good.world_from_camera;
  return good.world_from_camera * (good.odometry_world_from_camera.inverse() * fr.odometry_world_from_camera);
}

namespace {
constexpr double kRelocMatchPx = 2.5;    // px, track to shifted landmark projection
constexpr int kRelocMinInliers = 30;     // PnP inliers to accept a relocalization
}  // namespace

bool PoseEstimator::RelocalizeByProjectionTimed(int f, const Eigen::Isometry3d& predicted, std::string* why) {
  if (!(options_.relocalize_search_px > 0)) return false;
  const int64_t t0 = MonotonicMicros();
  const bool ok = RelocalizeByProjection(f, predicted, why);
  reloc_ms_ += (MonotonicMicros() - t0) * 1e-3;
  ++reloc_attempts_;
  reloc_successes_ += ok ? 1 : 0;
  return ok;
}

void PoseEstimator::PairByProjection(int f, const std::vector<int>& tracks, const std::vector<int64_t>& landmark_ids,
                                     const Eigen::Isometry3d& from, double search_px,
                                     std::vector<std::pair<int, int64_t>>* pairs) const {
  pairs->clear();
  const Frame& fr = frames_[f];
  const Eigen::Isometry3d cw = from.inverse();
  std::vector<Eigen::Vector3d> projected;  // (u, v, 0)
  std::vector<int64_t> ids;
  for (int64_t id : landmark_ids) {
    const auto it = points_.find(id);
    if (it == points_.end()) continue;
    Eigen::Vector2d uv;
    if (!ProjectIdeal(camera_, cw * it->second.x, &uv)) continue;
    if (uv.x() < -search_px || uv.y() < -search_px || uv.x() > camera_.width + search_px ||
        uv.y() > camera_.height + search_px)
      continue;
    projected.emplace_back(uv.x(), uv.y(), 0.0);
    ids.push_back(id);
  }
  if (projected.empty() || tracks.empty()) return;
  const PointGrid grid(projected, std::max(search_px, 2 * kRelocMatchPx) / 2);
  // The shift (track - projection) most pairs agree on: 2 px bins.
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  if (search_px > 2 * kRelocMatchPx) {
    const int bins = static_cast<int>(std::ceil(search_px / 2)) * 2 + 1, half = bins / 2;
    std::vector<int> votes(static_cast<size_t>(bins * bins), 0);
    for (int i : tracks) {
      const Eigen::Vector3d q(fr.pixels[i].x(), fr.pixels[i].y(), 0.0);
      grid.ForEachWithin(q, search_px, [&](int k) {
        const int bx = static_cast<int>(std::lround((q.x() - projected[k].x()) / 2)) + half;
        const int by = static_cast<int>(std::lround((q.y() - projected[k].y()) / 2)) + half;
        if (bx >= 0 && by >= 0 && bx < bins && by < bins) ++votes[static_cast<size_t>(by * bins + bx)];
      });
    }
    const size_t best = static_cast<size_t>(std::max_element(votes.begin(), votes.end()) - votes.begin());
    shift = Eigen::Vector2d((static_cast<int>(best % bins) - half) * 2.0, (static_cast<int>(best / bins) - half) * 2.0);
  }
  std::unordered_map<int64_t, int> claims;  // landmark -> pairs claiming it
  std::vector<std::pair<int, int64_t>> candidates;
  for (int i : tracks) {
    const Eigen::Vector3d q(fr.pixels[i].x() - shift.x(), fr.pixels[i].y() - shift.y(), 0.0);
    double d1 = std::numeric_limits<double>::infinity(), d2 = d1;
    int nearest = -1;
    grid.ForEachWithin(q, 2 * kRelocMatchPx, [&](int k) {
      const double d = (projected[k] - q).norm();
      if (d < d1) {
        d2 = d1;
        d1 = d;
        nearest = k;
      } else if (d < d2) {
        d2 = d;
      }
    });
    if (nearest < 0 || d1 > kRelocMatchPx || d2 < 2 * d1) continue;
    candidates.emplace_back(i, ids[nearest]);
    ++claims[ids[nearest]];
  }
  for (const auto& c : candidates)
    if (claims[c.second] == 1) pairs->push_back(c);
}

bool PoseEstimator::PoseFromPairs(int f, const std::vector<std::pair<int, int64_t>>& pairs,
                                  const Eigen::Isometry3d& prior, PnpResult* r) const {
  std::vector<Eigen::Vector3d> pts;
  std::vector<Eigen::Vector2d> px;
  for (const auto& [i, id] : pairs) {
    pts.push_back(points_.at(id).x);
    px.push_back(frames_[f].pixels[i]);
  }
  PnpOptions po = options_.pnp;
  po.seed = static_cast<uint64_t>(options_.seed) + static_cast<uint64_t>(f);
  po.min_inliers = std::max(po.min_inliers, kRelocMinInliers);
  return static_cast<int>(pairs.size()) >= po.min_inliers && SolvePnp(camera_, options_.robot, pts, px, &prior, po, r) &&
         2 * r->inliers.size() >= pairs.size();
}

bool PoseEstimator::MatchByProjection(int f, const std::vector<int>& tracks, const std::vector<int64_t>& landmark_ids,
                                      const Eigen::Isometry3d& predicted, std::vector<std::pair<int64_t, int64_t>>* merges,
                                      Eigen::Isometry3d* pose, std::string* why) const {
  std::vector<std::pair<int, int64_t>> pairs;
  PairByProjection(f, tracks, landmark_ids, predicted, options_.relocalize_search_px, &pairs);
  PnpResult first;
  if (!PoseFromPairs(f, pairs, predicted, &first)) {
    if (why)
      *why = std::to_string(pairs.size()) + " track-landmark pairs by position from the predicted pose, no pose with " +
             std::to_string(kRelocMinInliers) + " inliers and half of them";
    return false;
  }
  PairByProjection(f, tracks, landmark_ids, first.world_from_camera, 2 * kRelocMatchPx, &pairs);
  PnpResult r;
  if (!PoseFromPairs(f, pairs, first.world_from_camera, &r)) {
    if (why) *why = "the pose from " + std::to_string(first.inliers.size()) + " pairs did not hold";
    return false;
  }
  // The shift searched bounds the prediction's rotation error: a pose turned much further is a wrong pairing.
  const double turned_deg =
      Eigen::AngleAxisd(predicted.linear().transpose() * r.world_from_camera.linear()).angle() * 180 / M_PI;
  const double max_turn_deg = 2 * std::atan(options_.relocalize_search_px / camera_.fx) * 180 / M_PI + 2;
  if (turned_deg > max_turn_deg) {
    if (why) *why = "the pose turned " + std::to_string(turned_deg) + " deg from the prediction";
    return false;
  }
  merges->clear();
  for (int k : r.inliers) merges->emplace_back(frames_[f].ids[pairs[k].first], pairs[k].second);
  *pose = r.world_from_camera;
  return true;
}

bool PoseEstimator::RelocalizeByProjection(int f, const Eigen::Isometry3d& predicted, std::string* why) {
  if (!(options_.relocalize_search_px > 0)) return false;
  Frame& fr = frames_[f];
  // Tracks of f without a landmark (a track observing one is PoseFromMap's), against every landmark not in f.
  std::vector<int> tracks;
  for (size_t i = 0; i < fr.ids.size(); ++i)
    if (!points_.count(fr.ids[i])) tracks.push_back(static_cast<int>(i));
  if (static_cast<int>(tracks.size()) < kRelocMinInliers) {
    if (why) *why = "relocalization: " + std::to_string(tracks.size()) + " new tracks";
    return false;
  }
  std::vector<int64_t> landmarks;
  landmarks.reserve(points_.size());
  for (const auto& [id, p] : points_)
    if (fr.Find(id) < 0) landmarks.push_back(id);
  std::vector<std::pair<int64_t, int64_t>> merges;
  Eigen::Isometry3d pose;
  std::string match_why;
  if (!MatchByProjection(f, tracks, landmarks, predicted, &merges, &pose, &match_why)) {
    if (why) *why = "relocalization: " + match_why;
    return false;
  }
  for (const auto& [track, landmark] : merges) MergeLandmark(track, landmark, f);
  std::string pnp_why;
  if (!PoseFromMap(f, &pose, &pnp_why)) {  // cannot fail with those inliers; keep the frame consistent anyway
    if (why) *why = "relocalization: " + pnp_why;
    return false;
  }
  std::ostringstream m;
  m << "relocalized frame " << fr.seq << " by position: " << merges.size() << " new tracks observe landmarks again ("
    << (predicted.translation() - fr.world_from_camera.translation()).norm() << " mm, "
    << Eigen::AngleAxisd(predicted.linear().transpose() * fr.world_from_camera.linear()).angle() * 180 / M_PI
    << " deg from the prediction, " << f - last_good_ << " frames after the last pose)";
  notice_ = m.str();
  return true;
}

bool PoseEstimator::JoinByProjection(int first, int last, const std::vector<int64_t>& new_points, std::string* message) {
  if (!(options_.relocalize_search_px > 0) || !frames_[last].posed) return false;
  const Frame& fr = frames_[last];
  const std::unordered_set<int64_t> is_new(new_points.begin(), new_points.end());
  // Every track of `last` not observing an old landmark (new-map landmarks and tracks without one), against the old
  // map's landmarks projected from its pose chained through the odometry.
  std::vector<int> tracks;
  for (size_t i = 0; i < fr.ids.size(); ++i)
    if (!points_.count(fr.ids[i]) || is_new.count(fr.ids[i])) tracks.push_back(static_cast<int>(i));
  std::vector<int64_t> old_landmarks;
  for (const auto& [id, p] : points_)
    if (!is_new.count(id) && fr.Find(id) < 0) old_landmarks.push_back(id);
  std::vector<std::pair<int64_t, int64_t>> merges;
  Eigen::Isometry3d pose;
  std::string why;
  if (static_cast<int>(tracks.size()) < kRelocMinInliers ||
      !MatchByProjection(last, tracks, old_landmarks, fr.world_from_camera, &merges, &pose, &why)) {
    *message += (message->empty() ? "maps not joined by position (" : "; not by position either (") + why + ")";
    return false;
  }
  // The new map moves so that `last` takes its pose against the old map (kFourDof: x, y and yaw only, the camera
  // centre to its place).
  Eigen::Isometry3d t = pose * fr.world_from_camera.inverse();
  if (options_.model == MotionModel::kFourDof) {
    const Eigen::Matrix3d yaw = Eigen::AngleAxisd(std::atan2(t.linear()(1, 0), t.linear()(0, 0)),
                                                  Eigen::Vector3d::UnitZ()).toRotationMatrix();
    t.linear() = yaw;
    t.translation() = pose.translation() - yaw * fr.world_from_camera.translation();
    t.translation().z() = 0;
  }
  const double shift_mm = t.translation().norm(), turn_deg = Eigen::AngleAxisd(t.linear()).angle() * 180 / M_PI;
  ApplySimilarity(1.0, t, first, last, new_points);
  int merged = 0;
  for (const auto& [from, to] : merges)
    if (points_.count(to)) {
      MergeLandmark(from, to, last);
      ++merged;
    }
  std::ostringstream m;
  m << "joined to the old map by position (" << merged << " tracks on old landmarks; the new map moved " << shift_mm
    << " mm, " << turn_deg << " deg)";
  *message = m.str();
  return true;
}

void PoseEstimator::AddKeyframe(int f) {
  frames_[f].keyframe = true;
  int64_t t0 = MonotonicMicros();
  std::vector<int64_t> added;
  TriangulateNew(f, &added);
  if (segment_floor_first_ >= 0) {
    segment_floor_points_.insert(segment_floor_points_.end(), added.begin(), added.end());
    double s = 1;
    if (f - segment_floor_first_ > options_.online_scale_frames) {
      segment_floor_first_ = -1;  // no floor seen in time: the odometry's scale stays
      segment_floor_points_.clear();
    } else if (RescaleToFloorHeight(segment_floor_first_, f, segment_floor_points_, segment_floor_first_, &s,
                                    kMaxLateFloorRescale)) {
      std::ostringstream m;
      m << "map restarted at frame " << frames_[segment_floor_first_].seq << " scaled by " << s
        << " from the camera height above its floor, seen by frame " << frames_[f].seq;
      notice_ = m.str();
      segment_floor_first_ = -1;
      segment_floor_points_.clear();
    }
  }
  TryLateJoin(f, added);
  // Tracks of a map join waiting for parallax.
  std::vector<int64_t> candidates;
  candidates.swap(fuse_pending_);
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  FuseLandmarks(f, candidates);
  tri_ms_ += (MonotonicMicros() - t0) * 1e-3;
  t0 = MonotonicMicros();
  LocalBundleAdjustment(f);
  lba_ms_ += (MonotonicMicros() - t0) * 1e-3;
  if (options_.model == MotionModel::kSixDof && gauge_frame_ >= 0 && f - gauge_frame_ <= options_.online_scale_frames)
    RescaleSixDof(gauge_frame_);
  last_keyframe_ = f;
  last_keyframe_inliers_ = frames_[f].inliers;
  NoteActiveKeyframe(f);
}

void PoseEstimator::NoteActiveKeyframe(int f) {
  if (options_.max_active_keyframes <= 0) return;
  active_keyframes_.push_back(f);
  while (static_cast<int>(active_keyframes_.size()) > options_.max_active_keyframes) {
    const int oldest = active_keyframes_.front();
    active_keyframes_.pop_front();
    if (oldest == gauge_frame_ || oldest == gauge_frame_b_) continue;  // gauge frames keep their observations
    FreezeKeyframe(oldest);
    any_frozen_ = true;
  }
}

int PoseEstimator::TriangulateNew(int f, std::vector<int64_t>* added_ids) {
  const Frame& fr = frames_[f];
  int added = 0;
  std::vector<Eigen::Isometry3d> poses;
  std::vector<Eigen::Vector2d> pixels;
  std::vector<int> views;
  for (size_t i = 0; i < fr.ids.size(); ++i) {
    const int64_t id = fr.ids[i];
    if (points_.count(id)) continue;
    views.clear();
    for (int g : track_frames_[id])
      if (g <= f && frames_[g].posed) views.push_back(g);
    if (static_cast<int>(views.size()) < options_.min_triangulation_views) continue;
    // Evenly spread subset including the first and last view.
    const int m = std::min<int>(options_.max_triangulation_views, static_cast<int>(views.size()));
    poses.clear();
    pixels.clear();
    for (int k = 0; k < m; ++k) {
      const int g = views[static_cast<size_t>(std::llround(static_cast<double>(k) * (views.size() - 1) / (m - 1)))];
      poses.push_back(frames_[g].world_from_camera);
      pixels.push_back(frames_[g].pixels[frames_[g].Find(id)]);
    }
    TriangulatedPoint tp;
    if (!TriangulatePoint(camera_, poses, pixels, options_.triangulation, &tp)) continue;
    Point p{tp.point_in_world, false};
    if (options_.model == MotionModel::kFourDof && scale_source_ == ScaleSource::kCameraHeight &&
        std::abs(p.x.z()) < options_.floor_tolerance_mm)
      p.on_floor = true;
    points_[id] = p;
    ++added;
    if (added_ids) added_ids->push_back(id);
  }
  return added;
}

int PoseEstimator::FuseLandmarks(int f, const std::vector<int64_t>& candidates) {
  if (candidates.empty()) return 0;
  // The other landmarks: a map join's landmarks are fused onto the old map only (last seen before the join's span).
  auto is_old = [&](int64_t id) {
    auto t = track_frames_.find(id);
    return t == track_frames_.end() || t->second.back() < join_first_frame_;
  };
  const std::set<int64_t> is_candidate(candidates.begin(), candidates.end());
  std::vector<int64_t> old_ids;
  std::vector<Eigen::Vector3d> old_x;
  for (const auto& [id, p] : points_)
    if (!is_candidate.count(id) && frames_[f].Find(id) < 0 && is_old(id)) {
      old_ids.push_back(id);
      old_x.push_back(p.x);
    }
  if (old_ids.empty()) return 0;
  const PointGrid grid(old_x, options_.fuse_search_mm);
  int fused = 0;
  for (int64_t n : candidates) {
    auto pn = points_.find(n);
    auto tn = track_frames_.find(n);
    if (pn == points_.end() || tn == track_frames_.end()) continue;
    const Eigen::Vector3d xn = pn->second.x;
    // The new track's posed views (held observations).
    std::vector<std::pair<Eigen::Isometry3d, Eigen::Vector2d>> views;
    for (int g : tn->second) {
      const Frame& fr = frames_[g];
      const int i = fr.Find(n);
      if (fr.posed && i >= 0 && !fr.outlier[i]) views.emplace_back(fr.world_from_camera.inverse(), fr.pixels[i]);
    }
    if (static_cast<int>(views.size()) < 2) continue;
    // Not before the track's views have fuse_min_parallax_deg between them (the position is then good to ~1 mm
    // along the ray; at the first triangulation it is not); a live track is tried again at the next keyframe.
    const Eigen::Vector3d ray_first = views.front().first.inverse().translation() - xn;
    const Eigen::Vector3d ray_last = views.back().first.inverse().translation() - xn;
    const double parallax = std::atan2(ray_first.cross(ray_last).norm(), ray_first.dot(ray_last));
    if (parallax < options_.fuse_min_parallax_deg * M_PI / 180) {
      if (frames_[f].Find(n) >= 0) fuse_pending_.push_back(n);
      continue;
    }
    int64_t best = -1;
    double best_err = options_.fuse_max_px;
    grid.ForEachWithin(xn, options_.fuse_search_mm, [&](int k) {
      const int64_t o = old_ids[k];
      auto po = points_.find(o);  // old landmarks stay (merges remove candidates only); guarded all the same
      if (po == points_.end()) return;
      // Never seen together with the new track (two tracks of one frame are two points).
      if (auto to = track_frames_.find(o); to != track_frames_.end())
        for (int g : tn->second)
          if (std::binary_search(to->second.begin(), to->second.end(), g)) return;
      double worst = 0;
      for (const auto& [camera_from_world, px] : views) {
        Eigen::Vector2d uv;
        if (!ProjectIdeal(camera_, camera_from_world * po->second.x, &uv)) return;
        worst = std::max(worst, (uv - px).norm());
        if (worst >= best_err) return;
      }
      best_err = worst;
      best = o;
    });
    if (best < 0) continue;
    MergeLandmark(n, best, f);
    ++fused;
  }
  return fused;
}

bool PoseEstimator::JoinToOldMap(int first, int last, const std::vector<int64_t>& new_points, int* num_pairs,
                                 std::string* message) {
  *num_pairs = 0;
  const std::set<int64_t> is_new(new_points.begin(), new_points.end());
  std::vector<Eigen::Vector3d> old_x, new_x;
  for (const auto& [id, p] : points_) (is_new.count(id) ? new_x : old_x).push_back(p.x);
  if (old_x.empty() || new_x.empty()) {
    *message = "no landmarks to join the maps (odometry chaining kept)";
    return false;
  }
  const PointGrid grid(old_x, options_.join_search_mm);
  auto hash = [](const Eigen::Vector3i& c) {
    return (static_cast<int64_t>(c.x()) * 73856093) ^ (static_cast<int64_t>(c.y()) * 19349663) ^
           (static_cast<int64_t>(c.z()) * 83492791);
  };
  // 1. The offset old - new that most pairs within the search radius agree on (2 mm bins, summed over 3x3x3
  //    neighbourhoods): landmarks of corners seen by both maps coincide there; other pairs spread over the whole
  //    search volume.
  const double bin = 2.0;
  std::unordered_map<int64_t, std::pair<Eigen::Vector3i, int>> votes;  // bin hash -> (bin, pairs)
  for (const Eigen::Vector3d& x : new_x)
    grid.ForEachWithin(x, options_.join_search_mm, [&](int i) {
      const Eigen::Vector3i b(((old_x[i] - x) / bin).array().round().cast<int>());
      auto& v = votes[hash(b)];
      v.first = b;
      ++v.second;
    });
  if (votes.empty()) {
    *message = "no old landmark near the new map (odometry chaining kept)";
    return false;
  }
  int best_votes = -1;
  Eigen::Vector3i best_bin = Eigen::Vector3i::Zero();
  for (const auto& [h, v] : votes) {
    int sum = 0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = votes.find(hash(v.first + Eigen::Vector3i(dx, dy, dz)));
          if (it != votes.end()) sum += it->second.second;
        }
    const Eigen::Vector3i& b = v.first;  // ties: the smallest bin, so the result does not depend on hash order
    if (sum > best_votes || (sum == best_votes && std::make_tuple(b.x(), b.y(), b.z()) <
                                                      std::make_tuple(best_bin.x(), best_bin.y(), best_bin.z()))) {
      best_votes = sum;
      best_bin = b;
    }
  }
  const Eigen::Vector3d offset = best_bin.cast<double>() * bin;
  // 2. Pairs (each new landmark's nearest old one after the transform) and the transform by least squares, over
  //    rounds with a shrinking radius: Sim(3) for kSixDof; kFourDof keeps the robot model (floor plane, camera
  //    height): x, y and yaw only.
  const bool four_dof = options_.model == MotionModel::kFourDof;
  auto pairs_for = [&](const Sim3& t, double radius, std::vector<Eigen::Vector3d>* from,
                       std::vector<Eigen::Vector3d>* to) {
    int n = 0;
    for (const Eigen::Vector3d& x : new_x) {
      const Eigen::Vector3d y = t * x;
      int nearest = -1;
      double d2 = radius * radius;
      grid.ForEachWithin(y, radius, [&](int i) {
        const double e = (old_x[i] - y).squaredNorm();
        if (e <= d2) {
          d2 = e;
          nearest = i;
        }
      });
      if (nearest < 0) continue;
      ++n;
      if (from) from->push_back(x);
      if (to) to->push_back(old_x[nearest]);
    }
    return n;
  };
  Sim3 sim;
  sim.translation = offset;
  std::vector<Eigen::Vector3d> src, dst;
  for (double radius : {8.0, 4.0, 2.5, options_.join_max_mm}) {
    src.clear();
    dst.clear();
    pairs_for(sim, radius, &src, &dst);
    if (static_cast<int>(src.size()) < options_.join_min_landmarks) break;
    Sim3 next;
    bool ok = false;
    if (four_dof) {
      std::vector<Eigen::Vector3d> a = src, b = dst;
      for (auto& v : a) v.z() = 0;
      for (auto& v : b) v.z() = 0;
      ok = AlignUmeyama(a, b, false, &next);
      next.translation.z() = 0;
    } else {
      ok = AlignUmeyama(src, dst, true, &next);
    }
    if (!ok) {
      *num_pairs = static_cast<int>(src.size());
      *message = "maps not joined: degenerate landmark pairs (odometry chaining kept)";
      return false;
    }
    sim = next;
  }
  *num_pairs = static_cast<int>(src.size());
  // Chance pairs: the same count with the transform shifted by a wrong 6 mm in x and y.
  Sim3 wrong = sim;
  wrong.translation += Eigen::Vector3d(6, 6, 0);
  const int chance = pairs_for(wrong, options_.join_max_mm, nullptr, nullptr);
  if (*num_pairs < options_.join_min_landmarks || *num_pairs < 3 * chance) {
    std::ostringstream m;
    m << "maps not joined: " << *num_pairs << " common landmarks (need " << options_.join_min_landmarks
      << " and 3x the " << chance << " found at a wrong offset; most agreed offset " << offset.transpose() << " mm by "
      << best_votes << " pairs; odometry chaining kept)";
    *message = m.str();
    return false;
  }
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = sim.rotation;
  t.translation() = sim.translation;
  ApplySimilarity(sim.scale, t, first, last, new_points);
  std::ostringstream m;
  m << "joined to the old map by " << *num_pairs << " landmarks (" << chance << " at a wrong offset; shift "
    << sim.translation.norm() << " mm, rotation " << RotationAngle(sim.rotation) * 180 / M_PI << " deg, scale "
    << sim.scale << ")";
  *message = m.str();
  return true;
}

void PoseEstimator::TryLateJoin(int f, const std::vector<int64_t>& added) {
  // A map that grows slowly is still tried every kLateJoinRetryFrames: a restart facing a part of the room the old
  // map never held meets the old map's parts only when the robot comes back to them, minutes later (room_02, 7 Dec:
  // restarted at frame 554, tried until frame 1454 only, never joined over the 5 000 frames after; the model 390 mm
  // off). Each try costs a grid lookup per landmark of the new map.
  constexpr int kLateJoinRetryFrames = 300;  // 10 s at 30 Hz
  if (unjoined_first_ < 0) return;
  unjoined_points_.insert(unjoined_points_.end(), added.begin(), added.end());
  const bool grown_by_half = unjoined_points_.size() >= unjoined_tried_size_ + unjoined_tried_size_ / 2;
  const bool retry_due = f - unjoined_tried_frame_ >= kLateJoinRetryFrames && unjoined_points_.size() > unjoined_tried_size_;
  if (!grown_by_half && !retry_due) return;
  unjoined_tried_size_ = unjoined_points_.size();
  unjoined_tried_frame_ = f;
  RecheckUnjoinedScale(f);  // the join needs both maps at one scale
  if (options_.join_search_mm <= 0) return;
  // Landmarks merged or removed since are skipped by JoinToOldMap (it reads points_).
  int pairs = 0;
  std::string message;
  if (!JoinToOldMap(unjoined_first_, f, unjoined_points_, &pairs, &message)) return;
  message += " at frame " + std::to_string(frames_[f].seq);
  segment_floor_first_ = -1;  // joined: the old map's scale
  segment_floor_points_.clear();
  join_first_frame_ = unjoined_first_;
  const int fused = FuseLandmarks(f, unjoined_points_);
  std::ostringstream m;
  m << "map restarted at frame " << frames_[unjoined_first_].seq << " " << message << ", " << fused
    << " landmarks fused";
  notice_ += (notice_.empty() ? "" : "; ") + m.str();
  // Joined: the restart's frames lie in the map before it now.
  if (map_before_restart_ >= 0) {
    for (Frame& fr : frames_)
      if (fr.map_start_seq == current_map_start_) fr.map_start_seq = map_before_restart_;
    current_map_start_ = map_before_restart_;
  }
  unjoined_first_ = -1;
  unjoined_points_.clear();
}

void PoseEstimator::RecheckUnjoinedScale(int f) {
  constexpr double kMinScaleChange = 0.02;
  if (options_.model != MotionModel::kSixDof || !options_.use_floor_for_scale || !options_.camera_height_known) return;
  if (segment_floor_first_ >= 0) return;  // the restart's first floor search still runs (AddKeyframe)
  double s = 1;
  if (!RescaleToFloorHeight(unjoined_first_, f, unjoined_points_, unjoined_first_, &s, kMaxLateFloorRescale,
                            kMinScaleChange))
    return;
  std::ostringstream m;
  m << "map restarted at frame " << frames_[unjoined_first_].seq << " (not joined) rescaled by " << s
    << " from the camera height above the floor among its " << unjoined_points_.size() << " landmarks, at frame "
    << frames_[f].seq;
  notice_ += (notice_.empty() ? "" : "; ") + m.str();
}

void PoseEstimator::MergeLandmark(int64_t from, int64_t to, int f) {
  auto tf = track_frames_.find(from);
  std::vector<int> moved = tf != track_frames_.end() ? tf->second : std::vector<int>();
  for (int g : moved) {
    Frame& fr = frames_[g];
    const int i = fr.Find(from);
    if (i < 0) continue;
    if (fr.Find(to) >= 0) {  // cannot happen (never seen together); keep the frame consistent anyway
      fr.ids.erase(fr.ids.begin() + i);
      fr.pixels.erase(fr.pixels.begin() + i);
      fr.outlier.erase(fr.outlier.begin() + i);
      continue;
    }
    // Keep ids sorted: move the entry to the landmark id's place.
    const Eigen::Vector2d px = fr.pixels[i];
    const uint8_t out = fr.outlier[i];
    fr.ids.erase(fr.ids.begin() + i);
    fr.pixels.erase(fr.pixels.begin() + i);
    fr.outlier.erase(fr.outlier.begin() + i);
    const size_t at = static_cast<size_t>(std::lower_bound(fr.ids.begin(), fr.ids.end(), to) - fr.ids.begin());
    fr.ids.insert(fr.ids.begin() + at, to);
    fr.pixels.insert(fr.pixels.begin() + at, px);
    fr.outlier.insert(fr.outlier.begin() + at, out);
  }
  if (tf != track_frames_.end()) track_frames_.erase(tf);
  // Tracks fused into `from` earlier now observe `to` (no alias chains).
  for (auto& [track, alias] : alias_)
    if (alias.landmark == from) alias.landmark = to;
  for (auto& [track, landmark] : fused_tracks_)
    if (landmark == from) landmark = to;
  if (auto pf = points_.find(from); pf != points_.end()) {
    Point& target = points_[to];
    target.dropped_observations += pf->second.dropped_observations;
    target.dropped_sq_error += pf->second.dropped_sq_error;
  }
  std::vector<int>& list = track_frames_[to];
  std::vector<int> merged;
  merged.reserve(list.size() + moved.size());
  std::merge(list.begin(), list.end(), moved.begin(), moved.end(), std::back_inserter(merged));
  merged.erase(std::unique(merged.begin(), merged.end()), merged.end());
  list.swap(merged);
  points_.erase(from);
  alias_[from] = Alias{to, f};
  fused_tracks_.emplace_back(from, to);
}

void PoseEstimator::UpdateFrameStatistics(Frame* frame) const {
  const Frame& fr = *frame;
  const Eigen::Isometry3d cw = fr.world_from_camera.inverse();
  int n = 0;
  double sum = 0;
  for (size_t i = 0; i < fr.ids.size(); ++i) {
    auto it = points_.find(fr.ids[i]);
    if (it == points_.end()) continue;
    Eigen::Vector2d uv;
    if (!ProjectIdeal(camera_, cw * it->second.x, &uv)) continue;
    const double e2 = (uv - fr.pixels[i]).squaredNorm();
    if (e2 > options_.pnp.inlier_threshold_px * options_.pnp.inlier_threshold_px) continue;
    ++n;
    sum += e2;
  }
  frame->inliers = n;
  frame->rms = n > 0 ? std::sqrt(sum / n) : 0.0;
}

void PoseEstimator::LocalBundleAdjustment(int f) {
  // Window: the last local_window_keyframes posed keyframes up to f.
  std::vector<int> window;
  for (int g = f; g >= 0 && static_cast<int>(window.size()) < options_.local_window_keyframes; --g)
    if (frames_[g].keyframe && frames_[g].posed) window.push_back(g);
  std::reverse(window.begin(), window.end());
  if (window.empty()) return;
  std::set<int64_t> point_set;
  for (int g : window) {
    const Frame& fr = frames_[g];
    for (size_t i = 0; i < fr.ids.size(); ++i)
      if (!fr.outlier[i] && points_.count(fr.ids[i])) point_set.insert(fr.ids[i]);
  }
  std::set<int> observers;
  for (int64_t id : point_set)
    for (int g : track_frames_[id])
      if (frames_[g].keyframe && frames_[g].posed && g < window[0]) observers.insert(g);
  std::set<int> frame_set(window.begin(), window.end());
  int taken = 0;
  for (auto it = observers.rbegin(); it != observers.rend() && taken < options_.local_fixed_keyframes; ++it, ++taken)
    frame_set.insert(*it);
  std::vector<int> frame_list(frame_set.begin(), frame_set.end());
  std::vector<int64_t> point_list(point_set.begin(), point_set.end());
  std::unordered_map<int64_t, int> point_index;
  BaProblem bp;
  for (size_t i = 0; i < point_list.size(); ++i) {
    point_index[point_list[i]] = static_cast<int>(i);
    const Point& p = points_[point_list[i]];
    bp.points.push_back(p.x);
    bp.point_on_floor.push_back(p.on_floor ? 1 : 0);
  }
  int fixed = 0;
  for (size_t k = 0; k < frame_list.size(); ++k) {
    const int g = frame_list[k];
    const Frame& fr = frames_[g];
    bp.world_from_camera.push_back(fr.world_from_camera);
    const bool in_window = std::binary_search(window.begin(), window.end(), g) || frame_set.count(g) == 0;
    const bool free_frame = std::find(window.begin(), window.end(), g) != window.end();
    (void)in_window;
    bp.frame_fix.push_back(free_frame ? FrameFix::kFree : FrameFix::kFixed);
    fixed += free_frame ? 0 : 1;
    for (size_t i = 0; i < fr.ids.size(); ++i) {
      if (fr.outlier[i]) continue;
      auto it = point_index.find(fr.ids[i]);
      if (it != point_index.end()) bp.observations.push_back({static_cast<int>(k), it->second, fr.pixels[i]});
    }
  }
  // Gauge.
  const bool floor_mode = options_.model == MotionModel::kFourDof && scale_source_ == ScaleSource::kCameraHeight;
  auto index_of = [&](int g) {
    return static_cast<int>(std::lower_bound(frame_list.begin(), frame_list.end(), g) - frame_list.begin());
  };
  if (floor_mode) {
    if (fixed == 0) bp.frame_fix[index_of(window[0])] = FrameFix::kFixedFloor;
  } else {
    for (size_t w = 0; fixed < 2 && w < window.size(); ++w) {
      bp.frame_fix[index_of(window[w])] = FrameFix::kFixed;
      ++fixed;
    }
  }
  const BaSummary s = RunBundleAdjustment(camera_, options_.robot, MakeBaOptions(options_.local_ba_iterations), &bp);
  if (!s.ok) return;
  for (size_t k = 0; k < frame_list.size(); ++k)
    if (bp.frame_fix[k] != FrameFix::kFixed) frames_[frame_list[k]].world_from_camera = bp.world_from_camera[k];
  for (size_t i = 0; i < point_list.size(); ++i) points_[point_list[i]].x = bp.points[i];
  PruneLandmarks(point_list, frame_list);
}

void PoseEstimator::PruneLandmarks(const std::vector<int64_t>& ids, const std::vector<int>& frames) {
  std::set<int> frame_set(frames.begin(), frames.end());
  for (int64_t id : ids) {
    auto it = points_.find(id);
    if (it == points_.end()) continue;
    double sum = 0;
    int n = 0;
    bool behind = false;
    for (int g : track_frames_[id]) {
      if (!frame_set.count(g)) continue;
      const Frame& fr = frames_[g];
      const int i = fr.Find(id);
      if (i < 0 || fr.outlier[i]) continue;
      Eigen::Vector2d uv;
      if (!ProjectIdeal(camera_, fr.world_from_camera.inverse() * it->second.x, &uv)) {
        behind = true;
        break;
      }
      sum += (uv - fr.pixels[i]).squaredNorm();
      ++n;
    }
    if (behind || (n > 0 && std::sqrt(sum / n) > options_.max_landmark_error_px)) points_.erase(it);
  }
}

bool PoseEstimator::GlobalBundleAdjustment() {
  std::vector<int> frame_list;
  for (int g = 0; g < static_cast<int>(frames_.size()); ++g)
    if (frames_[g].posed && !frames_[g].frozen &&
        (options_.global_ba_all_frames || frames_[g].keyframe || g == gauge_frame_ || g == gauge_frame_b_))
      frame_list.push_back(g);
  std::vector<int64_t> point_list;
  std::unordered_map<int64_t, int> point_index;
  BaProblem bp;
  for (const auto& [id, p] : points_) {
    point_index[id] = static_cast<int>(point_list.size());
    point_list.push_back(id);
    bp.points.push_back(p.x);
    bp.point_on_floor.push_back(p.on_floor ? 1 : 0);
  }
  int gauge_index = -1, gauge_b_index = -1;
  for (size_t k = 0; k < frame_list.size(); ++k) {
    const int g = frame_list[k];
    const Frame& fr = frames_[g];
    if (g == gauge_frame_) gauge_index = static_cast<int>(k);
    if (g == gauge_frame_b_) gauge_b_index = static_cast<int>(k);
    bp.world_from_camera.push_back(fr.world_from_camera);
    bp.frame_fix.push_back(FrameFix::kFree);
    // Observations further than the PnP inlier threshold from the current map are left out: they were never checked
    // (points triangulated after the frame's PnP) and in the robust loss' linear region they only slow it down.
    const Eigen::Isometry3d cw = fr.world_from_camera.inverse();
    for (size_t i = 0; i < fr.ids.size(); ++i) {
      if (fr.outlier[i]) continue;
      auto it = point_index.find(fr.ids[i]);
      if (it == point_index.end()) continue;
      Eigen::Vector2d uv;
      if (!ProjectIdeal(camera_, cw * bp.points[it->second], &uv) ||
          (uv - fr.pixels[i]).norm() > options_.pnp.inlier_threshold_px)
        continue;
      bp.observations.push_back({static_cast<int>(k), it->second, fr.pixels[i]});
    }
  }
  if (gauge_index < 0) gauge_index = 0;
  const bool floor_mode = options_.model == MotionModel::kFourDof && scale_source_ == ScaleSource::kCameraHeight;
  bp.frame_fix[gauge_index] = floor_mode ? FrameFix::kFixedFloor : FrameFix::kFixed;
  if (any_frozen_) {
    // The frozen keyframes no longer tie the active ones to the gauge frames: the two oldest active keyframes
    // (the ones right after the frozen block) hold them where the windowed adjustments left them.
    int held = 0;
    for (int g : active_keyframes_) {
      if (held == 2) break;
      if (g == gauge_frame_ || g == gauge_frame_b_ || !frames_[g].posed) continue;
      const auto it = std::lower_bound(frame_list.begin(), frame_list.end(), g);
      if (it == frame_list.end() || *it != g) continue;
      bp.frame_fix[static_cast<size_t>(it - frame_list.begin())] = FrameFix::kFixed;
      ++held;
    }
  }
  if (!floor_mode && gauge_b_index >= 0 && gauge_b_index != gauge_index) {
    bp.distance_frame_a = gauge_index;
    bp.distance_frame_b = gauge_b_index;
    bp.distance_mm =
        (bp.world_from_camera[gauge_index].translation() - bp.world_from_camera[gauge_b_index].translation()).norm();
  }
  BaOptions global_options = MakeBaOptions(options_.global_ba_iterations);
  global_options.function_tolerance = options_.global_ba_function_tolerance;
  const BaSummary s = RunBundleAdjustment(camera_, options_.robot, global_options, &bp);
  last_message_ = "global BA: " + s.message;
  if (!s.ok) return false;
  std::vector<Eigen::Isometry3d> before;
  before.reserve(frames_.size());
  for (const Frame& fr : frames_) before.push_back(fr.world_from_camera);
  for (size_t k = 0; k < frame_list.size(); ++k) frames_[frame_list[k]].world_from_camera = bp.world_from_camera[k];
  FollowKeyframes(before);
  for (size_t i = 0; i < point_list.size(); ++i) points_[point_list[i]].x = bp.points[i];
  PruneLandmarks(point_list, frame_list);
  if (options_.global_ba_all_frames) return true;
  // The other frames: pose-only refit against the adjusted map (inliers of their PnP kept).
  for (int g = 0; g < static_cast<int>(frames_.size()); ++g)
    if (frames_[g].posed && !std::binary_search(frame_list.begin(), frame_list.end(), g)) RefitPose(g);
  return true;
}

void PoseEstimator::RefitPose(int f) {
  Frame& fr = frames_[f];
  std::vector<Eigen::Vector3d> pts;
  std::vector<Eigen::Vector2d> px;
  std::vector<int> use;
  for (size_t i = 0; i < fr.ids.size(); ++i) {
    if (fr.outlier[i]) continue;
    auto it = points_.find(fr.ids[i]);
    if (it == points_.end()) continue;
    use.push_back(static_cast<int>(pts.size()));
    pts.push_back(it->second.x);
    px.push_back(fr.pixels[i]);
  }
  if (static_cast<int>(use.size()) >= options_.pnp.min_inliers)
    RefinePose(camera_, options_.robot, MakeBaOptions(options_.pnp.refine_iterations), pts, px, use,
               &fr.world_from_camera);
}

void PoseEstimator::RescaleSixDof(int first_frame) {
  if (options_.use_floor_for_scale && gauge_frame_ >= 0) {
    std::vector<int64_t> all;
    all.reserve(points_.size());
    for (const auto& kv : points_) all.push_back(kv.first);
    if (RescaleToFloorHeight(0, static_cast<int>(frames_.size()) - 1, all, gauge_frame_)) return;
  }
  if (options_.refine_scale_with_odometry) RescaleToOdometryPath(first_frame);
}

bool PoseEstimator::RescaleToFloorHeight(int first_frame, int last_frame, const std::vector<int64_t>& point_ids,
                                         int pivot_frame, double* applied_scale, double max_factor, double min_change) {
  if (pivot_frame < 0 || !frames_[pivot_frame].posed) return false;
  std::vector<int64_t> floor_ids;
  FloorPlane plane;
  if (!DetectFloor(point_ids, &floor_ids, &plane)) return false;
  const Eigen::Vector3d c0 = frames_[pivot_frame].world_from_camera.translation();
  Eigen::Vector3d n = plane.normal;
  double d = plane.offset_mm;
  if (n.dot(c0) + d < 0) {
    n = -n;
    d = -d;
  }
  // Expected height from each camera's tilt relative to the plane (the world z need not be vertical).
  const Eigen::Matrix3d level = Eigen::Quaterniond::FromTwoVectors(n, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  double measured = 0, expected = 0;
  for (int f = first_frame; f <= last_frame; ++f) {
    const Frame& fr = frames_[f];
    if (!fr.posed) continue;
    measured += n.dot(fr.world_from_camera.translation()) + d;
    Eigen::Isometry3d levelled = Eigen::Isometry3d::Identity();
    levelled.linear() = level * fr.world_from_camera.linear();
    expected +=
        WorldFromCameraFloor(options_.robot, FloorPoseFromWorldFromCamera(options_.robot, levelled)).translation().z();
  }
  if (!(measured > 1e-6 && expected > 1e-6)) return false;
  const bool images_only =
      std::none_of(frames_.begin(), frames_.end(), [](const Frame& fr) { return fr.has_odometry; });
  if (!options_.camera_height_known && !images_only) return false;  // odometry's scale and level stay
  // Unknown camera height (images only): the floor levels the world, the scale stays as it is.
  const double s = options_.camera_height_known ? expected / measured : 1.0;
  if (applied_scale) *applied_scale = s;
  if (max_factor > 0 && (s > max_factor || s < 1.0 / max_factor)) return false;
  if (min_change > 0 && std::abs(s - 1.0) <= min_change) return false;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = c0 - s * c0;
  if (images_only) {
    // Images only: the world was the first camera's frame. Level it as the odometry's would be: the floor becomes
    // z = 0 with +z up, so that every consumer (region of interest, object finder, planner, viewer) finds the floor
    // where a robot's world has it.
    const Eigen::Matrix3d level = Eigen::Quaterniond::FromTwoVectors(n, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d on_plane = s * (-d * n) + c0 - s * c0;  // a floor point after the scaling
    t.linear() = level;
    t.translation() = level * (c0 - s * c0);
    t.translation().z() -= (level * on_plane).z();
  }
  ApplySimilarity(s, t, first_frame, last_frame, point_ids);
  if (options_.camera_height_known) scale_source_ = ScaleSource::kCameraHeight;
  return true;
}

bool PoseEstimator::OdometryStepScale(int first_frame, int last_frame, double* scale) const {
  // Only the steps that travel (>= 30 % of the longest): the ratio of two near-zero steps (a turn in place, where
  // only the camera's offset from the pan axis moves it) is noise, and a span that starts with a turn would be
  // scaled by it (synthetic: scale 0.47 after 57 turning and 10 travelling frames).
  std::vector<std::pair<double, double>> steps;  // (odometry, visual) step lengths
  double longest = 0;
  for (int f = std::max(1, first_frame + 1); f <= last_frame; ++f) {
    const Frame& a = frames_[f - 1];
    const Frame& b = frames_[f];
    if (!a.posed || !b.posed || !a.has_odometry || !b.has_odometry) continue;
    const double odo = (b.odometry_world_from_camera.translation() - a.odometry_world_from_camera.translation()).norm();
    const double vis = (b.world_from_camera.translation() - a.world_from_camera.translation()).norm();
    steps.push_back({odo, vis});
    longest = std::max(longest, odo);
  }
  std::vector<double> ratios;
  for (const auto& [odo, vis] : steps)
    if (odo > 1e-3 && odo >= 0.3 * longest && vis > 1e-9) ratios.push_back(odo / vis);
  if (ratios.empty()) return false;
  const size_t m = ratios.size() / 2;
  std::nth_element(ratios.begin(), ratios.begin() + m, ratios.end());
  double med = ratios[m];
  if (ratios.size() % 2 == 0) med = 0.5 * (med + *std::max_element(ratios.begin(), ratios.begin() + m));
  *scale = med;
  return std::isfinite(med) && med > 0;
}

double PoseEstimator::RescaleToOdometryPath(int first_frame) {
  if (scale_source_ != ScaleSource::kOdometry || gauge_frame_ < 0) return 1.0;
  double odo = 0, vis = 0;
  for (int f = std::max(1, first_frame + 1); f < static_cast<int>(frames_.size()); ++f) {
    const Frame& a = frames_[f - 1];
    const Frame& b = frames_[f];
    if (!a.posed || !b.posed || !a.has_odometry || !b.has_odometry) continue;
    odo += (b.odometry_world_from_camera.translation() - a.odometry_world_from_camera.translation()).norm();
    vis += (b.world_from_camera.translation() - a.world_from_camera.translation()).norm();
  }
  if (!(odo > 0 && vis > 0)) return 1.0;
  const double s = odo / vis;
  const Eigen::Vector3d c0 = frames_[gauge_frame_].world_from_camera.translation();
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = c0 - s * c0;
  std::vector<int64_t> all;
  all.reserve(points_.size());
  for (const auto& kv : points_) all.push_back(kv.first);
  ApplySimilarity(s, t, 0, static_cast<int>(frames_.size()) - 1, all);
  return s;
}

bool PoseEstimator::TwoViewPose(int f) {
  if (options_.two_view_min_matches <= 0 || last_good_ < 0 || options_.model != MotionModel::kSixDof) return false;
  Frame& fr = frames_[f];
  const Frame& ref = frames_[last_good_];
  // Tracks shared with the last posed frame (ids sorted in both).
  std::vector<cv::Point2d> a, b;
  for (size_t i = 0, j = 0; i < ref.ids.size() && j < fr.ids.size();) {
    if (ref.ids[i] < fr.ids[j]) {
      ++i;
    } else if (fr.ids[j] < ref.ids[i]) {
      ++j;
    } else {
      a.emplace_back(ref.pixels[i].x(), ref.pixels[i].y());
      b.emplace_back(fr.pixels[j].x(), fr.pixels[j].y());
      ++i;
      ++j;
    }
  }
  auto fail = [&](const std::string& why) {
    last_message_ = "frame " + std::to_string(fr.seq) + ": two-view pose failed: " + why;
    return false;
  };
  if (static_cast<int>(a.size()) < options_.two_view_min_matches)
    return fail(std::to_string(a.size()) + " tracks shared with frame " + std::to_string(ref.seq));
  cv::Mat k;
  cv::eigen2cv(camera_.K(), k);
  cv::Mat mask;
  const cv::Mat e = cv::findEssentialMat(a, b, k, cv::RANSAC, 0.999, options_.pnp.inlier_threshold_px * 0.5, mask);
  if (e.rows != 3 || e.cols != 3) return fail("no unique essential matrix");
  cv::Mat r_cv, t_cv;
  const int good = cv::recoverPose(e, a, b, k, r_cv, t_cv, mask);
  if (good < options_.two_view_min_matches) return fail(std::to_string(good) + " essential-matrix inliers");
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  cv::cv2eigen(r_cv, r);
  cv::cv2eigen(t_cv, t);  // x_f = r x_ref + s t, |t| = 1, s unknown
  // Scale: every landmark seen in f gives s from its viewing ray (least squares along the ray's normal plane).
  const Eigen::Isometry3d ref_from_world = ref.world_from_camera.inverse();
  const Eigen::Matrix3d k_inv = camera_.K().inverse();
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector2d>> seen;  // landmark in ref's frame, pixel in f
  std::vector<double> scales;
  for (size_t j = 0; j < fr.ids.size(); ++j) {
    const auto it = points_.find(fr.ids[j]);
    if (it == points_.end()) continue;
    const Eigen::Vector3d x_ref = ref_from_world * it->second.x;
    const Eigen::Vector3d d = (k_inv * fr.pixels[j].homogeneous()).normalized();
    const Eigen::Matrix3d proj = Eigen::Matrix3d::Identity() - d * d.transpose();
    const Eigen::Vector3d pt = proj * t, prx = proj * (r * x_ref);
    if (pt.squaredNorm() < 1e-12) continue;
    seen.emplace_back(x_ref, fr.pixels[j]);
    scales.push_back(-pt.dot(prx) / pt.squaredNorm());
  }
  if (static_cast<int>(scales.size()) < options_.two_view_min_landmarks)
    return fail(std::to_string(scales.size()) + " landmarks seen");
  std::vector<double> sorted = scales;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double s = sorted[sorted.size() / 2];
  if (!(s > 0)) return fail("scale not positive");
  // The landmarks that agree with the scaled pose.
  int agree = 0;
  for (const auto& [x_ref, pixel] : seen) {
    Eigen::Vector2d uv;
    if (ProjectIdeal(camera_, r * x_ref + s * t, &uv) && (uv - pixel).norm() < options_.pnp.inlier_threshold_px)
      ++agree;
  }
  if (agree < options_.two_view_min_landmarks)
    return fail(std::to_string(agree) + " of " + std::to_string(seen.size()) + " landmarks agree with the scale");
  Eigen::Isometry3d f_from_ref = Eigen::Isometry3d::Identity();
  f_from_ref.linear() = r;
  f_from_ref.translation() = s * t;
  std::fill(fr.outlier.begin(), fr.outlier.end(), 0);
  fr.posed = true;
  fr.map_start_seq = current_map_start_;
  fr.world_from_camera = ref.world_from_camera * f_from_ref.inverse();
  UpdateFrameStatistics(&fr);
  fr.status = phase_ == Phase::kLost ? PoseStatus::kRelocalized : PoseStatus::kTracking;
  phase_ = Phase::kTracking;
  last_good_ = f;
  std::ostringstream m;
  m << "frame " << fr.seq << " posed from the essential matrix with frame " << ref.seq << " (" << good
    << " inliers), scale from " << agree << "/" << seen.size() << " landmarks";
  last_message_ = m.str();
  return true;
}

bool PoseEstimator::RegisterAgainstMap(int f, const Eigen::Isometry3d& prior) {
  if (!PoseFromMap(f, &prior, nullptr)) return false;
  frames_[f].status = PoseStatus::kTracking;
  return true;
}

std::vector<int64_t> PoseEstimator::UnjoinedRestartSeqs() const {
  std::vector<int64_t> seqs = unjoined_restart_seqs_;
  if (unjoined_first_ >= 0) seqs.push_back(frames_[unjoined_first_].seq);
  return seqs;
}

double MapBendFraction(const std::vector<Eigen::Vector3d>& before, const std::vector<Eigen::Vector3d>& after) {
  if (before.size() != after.size() || before.size() < 10) return -1;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : after) mean += p;
  mean /= static_cast<double>(after.size());
  double spread_sq = 0;
  for (const Eigen::Vector3d& p : after) spread_sq += (p - mean).squaredNorm();
  const double spread = std::sqrt(spread_sq / static_cast<double>(after.size()));
  Sim3 sim;
  double rms = 0;
  if (!(spread > 0) || !AlignSimilarity(before, after, &sim, &rms)) return -1;
  std::vector<double> d;
  d.reserve(after.size());
  for (size_t i = 0; i < after.size(); ++i) d.push_back((sim * before[i] - after[i]).norm());
  const size_t p90 = d.size() * 9 / 10;
  std::nth_element(d.begin(), d.begin() + p90, d.end());
  return d[p90] / spread;
}

void PoseEstimator::GlobalBundleAdjustmentKeepingShape() {
  final_bend_fraction_ = -1;
  final_ba_dropped_ = false;
  if (!any_frozen_) {  // the BA over every keyframe is the whole adjustment, not a refinement: nothing to hold it to
    GlobalBundleAdjustment();
    return;
  }
  // The windowed adjustments' state, restored when the BA bends a map.
  std::vector<Eigen::Isometry3d> poses_before;
  poses_before.reserve(frames_.size());
  for (const Frame& fr : frames_) poses_before.push_back(fr.world_from_camera);
  std::map<int64_t, Point> points_before = points_;
  if (!GlobalBundleAdjustment()) return;
  std::map<int64_t, std::pair<std::vector<Eigen::Vector3d>, std::vector<Eigen::Vector3d>>> maps;  // before, after
  for (size_t f = 0; f < frames_.size(); ++f) {
    if (!frames_[f].posed) continue;
    auto& m = maps[frames_[f].map_start_seq];
    m.first.push_back(poses_before[f].translation());
    m.second.push_back(frames_[f].world_from_camera.translation());
  }
  for (const auto& [map_start, centres] : maps)
    final_bend_fraction_ = std::max(final_bend_fraction_, MapBendFraction(centres.first, centres.second));
  std::ostringstream m;
  if (final_bend_fraction_ > kMaxFinalBendFraction) {
    for (size_t f = 0; f < frames_.size(); ++f) frames_[f].world_from_camera = poses_before[f];
    points_ = std::move(points_before);
    final_ba_dropped_ = true;
    m << "global BA dropped: it bent a map by " << 100.0 * final_bend_fraction_
      << " % of its camera spread (p90, after a similarity; over " << 100.0 * kMaxFinalBendFraction
      << " %): the final poses are the windowed adjustments' (" << last_message_ << ")";
    last_message_ = m.str();
  } else if (final_bend_fraction_ >= 0) {
    m << "; map bend " << 100.0 * final_bend_fraction_ << " % of the camera spread (p90, kept)";
    last_message_ += m.str();
  }
}

std::vector<CameraPoseEstimate> PoseEstimator::Finish() {
  const int64_t start_us = MonotonicMicros();
  if (map_initialized_) {
    // Register frames never posed (before the first span, lost stretches) against the map.
    for (int f = 0; f < static_cast<int>(frames_.size()); ++f) {
      if (frames_[f].posed) continue;
      int nearest = -1;
      for (int d = 1; d < static_cast<int>(frames_.size()) && nearest < 0; ++d) {
        if (f + d < static_cast<int>(frames_.size()) && frames_[f + d].posed)
          nearest = f + d;
        else if (f - d >= 0 && frames_[f - d].posed)
          nearest = f - d;
      }
      if (nearest < 0) break;
      if (RegisterAgainstMap(f, frames_[nearest].world_from_camera))
        frames_[f].map_start_seq = frames_[nearest].map_start_seq;  // registered from its neighbour's map
    }
    GlobalBundleAdjustmentKeepingShape();
    if (options_.model == MotionModel::kSixDof) RescaleSixDof(0);
    // Final per-frame statistics (compacted and frozen frames keep their online figures).
    for (auto& fr : frames_)
      if (fr.posed && !fr.compacted && !fr.frozen) UpdateFrameStatistics(&fr);
  }
  final_ba_ms_ = (MonotonicMicros() - start_us) * 1e-3;
  std::vector<CameraPoseEstimate> out;
  out.reserve(frames_.size());
  for (int f = 0; f < static_cast<int>(frames_.size()); ++f) out.push_back(Estimate(f));
  return out;
}

std::vector<Landmark> PoseEstimator::Landmarks(bool current_map_only) const {
  std::vector<Landmark> out;
  out.reserve(points_.size());
  std::unordered_set<int64_t> current;
  const bool only_current = current_map_only && unjoined_first_ >= 0;
  if (only_current) current.insert(unjoined_points_.begin(), unjoined_points_.end());
  for (const auto& [id, p] : points_) {
    if (only_current && !current.count(id)) continue;
    Landmark l;
    l.id = id;
    l.position_mm = p.x;
    l.on_floor = p.on_floor;
    double sum = 0;
    int n = 0;
    auto tf = track_frames_.find(id);
    if (tf != track_frames_.end()) {
      for (int g : tf->second) {
        const Frame& fr = frames_[g];
        if (!fr.posed) continue;
        const int i = fr.Find(id);
        Eigen::Vector2d uv;
        if (i < 0 || fr.outlier[i] || !ProjectIdeal(camera_, fr.world_from_camera.inverse() * p.x, &uv)) continue;
        sum += (uv - fr.pixels[i]).squaredNorm();
        ++n;
      }
    }
    n += p.dropped_observations;
    sum += p.dropped_sq_error;
    l.num_observations = n;
    l.reprojection_rms_px = n > 0 ? std::sqrt(sum / n) : 0.0;
    out.push_back(l);
  }
  return out;
}

}  // namespace objscan

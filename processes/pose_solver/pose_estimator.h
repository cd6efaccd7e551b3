// PoseEstimator: incremental structure from motion for one camera on the robot, LCM-free.
//
// Phases
//  1. Preliminary (status INITIALIZING): frames are buffered until SelectStartSpan (factorization.h) finds a span
//     with enough common tracks and rotation (with odometry: only frames after the base last stood or turned in
//     place, below kStillBaseSpeedMmS, and with at least min_span_baseline_mm of camera travel: a span turned in
//     place has no depth, its factorization no parallax about the scene, its odometry scale is noise); Tomasi–Kanade weak-perspective factorization of the span gives the
//     rotations and shape, both depth-reversal candidates are upgraded to perspective and bundle-adjusted, the better
//     one is kept. Metric scale and world frame:
//       kSixDof:  world_from_camera of the span's first frame = the odometry's WorldFromCamera at that frame; scale =
//                 if a floor plane is seen among the span's landmarks (use_floor_for_scale), the camera height above
//                 it (SCALE_CAMERA_HEIGHT), else the median over the span's steps of odometry / visual step length
//                 (SCALE_ODOMETRY; the median ignores steps spoilt by an odometry time-stamping offset). Refined at
//                 keyframes during the first online_scale_frames frames and at Finish(): by the camera height above
//                 the floor plane when one is seen, else by the odometry path length (refine_scale_with_odometry).
//     When it succeeds, the earlier frames of the window (the span, and frames before it that PnP against the new
//     map accepts) are returned in FrameResult::late_poses so that every frame gets a published pose.
//       kFourDof: world = odometry frame; if a floor plane is seen among the landmarks (>= min_floor_points within
//                 floor_tolerance_mm, normal within 20 deg of vertical), the map is levelled onto it (floor z = 0) and
//                 scaled so that the cameras sit at the robot model's height (SCALE_CAMERA_HEIGHT); floor landmarks
//                 are then held at z = 0 in every adjustment, which keeps the scale. Otherwise SCALE_ODOMETRY.
//       Without odometry: world = first camera of the span at an arbitrary scale (SCALE_NONE).
//  2. Sequential (status TRACKING): per frame PnP (pnp.h) against the landmarks whose track ids are in the frame;
//     keyframe when keyframe_interval frames passed or the tracked landmarks fell below keyframe_track_ratio of the
//     last keyframe's; at a keyframe: new landmarks by multi-view triangulation (motion stereo over the posed frames
//     that saw the track), windowed BA over the last local_window_keyframes keyframes (other keyframes seeing those
//     points held fixed), landmarks with large reprojection error removed.
//     Wide-baseline option (two_view_min_matches > 0, 6-DOF): a frame that PnP cannot pose (short tracks see few
//     landmarks) is posed from the essential matrix of the tracks it shares with the last posed frame, the step's
//     scale from the landmarks it sees; the keyframe rules then apply as after PnP. Off by default.
//  3. Lost: fewer than min_inliers PnP inliers -> the frame is reported with status LOST, num_inliers 0 and the LAST
//     GOOD pose (not a made-up one: consumers must ignore the pose of LOST frames). Every later frame tries PnP against
//     all landmarks, then relocalization by position (RelocalizeByProjection: KLT ids do not reappear, so new tracks
//     are paired with the landmarks projected from the last pose moved by the odometry). After
//     relocalize_after_lost_frames lost frames the preliminary phase restarts, and until its new map starts (at most
//     15 s) each frame still tries relocalization by position, which drops the restart when it succeeds; the new map is chained to the old one through the odometry motion between the
//     last good frame and the new span, then joined to it by the landmarks both saw (KLT ids do not reappear, so by
//     position), after the new span's BA in the final camera model: the offset most new-old landmark pairs within
//     join_search_mm agree on, then the least-squares Sim(3) (kFourDof: x, y and yaw only, the robot model fixes
//     the rest) of the nearest pairs, the radius shrinking to join_max_mm, applied to the new map. The join needs
//     join_min_landmarks pairs and three times the pairs the same transform finds 6 mm off (chance), else the
//     odometry chaining stands. The joined span's landmarks are then fused onto the old map's (below), so the
//     adjustments tie the two maps together. The first pose after recovery has status RELOCALIZED.
//     Fusion (FuseLandmarks): a new landmark becomes an older one when its track was never seen with the old one's
//     in a frame that still holds observations, they lie within fuse_search_mm, the track's first and last held
//     (posed, inlier) views see it fuse_min_parallax_deg apart, and the old landmark reprojects within fuse_max_px
//     in every such view; later frames of the track observe the old landmark. Only a join's new landmarks are tried,
//     and only against landmarks last seen before the joined span (fusing every new landmark with every older one,
//     as a loop closure, was measured worse: docs/benchmarks.md).
//  4. Finish(): frames never posed get PnP against the final map, then global BA over the active (not frozen)
//     keyframes (or all posed frames) and landmarks (observations beyond the PnP inlier threshold left out; with
//     frozen keyframes the two oldest active ones are held), pose refits of the other frames that still have
//     observations, the compacted ones follow their keyframes; a BA that bends a map (kMaxFinalBendFraction) is
//     dropped for the windowed adjustments' poses; scale refinement (kSixDof), final poses for every frame.
// Pixels are corrected for distortion on input. Deterministic (seeded RANSAC, single-threaded Ceres).
// Memory: every frame keeps its pose (~0.3 kB); observations (~25 bytes per track) are kept for the last
// max_active_keyframes keyframes, unposed frames and the last observations_kept_frames frames only (set both to 0 to
// keep all for the final adjustment), so memory per frame is flat once a stream has more keyframes than that (long
// lost stretches keep theirs until Finish). Landmarks() counts (num_observations, RMS) include the dropped
// observations, with their reprojection error as it was when they were dropped.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <map>
#include <functional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "common/camera_model.h"
#include "common/floor_fit.h"
#include "common/robot_model.h"
#include "common/sensor_data.h"
#include "processes/pose_solver/bundle_adjustment.h"
#include "processes/pose_solver/factorization.h"
#include "processes/pose_solver/pnp.h"
#include "processes/pose_solver/triangulation.h"

namespace objscan {

struct PoseEstimatorOptions {
  MotionModel model = MotionModel::kSixDof;    // camera model of all adjustments
  RobotGeometry robot;                         // mast height and offsets (4-DOF model, odometry poses)
  StartSpanOptions start_span;                 // choice of the preliminary span
  double min_span_baseline_mm = 50;            // mm, camera travel (odometry) a span with odometry needs (>= 0)
  PnpOptions pnp;                              // per-frame PnP (model is overridden by `model`)
  TriangulationOptions triangulation;          // acceptance of new landmarks
  int min_triangulation_views = 3;             // posed views a track needs before it is triangulated
  int max_triangulation_views = 8;             // views used (evenly spread over the track)
  int keyframe_interval = 5;                   // frames: at most this many frames between keyframes
  double keyframe_track_ratio = 0.7;           // keyframe when tracked landmarks < ratio x those of the last keyframe
  int local_window_keyframes = 5;              // keyframes optimized by the windowed BA
  int local_ba_iterations = 5;                 // Ceres iterations of the windowed BA
  int local_fixed_keyframes = 4;               // older keyframes (nearest first) held fixed in the windowed BA
  bool global_ba_all_frames = false;           // final BA over every frame (slow) instead of keyframes + pose refits
                                               // (needs observations_kept_frames = 0)
  int observations_kept_frames = 30;           // frames: a posed non-keyframe drops its observations once it is
                                               // this many frames old (memory then grows with the keyframes only;
                                               // its final pose follows its neighbouring keyframes' final-BA
                                               // correction instead of a pose refit); 0 = keep every frame's
                                               // observations until Finish (memory ~40 kB per frame)
  int max_active_keyframes = 60;               // keyframes that keep their observations; beyond it the oldest is
                                               // frozen (observations dropped, pose and landmarks as the windowed
                                               // BA left them), so memory stops growing on long streams, and the
                                               // final BA adjusts the active keyframes with the two oldest held
                                               // fixed; 0 = no limit (needs observations_kept_frames > 0 too)
  int global_ba_iterations = 40;               // Ceres iterations of the final BA
  double global_ba_function_tolerance = 1e-5;  // final BA stops when a step changes the cost by less than this
                                               // fraction (the Huber loss' IRLS tail creeps at ~1e-6 per step)
  int init_ba_iterations = 50;                 // Ceres iterations of the span BA
  std::string ba_loss = "huber";               // robust loss: "huber" or "cauchy"
  double ba_loss_px = 1.0;                     // px, robust loss scale
  double max_landmark_error_px = 2.5;          // px, landmarks with a larger RMS after BA are removed
  bool use_floor_for_scale = true;             // level on (4dof) / scale from (both) the floor plane when it is seen
  bool camera_height_known = true;             // robot's camera height is the real one (a robot); false (an image
                                               // folder): without odometry the floor only levels the world (floor
                                               // z = 0, +z up) and the scale stays arbitrary
  double floor_tolerance_mm = 6.0;             // mm, plane inlier distance / floor landmark |z|
  int min_floor_points = 20;                   // landmarks needed to accept a floor plane
  bool refine_scale_with_odometry = true;      // kSixDof: rescale at Finish() by odometry / visual path length
  int online_scale_frames = 100;               // kSixDof: at keyframes within this many frames of the map start,
                                               // rescale the map by odometry / visual path length (0 = off)
  int relocalize_after_lost_frames = 10;       // lost frames before the preliminary phase restarts
  double relocalize_search_px = 40.0;          // px: a lost frame (and, for 15 s, each frame of a restart still
                                               // without a map) is relocalized by position: new tracks paired with
                                               // landmarks projected from the last pose moved by the odometry,
                                               // searching a shift up to this (RelocalizeByProjection); 0 = off
  double fuse_search_mm = 5.0;                 // mm, largest distance between the new and the old landmark
  double fuse_min_parallax_deg = 10.0;         // deg, the new track's first and last held view must see it
                                               // this far apart before it is fused (until then it is retried at
                                               // keyframes while the track lives)
  double fuse_max_px = 1.5;                    // px, the old landmark's largest reprojection error over the new
                                               // track's views
  double join_search_mm = 50.0;                // mm: after a restart, old landmarks this close to new ones (after
                                               // the odometry chaining) are candidates for joining the maps by
                                               // Sim(3); 0 = odometry chaining only
  double join_max_mm = 1.5;                    // mm, final pair distance of the join, (0, 2.5] (the rounds before
                                               // use 8, 4 and 2.5 mm; join_search_mm must be 0 or >= 8)
  int join_min_landmarks = 15;                 // common landmarks needed to join (else odometry chaining is kept)
  int two_view_min_matches = 0;                // wide baseline (short tracks): when PnP fails, pose the frame from
                                               // the essential matrix of its tracks shared with the last posed frame
                                               // if at least this many are E-RANSAC inliers, scale from the landmarks
                                               // it sees; 0 = off (the frame is lost)
  int two_view_min_landmarks = 3;              // landmarks the frame must see (consistent with the two-view pose
                                               // within pnp.inlier_threshold_px) to fix that step's scale (>= 2)
  int64_t seed = 1;                            // RANSAC seeds (seed + frame index)
};
bool ValidatePoseEstimatorOptions(const PoseEstimatorOptions& options, std::string* why);

// The preliminary-phase reconstruction of a span: weak-perspective factorization of meas[frame][point] (every point
// in every frame, undistorted px), perspective upgrade of both depth-reversal candidates (depth 1000 units, scale
// arbitrary), 6-DOF BA of each (frame 0 fixed, baseline 0..last held; a candidate whose RMS after 10 iterations is
// above 1.5x the other's after all of them + 0.05 px is not adjusted further), the candidate with the lower RMS
// returned in *out (world = the factorization's model frame) with its RMS in *rms_px. With `acceptable`, only candidates it
// accepts count (on a short span both fit the pixels alike; the odometry tells them apart: SpanMotionAgreesWith-
// Odometry); its reason for the last refusal becomes *why. False with *why on failure.
using SpanCheck = std::function<bool(const BaProblem& candidate, std::string* why)>;
bool ReconstructSpan(const PinholeCamera& camera, const std::vector<std::vector<Eigen::Vector2d>>& meas,
                     const BaOptions& ba_options, BaProblem* out, double* rms_px, std::string* why = nullptr,
                     const SpanCheck& acceptable = {});

struct Landmark {
  int64_t id = 0;                                         // track id
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // world
  int num_observations = 0;                               // posed frames that observe it
  double reprojection_rms_px = 0;                         // RMS over those
  bool on_floor = false;                                  // held at z = 0 (kFourDof floor mode)
};

// Odometry readings, interpolated at frame times (linear in x, y, theta (unwrapped), pan, tilt; clamped at the ends).
class OdometryBuffer {
 public:
  explicit OdometryBuffer(size_t capacity = 4096) : capacity_(capacity) {}
  // Readings older than the newest are ignored (returns false).
  bool Add(const OdometryReading& reading);
  // False when empty or utime is more than max_gap_us outside the buffered range.
  bool At(int64_t utime, OdometryReading* out, int64_t max_gap_us = 500000) const;
  bool empty() const { return readings_.empty(); }

 private:
  size_t capacity_;
  std::deque<OdometryReading> readings_;
};

struct FrameResult {
  CameraPoseEstimate pose;       // the pose to publish for this frame now
  bool keyframe = false;         // a keyframe was added (publish landmarks)
  bool initialized_now = false;  // the preliminary phase finished with this frame
  // With initialized_now: poses of the EARLIER frames of the preliminary window that the new map registered (the
  // span and the frames before it that PnP against the map accepts), in frame order, to publish now (their first
  // publication said INITIALIZING or LOST).
  std::vector<CameraPoseEstimate> late_poses;
};

// How far a map was bent between two estimates of its camera centres (same frames, same order, any unit): the 90th
// percentile of the distances of `after` from the similarity of `before` that fits it best (AlignSimilarity), divided
// by the RMS spread of `after` about its mean. 0 for a map moved, turned and scaled as a whole; -1 with fewer than 10
// centres, no spread, or centres on a line (no similarity fits: AlignUmeyama).
double MapBendFraction(const std::vector<Eigen::Vector3d>& before, const std::vector<Eigen::Vector3d>& after);

// Finish() drops a global BA (with frozen keyframes) that bends a map by more than this fraction of its camera spread
// (1.7 mm in a room run's 1.7 m). 17 single-map room runs (final against online poses): 0.006-0.022 %; room_07
// (7 Dec): 0.47 %, the orbit bent 12 mm and the last 50 frames sent 565 mm away (online poses 1.5 mm RMS from the
// truth over the modeling frames, final 47 mm; not reproduced since). Blind to a bend of under a tenth of the frames
// (a percentile, as the legitimate refinement moves a few frames far: p99 up to 0.29 %).
constexpr double kMaxFinalBendFraction = 1e-3;

class PoseEstimator {
 public:
  // camera must be valid (PinholeCamera::IsValid); options validated (throws std::invalid_argument otherwise).
  PoseEstimator(const PinholeCamera& camera, const PoseEstimatorOptions& options);

  // Processes the next frame (seq must increase; the caller rejects others). odometry: reading at the frame time
  // or null. Returns the pose to publish for it.
  FrameResult AddFrame(const TrackFrame& frame, const OdometryReading* odometry);

  // End of stream: registers unposed frames, global BA, scale refinement. Returns one pose per frame added (in
  // order); frames that could not be posed keep status LOST (or INITIALIZING when no map was ever built).
  std::vector<CameraPoseEstimate> Finish();

  // current_map_only: while the newest map is a restart not joined to the old one (JoinToOldMap, TryLateJoin), only
  // its own landmarks: the old ones lie in another frame, and a consumer that takes both together with the current
  // poses sees double walls and phantom obstacles (room_08: 25 k of 39 k obstacle points more than 150 mm from any
  // solid after an unjoined restart, the planner boxed in).
  std::vector<Landmark> Landmarks(bool current_map_only = false) const;
  // Track ids re-associated with an older landmark (a map join's fusion), as (track id, landmark id) in the order of
  // fusion: the track's observations belong to that landmark (Landmarks() lists it under the landmark id only).
  const std::vector<std::pair<int64_t, int64_t>>& FusedTrackIds() const { return fused_tracks_; }
  // Frame seqs where a restarted map began that was never joined to the map before it (a later restart or the end
  // came first): poses on the two sides are related by the odometry only, centimetres apart after long runs, so a
  // model built from views on both sides mixes two frames. In order; the current map's start included while it is
  // unjoined.
  std::vector<int64_t> UnjoinedRestartSeqs() const;
  int num_fused() const { return static_cast<int>(fused_tracks_.size()); }
  ScaleSource scale_source() const { return scale_source_; }
  int span_first_frame() const { return span_first_; }  // index of the last preliminary span's first frame (-1: none)
  bool initialized() const { return map_initialized_; }
  int num_frames() const { return static_cast<int>(frames_.size()); }
  int num_keyframes() const;
  // Approximate heap bytes held by the estimator's frames, observations and map (container payloads plus a fixed
  // per-node allowance for the hash/tree maps), for status and memory benchmarks.
  size_t ApproxMemoryBytes() const;
  // Timing figures (CPU time of the calling thread, ms) for benchmarks.
  double init_ms() const { return init_ms_; }
  double final_ba_ms() const { return final_ba_ms_; }
  // Finish()'s check of the global BA (with frozen keyframes, a light refinement of the windowed adjustments: its
  // poses move a median 0.03-0.3 mm from the online ones in 16 room runs): the largest MapBendFraction over the maps
  // (-1 before Finish, when not checked, when the BA failed, or when no map could be measured), and whether the BA
  // was dropped for bending a map.
  double final_bend_fraction() const { return final_bend_fraction_; }
  bool final_ba_dropped() const { return final_ba_dropped_; }
  const std::string& last_message() const { return last_message_; }
  // While there is no map (start, or after a loss): why the latest attempt did not start one; "" once tracking.
  const std::string& init_wait_reason() const { return init_wait_reason_; }
  bool has_map() const { return phase_ != Phase::kInitializing; }
  // A message about an event after initialization (e.g. a restarted map scaled by the floor later), once; else "".
  std::string TakeNotice() { return std::exchange(notice_, std::string()); }
  // Accumulated thread CPU ms of the sequential steps (benchmarks): PnP, triangulation, windowed BA.
  double pnp_ms_total() const { return pnp_ms_; }
  double triangulation_ms_total() const { return tri_ms_; }
  double local_ba_ms_total() const { return lba_ms_; }
  // Relocalization by position: attempts, successes and their accumulated thread CPU ms.
  int relocalization_attempts() const { return reloc_attempts_; }
  int relocalizations() const { return reloc_successes_; }
  double relocalization_ms_total() const { return reloc_ms_; }

 private:
  struct Frame {
    int64_t utime = 0, seq = 0;
    std::vector<int64_t> ids;             // sorted
    std::vector<Eigen::Vector2d> pixels;  // undistorted, same order
    std::vector<uint8_t> outlier;         // PnP outlier flag per feature
    bool has_odometry = false;
    Eigen::Isometry3d odometry_world_from_camera = Eigen::Isometry3d::Identity();
    Eigen::Vector2d odometry_base_mm = Eigen::Vector2d::Zero();  // mm, base position by the odometry
    bool posed = false;
    int64_t map_start_seq = -1;  // the map it was posed in (CameraPoseEstimate::map_start_seq), -1 while unposed
    bool keyframe = false;
    bool compacted = false;  // observations dropped (see observations_kept_frames)
    bool frozen = false;     // a keyframe whose observations were dropped (max_active_keyframes)
    Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
    PoseStatus status = PoseStatus::kInitializing;
    int inliers = 0;
    double rms = 0;
    int Find(int64_t id) const;  // index of id or -1
  };
  struct Point {
    Eigen::Vector3d x;
    bool on_floor = false;
    int dropped_observations = 0;  // inlier observations of frames that dropped theirs (counted in Landmarks())
    double dropped_sq_error = 0;   // px^2, their summed squared reprojection error when they were dropped
  };
  struct Alias {
    int64_t landmark = 0;  // landmark id the track's observations go to
    int last_frame = 0;    // last frame that carried the track
  };
  enum class Phase { kInitializing, kTracking, kLost };

  bool TryInitialize(int newest);
  // The preliminary phase on frames first..last and their common tracks: reconstruction, commit, the metric frame
  // from the odometry and the floor, then (after a loss) the join to the old map. False with last_message_.
  bool InitializeSpan(int first, int last, const std::vector<int64_t>& common);
  // Factorization + BA of the span's common tracks (both depth-reversal candidates, the odometry's veto); false with
  // last_message_ when none succeeds or the RMS is over twice max_landmark_error_px.
  bool ReconstructSpanFromTracks(int first, int last, const std::vector<int64_t>& common, BaProblem* best,
                                 double* best_rms);
  // Poses the span's frames (keyframes every keyframe_interval and the last), adds the common tracks' points and
  // triangulates the rest of frame last's tracks; returns the new landmarks' ids (common ones sorted first).
  std::vector<int64_t> CommitSpan(int first, int last, const std::vector<int64_t>& common, const BaProblem& best);
  struct SpanPlacement {
    Eigen::Isometry3d anchor = Eigen::Isometry3d::Identity();  // desired world_from_camera of the span's first frame
    bool have_anchor = false;                                   // from the odometry (chained after a loss)
    ScaleSource scale_source_before = ScaleSource::kNone;       // the map's before the span (a join restores it)
  };
  // Scales the new span by the odometry's step lengths and places frame first at the anchor.
  SpanPlacement PlaceSpanByOdometry(int first, int last, const std::vector<int64_t>& new_points);
  // 6-DOF: rescale to the camera height above a floor seen in the span (else retried at keyframes after a loss);
  // 4-DOF: level on the floor, scale to the model height, re-anchor in the floor plane at the anchor, or lift to the
  // model height.
  void LevelAndScaleSpanByFloor(int first, int last, const std::vector<int64_t>& new_points,
                                const SpanPlacement& placement);
  bool Track(int f, FrameResult* result);
  // PnP (RANSAC + refinement from prior, may be null) of frame f against the current landmarks; on success f is
  // posed with its inlier count, RMS and outlier flags set (status untouched). False with *why (frame untouched).
  bool PoseFromMap(int f, const Eigen::Isometry3d* prior, std::string* why);
  void AddKeyframe(int f);
  // Triangulates the tracks of frame f that have no landmark yet; their ids are appended to *added if not null.
  int TriangulateNew(int f, std::vector<int64_t>* added = nullptr);
  // Re-associates the new landmarks `candidates` (tracked in frame f) with older ones (see the top: only with
  // landmarks last seen before the joined span); candidates still short of parallax whose track lives go to
  // fuse_pending_. Returns the number fused.
  int FuseLandmarks(int f, const std::vector<int64_t>& candidates);
  // After a restart: joins the new map (frames first..last, points new_points, chained through odometry) to the old
  // landmarks by the Sim(3) (kFourDof: x, y, yaw) of the landmarks both saw (see the top); false (nothing moved,
  // with *message) when too few pairs agree or they are degenerate.
  bool JoinToOldMap(int first, int last, const std::vector<int64_t>& new_points, int* num_pairs, std::string* message);
  // At keyframe f: JoinToOldMap for the pending unjoined map (unjoined_first_..f) once it grew; on success its
  // landmarks are fused and notice_ says so.
  void TryLateJoin(int f, const std::vector<int64_t>& added);
  // Moves every held observation of landmark `from` to landmark `to`, removes `from` and aliases its track (frame f
  // is the last that carried it).
  void MergeLandmark(int64_t from, int64_t to, int f);
  void LocalBundleAdjustment(int f);
  // Sets frame->inliers and frame->rms (px) from its observations of the current points (pose solver inlier threshold).
  void UpdateFrameStatistics(Frame* frame) const;
  // Drops the observations of frame f when it is posed, not a keyframe nor a gauge frame (see
  // observations_kept_frames).
  // First refits its pose against the current map (RefitPose).
  void CompactFrame(int f);
  // Drops the observations of keyframe f (not a gauge frame) and marks it frozen; its pose no longer changes.
  void FreezeKeyframe(int f);
  // Compacts the posed frames at least observations_kept_frames older than newest (each once).
  void CompactOldFrames(int newest);
  // Records keyframe f as active (max_active_keyframes > 0) and freezes the oldest beyond the limit.
  void NoteActiveKeyframe(int f);
  // Removes frame f's observations (and f from track_frames_).
  void DropObservations(int f);
  // Pose-only refinement of posed frame f against the current landmarks (its PnP inliers); unchanged when it sees
  // fewer than pnp.min_inliers of them.
  void RefitPose(int f);
  // Poses of compacted frames after the keyframes moved from old_world_from_camera (indexed like frames_; only
  // keyframes are read) to their current poses: each compacted frame keeps its pose relative to the keyframes before
  // and after it, interpolated between the two by frame index.
  void FollowKeyframes(const std::vector<Eigen::Isometry3d>& old_world_from_camera);
  // True when the adjustment converged and was applied.
  bool GlobalBundleAdjustment();
  // Finish()'s global BA, dropped (the poses and landmarks before it restored) when it bends a map by more than
  // kMaxFinalBendFraction; sets final_bend_fraction_, final_ba_dropped_ and last_message_.
  void GlobalBundleAdjustmentKeepingShape();
  // PnP of frame f against the current landmarks from a nearby pose; on success f is posed (status TRACKING) with
  // its outlier flags set. False (frame untouched) otherwise.
  bool RegisterAgainstMap(int f, const Eigen::Isometry3d& prior);
  // Relocalization by position (KLT ids never come back: a corner found again after the head or the base turned away
  // and back is a new track). Projects the landmarks into frame f from `predicted`, finds the image shift most
  // track/landmark pairs within relocalize_search_px agree on (the prediction's error is mostly a shift), pairs each track
  // without a landmark with the landmark nearest its shifted projection (within kRelocMatchPx, the second nearest at
  // least twice as far, each landmark once), runs PnP over the pairs, then pairs again from that pose and runs PnP
  // once more. Success needs kRelocMinInliers inliers and half of the pairs: the inlier tracks observe their
  // landmarks from then on (MergeLandmark) and f is posed (status untouched). False with *why (frame untouched).
  bool RelocalizeByProjection(int f, const Eigen::Isometry3d& predicted, std::string* why);
  // Pairs (feature index in f, landmark id) of the features `tracks` of frame f and the landmarks `landmark_ids`
  // projected from `from`, the shift searched within search_px (see RelocalizeByProjection).
  void PairByProjection(int f, const std::vector<int>& tracks, const std::vector<int64_t>& landmark_ids,
                        const Eigen::Isometry3d& from, double search_px,
                        std::vector<std::pair<int, int64_t>>* pairs) const;
  // PnP of frame f over `pairs` from `prior`: kRelocMinInliers inliers and half of the pairs, else false.
  bool PoseFromPairs(int f, const std::vector<std::pair<int, int64_t>>& pairs, const Eigen::Isometry3d& prior,
                     PnpResult* result) const;
  // The two rounds of pairing and PnP of RelocalizeByProjection: on success the inlier (track id, landmark id) pairs
  // and f's pose against those landmarks; nothing is changed.
  bool MatchByProjection(int f, const std::vector<int>& tracks, const std::vector<int64_t>& landmark_ids,
                         const Eigen::Isometry3d& predicted, std::vector<std::pair<int64_t, int64_t>>* merges,
                         Eigen::Isometry3d* pose, std::string* why) const;
  bool RelocalizeByProjectionTimed(int f, const Eigen::Isometry3d& predicted, std::string* why);  // counts, CPU time
  // After a restart whose 3-D join failed: the tracks of the span's last frame (with or without a landmark of the
  // new map) paired by position with the old map's landmarks projected from its pose (chained through the odometry);
  // when PnP holds, the new map (frames first..last, points new_points) moves rigidly (kFourDof: x, y, yaw) so that
  // frame `last` takes its pose against the old map, and the paired tracks observe the old landmarks. False
  // (nothing changed, *message extended with why) otherwise.
  bool JoinByProjection(int first, int last, const std::vector<int64_t>& new_points, std::string* message);
  // Frame f's pose predicted from the last good frame: moved by the odometry between the two when both have it,
  // else the last good pose itself. Needs last_good_ >= 0.
  Eigen::Isometry3d PredictFromLastGood(int f) const;
  // two_view_min_matches > 0: poses frame f relative to the last good frame from the essential matrix of their common
  // tracks, with the step's scale from the landmarks f sees (see the option). False (frame untouched) otherwise.
  bool TwoViewPose(int f);
  // kSixDof with odometry scale: rescales everything about the gauge camera so that the visual path length from
  // first_frame on matches the odometry's. Returns the factor applied (1 when not possible).
  double RescaleToOdometryPath(int first_frame);
  // Rescales frames first_frame..last_frame and the points point_ids about the centre of pivot_frame so that the
  // cameras' mean height above the floor plane found among those points equals the robot model's for their tilt
  // relative to the plane; sets SCALE_CAMERA_HEIGHT. Returns false (nothing changed) when no floor is found.
  // max_factor > 0: a scale change beyond [1 / max_factor, max_factor] is not applied (false, *applied_scale set);
  // min_change > 0: nor one within [1 - min_change, 1 + min_change].
  bool RescaleToFloorHeight(int first_frame, int last_frame, const std::vector<int64_t>& point_ids, int pivot_frame,
                            double* applied_scale = nullptr, double max_factor = 0, double min_change = 0);
  // While a restarted map is not joined (at TryLateJoin's tries): its scale measured again from the camera height
  // above the floor among all its landmarks, applied when more than 2 % off (room_02, 7 Dec: a restart scaled 11 %
  // wrong at its start from a short span's floor; the 3-D join then never matched, the planner's estimate and
  // odometry disagreed by 660 mm, the orbit stalled).
  void RecheckUnjoinedScale(int f);
  // Median over consecutive posed frames with odometry in [first_frame, last_frame] of odometry / visual step
  // length. False when no step qualifies.
  bool OdometryStepScale(int first_frame, int last_frame, double* scale) const;
  void RescaleSixDof(int first_frame);
  void PruneLandmarks(const std::vector<int64_t>& ids, const std::vector<int>& frames);
  // The pose solver's floor policy among the candidates' landmarks: the plane with the most landmarks within
  // floor_tolerance_mm and at most 5 % of them more than 3 tolerances beneath it (a table or an object's top has the
  // floor below it). Up = world +z (max tilt 20 deg) with odometry, else the posed cameras' mean image-up (70 deg).
  // RANSAC (common/floor_fit.h MostSupportedPlane: 300 samples, mt19937-uniform sequence, seed options_.seed), inlier_ids = the winning
  // hypothesis's inliers, *plane its total-least-squares refit (mm, world; Height = normal.x + offset_mm, normal on
  // up's side). False (outputs unspecified) with fewer than min_floor_points inliers. Deterministic.
  bool DetectFloor(const std::vector<int64_t>& candidates, std::vector<int64_t>* inlier_ids, FloorPlane* plane) const;
  void ApplySimilarity(double scale, const Eigen::Isometry3d& world_new_from_old, int first_frame, int last_frame,
                       const std::vector<int64_t>& point_ids);
  CameraPoseEstimate Estimate(int f) const;
  BaOptions MakeBaOptions(int iterations) const;

  PinholeCamera camera_;
  PoseEstimatorOptions options_;
  std::vector<Frame> frames_;
  std::map<int64_t, Point> points_;
  std::unordered_map<int64_t, std::vector<int>> track_frames_;  // track id -> frames that saw it
  std::unordered_map<int64_t, Alias> alias_;                    // live fused tracks (input id -> landmark)
  std::vector<std::pair<int64_t, int64_t>> fused_tracks_;       // every fusion (track id, landmark id)
  std::vector<int64_t> fuse_pending_;  // new landmarks whose tracks lack the parallax to be fused yet
  int join_first_frame_ = 0;           // first frame of the last joined map (fusion targets are landmarks last seen
                                       // before it)
  // A restarted map not joined at its start (too few landmarks in common yet: room_07's restarts shared 5-10) is
  // tried again at its keyframes while it grows (TryLateJoin): its first frame (-1: every map joined), its landmarks
  // (Landmarks(true)), and their count and frame at the last try (a new try once it grew by half, or grew at all
  // 300 frames later, for the whole run).
  int unjoined_first_ = -1;
  std::vector<int64_t> unjoined_restart_seqs_;  // earlier maps never joined (UnjoinedRestartSeqs)
  // The map frames are posed in now, as the seq where it began (the stream's first frame for the first map, a
  // restart's span start while it is not joined), and the one before an unjoined restart (a late join returns to
  // it). Each frame keeps the map it was posed in (Frame::map_start_seq); a late join relabels the restart's frames.
  int64_t current_map_start_ = -1;
  int64_t map_before_restart_ = -1;
  std::vector<int64_t> unjoined_points_;
  size_t unjoined_tried_size_ = 0;
  int unjoined_tried_frame_ = 0;
  Phase phase_ = Phase::kInitializing;
  bool map_initialized_ = false;
  int init_start_ = 0;      // first frame considered by the (re)initialization
  int span_first_ = -1;     // first frame of the last preliminary span
  int gauge_frame_ = -1;    // first frame of the first map (fixed in BA)
  int gauge_frame_b_ = -1;  // second frame of the 6-DOF scale gauge
  int last_good_ = -1;      // last frame with a tracked pose
  int last_keyframe_ = -1;
  int last_keyframe_inliers_ = 0;
  int lost_count_ = 0;
  bool recovering_ = false;           // a restart after loss is in progress (chain through odometry)
  std::deque<int> active_keyframes_;  // keyframes with observations, oldest first (max_active_keyframes > 0)
  bool any_frozen_ = false;           // a keyframe was frozen
  int compaction_cursor_ = 0;         // frames below this were queued for compaction
  std::vector<int> old_uncompacted_;  // queued frames still unposed (compacted once posed)
  ScaleSource scale_source_ = ScaleSource::kNone;
  double init_ms_ = 0, final_ba_ms_ = 0;
  double final_bend_fraction_ = -1;
  bool final_ba_dropped_ = false;
  double pnp_ms_ = 0, tri_ms_ = 0, lba_ms_ = 0, reloc_ms_ = 0;
  int reloc_attempts_ = 0, reloc_successes_ = 0;
  std::string last_message_;
  std::string notice_;  // a later event worth a log line (TakeNotice)
  std::string init_wait_reason_;  // why the latest preliminary-phase attempt did not start a map
  // After a span refused for disagreeing with the odometry (each try reconstructs the whole span: ~1-2 s at 30+
  // frames; room_07 fell 60 frames behind trying every frame), the next try waits until this frame.
  int init_retry_frame_ = -1;
  bool span_refused_by_odometry_ = false;  // the last InitializeSpan failed because no candidate agreed with it
  // kSixDof: a map restarted through odometry whose span showed no floor keeps the odometry's scale over a few
  // frames (room_05's closed loop: ~20 % off, the new floor 75 mm above the old one, the planner's map full of
  // phantom obstacles). Its first frame and landmarks, while the floor is looked for again at its keyframes.
  int segment_floor_first_ = -1;
  std::vector<int64_t> segment_floor_points_;
};

}  // namespace objscan

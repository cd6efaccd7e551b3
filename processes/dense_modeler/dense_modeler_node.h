// DenseModelerNode: the "dense_modeler" process.
// Inputs: CAMERA_IMAGE (image_t), CAMERA_INFO (camera_info_t, needed before frames can be used), FEATURE_TRACKS
// (feature_tracks_t), CAMERA_POSE (pose_t world_from_camera, mm), CAMERA_POSE_FINAL (pose_t after the pose solver's
// final adjustment), TARGET (target_t; a confirmed box restricts the model), LANDMARKS (landmarks_t, for the
// automatic region of interest and the floor), OBJSCAN_CONTROL (control_t).
// Region of interest (region_of_interest.h): the confirmed TARGET box (+ target_margin) if any, else the box of
// --roi-box if set, else (auto_roi) the region derived from the latest LANDMARKS and the tracks seen in the central
// window of the posed frames. The floor plane found among the landmarks (roi.detect_floor) cuts every source.
// Dense pairs (pixels, triangles, points) and the final seeds are restricted to the region; it is recomputed when
// landmarks or central tracks changed, before each pair and at the final phase (with the final landmarks). While a
// region can still come (auto_roi with a landmarks channel, or a target box to be confirmed) and none is known, pairs
// wait for it (without the region a pair votes the whole scene: the sim sphere's first pair gave 125 k points, 84 %
// of them floor, against ~17 k for the others), in order, and run once it is
// known - or unrestricted when the older frame would leave the ring buffer, or at the final phase. Frames (image +
// tracks + pose, matched by seq) live in a bounded ring buffer of buffer_frames entries. Frame j with j % pair_every
// == 0 is paired with frame j - pair_gap once both are complete with a usable pose (tracking, relocalized or ground
// truth), in whichever order they complete: dense points (affine_dense.h) from the tracks both frames share, plus the
// pair's own LK matches where the tracker left the region bare (pair_matches.h, model.pair_matches), are voted into the
// voxel grid (voxel_votes.h). Every complete frame also keeps a downsampled copy for the final carving (at most
// max_carving_views; when full, every second one is dropped, deterministic). Outputs: VOXEL_MAP every voxel_map_every
// pairs (voxels over the threshold, at most max_map_voxels, strongest first, truncated flag), and at the end the final
// VOXEL_MAP (is_final), MODEL and control_t COMMAND_FINISHED. Final phase: on control_t COMMAND_FINISHED from
// finish_sender (or COMMAND_FINALIZE aimed at this process): with revote_final_poses and a final_pose_channel, every
// pair's pixel matches (kept, 20 bytes each, up to max_stored_matches) are triangulated again with the final poses
// where both frames have one (else with the live poses) and the geometric checks, the final region included, and voted
// into a fresh grid (final poses in two or more maps never joined, pose_t.map_start_seq: only the pairs of the map
// with the most matches, and only its views carve; map_consistency.h ChooseModelMap), which replaces the live one unless no pair had final poses or it holds under half the live votes
// (then a warning; the live grid stays); seeds = voxels over the threshold (inside the target box when known), space
// carving with the stored views in the poses the votes were cast with (final when the re-vote ran, else live), marching
// tetrahedra mesh, files written to
// output_dir (when set). COMMAND_SNAPSHOT writes the vote grid (after the final phase: the re-voted one) to
// control_t.argument (or output_dir/votes_snapshot.bin); OnShutdown saves output_dir/votes_snapshot.bin when output_dir
// is set. Rejections (counted, the node keeps running): "image: malformed", "image: out of order or repeated", "image:
// implausible seq jump" (common/status.h; only usable images move the stream's sequence on), adapter reasons for images/camera info/tracks/poses, "image: no
// camera_info yet", "image: wrong size" (differs from camera_info), "image: older than the ring buffer", "tracks:
// malformed", "tracks: older than the ring buffer" (the buffer is full of newer frames), "pose: malformed",
// "pose: unknown frame" (no image for that seq in the buffer), "pose: not tracking" (initializing or lost), the same
// for final poses prefixed "final ", "frame: evicted without pose", "pair: frame gone" (a waiting pair whose frame
// left the buffer), "target: malformed", "target: empty box", "landmarks: malformed", "landmarks: not in world
// frame", "control: malformed", "snapshot: no path", "snapshot: write failed". Pair check: when landmarks are known, a
// pair whose frames see their landmarks with a median reprojection error over max_pair_landmark_error_px is skipped
// (the pose solver's early live poses can belong to a map it rescaled since). Status values: pairs,
// pairs_skipped_inconsistent, pairs_waiting (for the region), pairs_without_region (run unrestricted although a
// region was expected), pairs_before_target (require_target: dropped while no TARGET was confirmed), dense_points, refine_searches and refine_full_searches (the pairs' epipolar searches and
// those that scored every step, affine_dense.h), pair_matches_added (matches pair_matches.h added, all pairs), voxels,
// votes, pair_ms, vote_ms, carving_views, central_track_ids (track ids whose central views are counted), roi_source (0
// none, 1 target, 2 configuration, 3 automatic), roi_floor (1 when the floor cuts the region); after the final phase
// final_ms, final_seeds, final_voxels, final_triangles, final_floor_band_dropped, final_crevice_band_dropped,
// final_carved, final_hidden_vertices, final_curled_triangles, final_voxels_off_mesh, final_weak_vertices,
// final_weak_moved, final_rim_vertices_removed (weak_surface_refit.h), final_carving_s, final_visibility_s,
// final_revoted_pairs (pairs triangulated with final poses; 0 = the live votes were kept), final_revote_rejected
// (matches the re-triangulation's checks rejected, the final region's included), final_revote_s, live_final_offset_mm
// (live votes kept although final poses came: the median camera centre offset between them, mm; -1 otherwise) and
// model_off_trajectory_frame (1 when that offset is over 5 mm: the model is not in trajectory.txt's frame, the
// session fails the run), final_floor_thickness_mm, final_floor_local_thickness_mm and final_floor_points (the final
// map's floor around the target, map_consistency.h; -1 = not measured; an inconsistent map is the error state),
// final_maps (maps among the final poses of the pairs' frames), final_model_map_start_seq (the map the re-voted
// model lies in, the only one or the one kept among several; -1 = none known, or the live votes stayed) and
// final_pairs_other_maps (pairs dropped for it: a frame in another map).
// Handlers run inside
// Bus::Handle() on the caller's thread; not thread-safe.
#pragma once

#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/camera_model.h"
#include "common/node.h"
#include "common/sensor_data.h"
#include "common/statistics.h"
#include "common/status.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/target_t.hpp"
#include "processes/dense_modeler/dense_model.h"

namespace objscan {

class Bus;
class OptionParser;

struct DenseModelerNodeOptions {
  std::string name = "dense_modeler";                    // process name (status name, control sender)
  std::string image_channel = "CAMERA_IMAGE";            // images (image_t)
  std::string info_channel = "CAMERA_INFO";              // intrinsics (camera_info_t)
  std::string tracks_channel = "FEATURE_TRACKS";         // tracks (feature_tracks_t)
  std::string pose_channel = "CAMERA_POSE";              // live poses (pose_t)
  std::string final_pose_channel = "CAMERA_POSE_FINAL";  // poses after final adjustment (pose_t); "" = ignore
  std::string target_channel = "TARGET";                 // target box (target_t); "" = ignore
  std::string landmarks_channel = "LANDMARKS";           // sparse landmarks (landmarks_t); "" = ignore
  std::string voxel_map_channel = "VOXEL_MAP";           // output voxel_map_t
  std::string model_channel = "MODEL";                   // output model_t
  std::string control_channel = "OBJSCAN_CONTROL";       // control_t in and out
  std::string status_channel = "PROCESS_STATUS";         // process_status_t
  std::string finish_sender = "pose_solver";             // COMMAND_FINISHED from this sender starts the final phase
  std::string output_dir;                                // model files and snapshots go here ("" = no files)
  int buffer_frames = 40;                                // frames (full images) kept in the ring buffer (> pair_gap)
  int pair_gap = 6;                                      // frame j is paired with frame j - pair_gap (>= 1)
  int pair_every = 2;                                    // only frames with seq % pair_every == 0 start a pair (>= 1)
  double max_pair_landmark_error_px = 3.0;               // px, a pair is skipped when the median landmark reprojection
                                                         // error in either frame exceeds this (stale pose; 0 = off)
  int voxel_map_every = 10;                              // pairs between VOXEL_MAP publications (>= 1)
  int max_map_voxels = 200000;                           // voxels per VOXEL_MAP message at most (>= 1)
  bool revote_final_poses = true;                        // final phase: triangulate every pair's pixel matches again
                                                         // with the final poses and vote them into a fresh grid
  int max_stored_matches = 100000000;                    // pixel matches kept for that at most (20 bytes each, 2 GB;
                                                         // when exceeded, the final phase keeps the live votes), >= 0.
                                                         // room_01's closed loop, 7 Dec: over 32 M in 1 387 pairs, no
                                                         // re-vote, the model 10 mm off trajectory.txt (mesh p90 9.7
                                                         // mm) although the orbit's final poses were within 0.45 mm
  int carving_downsample = 2;                            // integer downsampling of the images kept for carving, [1, 8]
  int max_carving_views = 200;                           // images kept for carving at most (>= 2)
  bool use_target_box = true;                            // restrict to the confirmed TARGET box (+ margin)
  bool require_target = false;                           // closed loop (robot searching for its target): nothing is
                                                         // modeled before a confirmed TARGET box; earlier pairs are
                                                         // dropped (never run unrestricted), frames are kept for
                                                         // carving only when the box's centre is in their view, and
                                                         // auto_roi / roi_box are not used
  double target_margin_mm = 30.0;                        // mm, added on every side of the target box (>= 0)
  std::string roi_box;                                   // mm, world "xmin,ymin,zmin,xmax,ymax,zmax" ("" = none)
  bool auto_roi = true;                                  // derive the region from landmarks when no box is known
  AutoRoiOptions roi;                                    // automatic region and floor detection
  int max_central_track_ids = 200000;                    // track ids whose central views are counted at most; beyond,
                                                         // ids neither landmarks nor in the current frame are
                                                         // forgotten (bounds a long run's memory; >= 1)
  int image_queue_capacity = 60;                         // frames buffered by the image subscription (>= 1)
  int threads = 1;                                       // OpenCV threads (cv::setNumThreads)
  double status_period_s = 1.0;                          // s, status publication period (> 0)
  bool exit_when_finished = true;                        // Finished() turns true after the final phase
  DenseModelOptions model;                               // dense matching, voting, carving, meshing
};

// Registers the options a user sets on the command line (the rest keep their defaults; code and tests set the
// struct's fields directly).
void AddDenseModelerNodeOptions(OptionParser& parser, DenseModelerNodeOptions* options);
// True when usable; otherwise false with *why set.
bool ValidateDenseModelerNodeOptions(const DenseModelerNodeOptions& options, std::string* why);

class DenseModelerNode : public Node {
 public:
  // Subscribes on bus (which must outlive the node). Throws std::invalid_argument on invalid options.
  DenseModelerNode(Bus& bus, const DenseModelerNodeOptions& options);

  void Tick(int64_t wall_utime) override;
  bool Finished() const override { return finished_ && options_.exit_when_finished; }
  void OnShutdown() override;

  const StatusReporter& status() const { return status_; }
  const VoxelVoteGrid& grid() const { return grid_; }
  bool final_phase_done() const { return finished_; }
  int64_t pairs_done() const { return pairs_done_; }
  // Carving views whose pose was replaced by a CAMERA_POSE_FINAL pose in the final phase.
  int final_poses_used() const { return final_poses_used_; }
  // The current region of interest (invalid = none yet) and its source (0 none, 1 target, 2 config, 3 automatic).
  const RegionOfInterest& region() const { return region_; }
  int region_source() const { return region_source_; }
  // Runs the final phase now (as on COMMAND_FINISHED); no-op when done already.
  void RunFinalPhase(int64_t utime);

 private:
  struct FrameSlot {
    int64_t utime = 0;
    cv::Mat image;  // full resolution (empty until received)
    cv::Mat gray8;  // CV_8UC1 gray of image, made by the frame's first pair, released after its last one
                    // (ReleaseGraysAfterPair)
    cv::Mat gray;   // CV_32FC1 gray of image, likewise
    std::optional<TrackFrame> tracks;
    std::optional<CameraPoseEstimate> pose;  // usable poses only
    bool processed = false;                  // pairing / carving copy done
    bool conflicting_inputs = false;          // two different poses or track sets arrived for it: used no more
  };
  struct StoredView {
    int64_t seq = 0;
    CarvingView view;  // colour, carving_downsample
  };
  struct StoredPair {  // a dense pair's pixel matches, for the final phase's re-triangulation
    int64_t seq_a = 0, seq_b = 0;
    PinholeCamera camera;                                            // the intrinsics it was matched with
    Eigen::Isometry3d world_from_a = Eigen::Isometry3d::Identity();  // mm, the live poses it was matched with
    Eigen::Isometry3d world_from_b = Eigen::Isometry3d::Identity();
    std::vector<DenseMatch> matches;
  };

  void OnImage(const image_t& msg);
  void OnCameraInfo(const camera_info_t& msg);
  void OnTracks(const feature_tracks_t& msg);
  void OnPose(const pose_t& msg, bool final_pose);
  void OnTarget(const target_t& msg);
  void OnLandmarks(const landmarks_t& msg);
  // Recomputes region_ from the sources (see the header comment) when something changed or force is set.
  void UpdateRegion(bool force);
  void OnControl(const control_t& msg);
  // The slot of frame seq, made (evicting the oldest frames beyond buffer_frames) when new; null when the buffer is
  // full and seq is older than all its frames (it would be evicted at once).
  FrameSlot* Slot(int64_t seq);
  void TryProcess(int64_t seq);
  // A second, different pose or track set for frame seq: rejected (reason), the frame used no more (its carving view
  // dropped, no later pair).
  void MarkConflicting(int64_t seq, FrameSlot* slot, const std::string& reason);
  // Queues the pair (seq_a, seq_b) when both frames are complete, unless its frames disagree with the landmarks
  // (max_pair_landmark_error_px: then skipped and counted), and runs the waiting pairs that can run.
  void QueuePair(int64_t seq_a, int64_t seq_b);
  // Updates the region, then runs the waiting pairs, oldest first: all once the region is known or when force is
  // set (final phase), otherwise only those whose older frame is evicting_seq or older (about to leave the ring
  // buffer).
  void RunWaitingPairs(bool force, int64_t evicting_seq = -1);
  // Dense points of the pair (seq_a, seq_b) with the current region, voted into grid_ (and stored for the re-vote);
  // false when a frame is gone.
  bool RunPair(int64_t seq_a, int64_t seq_b);
  // After the pair (seq_a, seq_b) ran or was skipped: frame j is A only in the pair (j, j + pair_gap), so A's grays
  // are done, and so are B's (b may be null) when B is never an A.
  void ReleaseGraysAfterPair(FrameSlot* a, int64_t seq_b, FrameSlot* b);
  // A region of interest can still arrive (automatic from the landmarks, or a TARGET box to be confirmed).
  bool RegionExpected() const;
  void PublishVoxelMap(int64_t utime, int64_t seq, bool is_final, const std::vector<VoxelRecord>* final_voxels);
  // Final phase: replaces grid_ by the stored pairs' matches triangulated with the final poses (the live ones for
  // frames without) when revote_final_poses is set and every pair was stored. True when it did (the carving views
  // then take the final poses too; otherwise the live ones the kept votes were cast with).
  bool RevoteWithFinalPoses();
  // Final phase, before the re-vote: keeps the pairs of one map (ChooseModelMap: final poses in maps never joined,
  // pose_t.map_start_seq), logs a choice among several and reports it (status final_maps, final_model_map_start_seq,
  // final_pairs_other_maps); the carving views of other maps are left out later. Returns the live votes the kept
  // pairs' share stands for (all the live votes when nothing was dropped).
  int64_t KeepOneMap(std::vector<StoredPair>* pairs);
  // Final phase, when the live votes were kept although final poses arrived: the median camera centre offset between
  // the two (status live_final_offset_mm, model_off_trajectory_frame; a warning beyond kLiveFinalOffsetWarnMm).
  void ReportLiveFinalOffset(bool use_final_poses);
  // Final phase: the model's figures (ridge, mesh clean-up, weak vertices, carving, times, pair times) to the log.
  void LogFinalModel(const FinalModel& model, size_t views, int final_used) const;
  // Final phase: the final_* status values and the end state (an empty model and an inconsistent map are the error
  // state, saying why and what to try; the files are written either way), published at once.
  void ReportFinalState(const FinalModel& model, int64_t start_us);
  // The final map's floor around the target (map_consistency.h): "" when consistent or not measurable (no floor in
  // the region, not the final map's landmarks, live votes kept, too few floor points, lengths not metric), else why
  // the model is not to be trusted and what to try. Sets the status values final_floor_thickness_mm,
  // final_floor_local_thickness_mm (-1 = not measured) and final_floor_points.
  std::string CheckMapConsistency();
  // The region in the final poses' frame: region_ moved by the Sim(3) from the pairs' live to their final camera
  // centres when that moves its centre by more than a voxel and fits within 20 mm RMS (else region_). The floor
  // moves with it only when the landmarks in use are live ones; fitted among the final map's landmarks (they arrive
  // after the final poses) it is in the final frame already and is fitted again around the moved box instead. An
  // automatic region (source 3) derived from the final map's landmarks stays. *note: what was done, for the log
  // ("" when nothing to say).
  RegionOfInterest RegionInFinalFrame(const std::vector<StoredPair>& pairs, std::string* note) const;
  // revote_final_poses is set and final poses can arrive (final_pose_channel): the pairs' matches are kept.
  bool RevoteEnabled() const { return options_.revote_final_poses && !options_.final_pose_channel.empty(); }
  bool SaveSnapshot(const std::string& path);
  AffineDenseOptions DenseOptionsForNow() const;

  Bus& bus_;
  DenseModelerNodeOptions options_;
  StatusReporter status_;
  VoxelVoteGrid grid_;
  std::optional<PinholeCamera> camera_;
  std::map<int64_t, FrameSlot> frames_;
  std::vector<DensePoint> pair_points_;  // the last dense pair's points (buffer reused from pair to pair)
  std::vector<StoredView> carving_views_;
  std::vector<StoredPair> stored_pairs_;  // every pair so far while stored_complete_
  int64_t stored_matches_ = 0;
  bool stored_complete_ = true;  // false once max_stored_matches was exceeded (stored_pairs_ freed)
  std::map<int64_t, Eigen::Isometry3d> final_poses_;
  std::unordered_map<int64_t, int64_t> final_map_of_;  // seq -> map_start_seq of its final pose (pose_t)
  int64_t model_map_start_seq_ = -1;  // final phase: the one map kept among two or more (-1: no choice made)
  ScaleSource scale_source_ = ScaleSource::kNone;  // of the last usable pose: says mm or arbitrary in the files
  std::set<int64_t> conflicting_final_;  // frames with two different final poses: no final pose
  bool have_box_ = false;  // confirmed TARGET box
  Eigen::Vector3d box_min_ = Eigen::Vector3d::Zero(), box_max_ = Eigen::Vector3d::Zero();
  RegionOfInterest config_region_;                               // from roi_box
  std::vector<int64_t> landmark_ids_;                            // latest LANDMARKS
  std::vector<Eigen::Vector3d> landmark_points_;                 // mm, world
  std::unordered_map<int64_t, Eigen::Vector3d> landmark_by_id_;  // the same, by track id
  int64_t pairs_skipped_inconsistent_ = 0;                       // pairs skipped by the landmark reprojection check
  std::unordered_map<int64_t, int> central_counts_;  // track id -> posed frames with it in the central window
  RegionOfInterest region_;                          // current region (invalid = none)
  int region_source_ = 0;                            // 0 none, 1 target, 2 configuration, 3 automatic
  bool region_dirty_ = true;
  int64_t pairs_done_ = 0;
  int64_t model_first_seq_ = -1, model_last_seq_ = -1;  // frames of the pairs that voted (seq)
  RecentValues pair_ms_{100000};   // ms, the pairs' wall times (pair matches + dense pair; status pair_ms), the last
                                   // 100 000 kept for the final log's percentiles
  RecentValues dense_ms_{100000};  // ms, ComputeDensePair's share of them (the dense pair alone)
  std::deque<std::pair<int64_t, int64_t>> waiting_pairs_;  // (seq_a, seq_b) waiting for the region of interest
  int64_t pairs_without_region_ = 0;                       // pairs run unrestricted although a region was expected
  int64_t pairs_before_target_ = 0;                        // require_target: pairs dropped before a TARGET box
  int64_t pair_matches_added_ = 0;                         // matches AddPairMatches gave the pairs so far
  int64_t dense_points_ = 0;
  int64_t refine_searches_ = 0, refine_full_searches_ = 0;  // epipolar searches of the pairs so far, every step scored
  int64_t last_seq_ = -1, last_utime_ = 0;
  int64_t newest_image_seq_ = -1;                       // newest image accepted
  int64_t last_landmarks_seq_ = std::numeric_limits<int64_t>::min();  // seq of the landmark map in use
  bool landmarks_final_ = false;  // the map in use came after final poses: the pose solver's final map (final frame)
  int64_t carving_keep_stride_ = 1;  // keep frames whose processed index % stride == 0
  int64_t complete_frames_ = 0;
  int final_poses_used_ = 0;
  bool final_votes_from_final_poses_ = false;  // the final phase re-voted with the final poses (region_ is final)
  bool finished_ = false;
};

}  // namespace objscan

#include "processes/dense_modeler/dense_modeler_node.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>
#include <unordered_set>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/log.h"
#include "common/options.h"
#include "common/statistics.h"
#include "common/time.h"
#include "objscan/model_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/voxel_map_t.hpp"
#include "processes/dense_modeler/map_consistency.h"

namespace objscan {

void AddDenseModelerNodeOptions(OptionParser& p, DenseModelerNodeOptions* o) {
  // Only what a user sets (issue 27): plumbing, the pairing (scripts/profiles), memory and publication bounds, the
  // region and target, voxel size and vote threshold, and the two options the docs give
  // as command-line examples. Every other field keeps its default here; tests and tools set the struct directly.
  p.Add("name", &o->name, "process name (status name, sender of control messages)");
  p.AddChannel(&o->image_channel, "input image channel (image_t)");
  p.AddChannel(&o->info_channel, "camera_info_t channel");
  p.AddChannel(&o->tracks_channel, "feature_tracks_t channel");
  p.AddChannel(&o->pose_channel, "live camera pose channel (pose_t)");
  p.AddChannel(&o->final_pose_channel, "final adjusted camera poses (pose_t, \"\" = ignore)");
  p.AddChannel(&o->target_channel, "target_t channel (\"\" = ignore)");
  p.AddChannel(&o->landmarks_channel, "landmarks_t channel for the automatic region (\"\" = ignore)");
  p.AddChannel(&o->voxel_map_channel, "output voxel_map_t channel");
  p.AddChannel(&o->model_channel, "output model_t channel");
  p.AddChannel(&o->control_channel, "control_t channel (in and out)");
  p.AddChannel(&o->status_channel, "process_status_t channel");
  p.Add("finish-sender", &o->finish_sender, "COMMAND_FINISHED from this sender starts the final phase");
  p.Add("output-dir", &o->output_dir, "directory for model files and vote snapshots (\"\" = none)");
  p.Add("buffer-frames", &o->buffer_frames, "frames kept in the ring buffer (> pair-gap)");
  p.Add("pair-gap", &o->pair_gap, "frame j is paired with frame j - pair-gap");
  p.Add("pair-every", &o->pair_every, "only frames with seq % pair-every == 0 start a pair");
  p.Add("voxel-map-every", &o->voxel_map_every, "pairs between VOXEL_MAP publications");
  p.Add("max-map-voxels", &o->max_map_voxels, "voxels per VOXEL_MAP message at most");
  p.Add("max-stored-matches", &o->max_stored_matches,
        "pixel matches kept for the re-vote at most (20 bytes each; beyond, the live votes are kept)");
  p.Add("use-target-box", &o->use_target_box, "restrict the model to the confirmed TARGET box");
  p.Add("require-target", &o->require_target,
        "model nothing before a confirmed TARGET (closed loop: the robot searches for its target first)");
  p.Add("target-margin", &o->target_margin_mm, "mm, margin around the target box");
  p.Add("roi-box", &o->roi_box, "mm, world region xmin,ymin,zmin,xmax,ymax,zmax when no TARGET box (\"\" = none)");
  p.Add("auto-roi", &o->auto_roi, "derive the region of interest from the landmarks near the image centre");
  AutoRoiOptions* r = &o->roi;
  p.Add("roi-margin", &r->margin_mm, "mm, minimum growth of the automatic box on every side");
  p.Add("roi-detect-floor", &r->detect_floor, "exclude the floor plane found among the landmarks");
  p.Add("roi-floor-clearance", &r->floor_clearance_mm, "mm, points lower than this above the floor are dropped");
  p.Add("image-queue-capacity", &o->image_queue_capacity, "frames buffered by the image subscription (>= 1)");
  p.Add("threads", &o->threads, "OpenCV threads (cv::setNumThreads)");
  p.Add("exit-when-finished", &o->exit_when_finished, "exit after the final phase");
  DenseModelOptions* m = &o->model;
  p.Add("vote-threshold", &m->vote_threshold, "votes a voxel needs for VOXEL_MAP and the final model");
  p.Add("ridge-border-rings", &m->ridge.border_rings, "rings of triangles peeled off the mesh's open borders");
  p.Add("ridge-smoothing-radius", &m->ridge.smoothing_radius,
        "voxels, radius of the vote-weighted local surface fit of the surface points before meshing (0 = off)");
  p.Add("voxel-size", &m->votes.voxel_size_mm, "mm, voxel edge");
}

bool ValidateDenseModelerNodeOptions(const DenseModelerNodeOptions& o, std::string* why) {
  std::ostringstream e;
  for (const auto& [name, value] :
       std::vector<std::pair<std::string, std::string>>{{"name", o.name},
                                                        {"image-channel", o.image_channel},
                                                        {"info-channel", o.info_channel},
                                                        {"tracks-channel", o.tracks_channel},
                                                        {"pose-channel", o.pose_channel},
                                                        {"voxel-map-channel", o.voxel_map_channel},
                                                        {"model-channel", o.model_channel},
                                                        {"control-channel", o.control_channel},
                                                        {"status-channel", o.status_channel},
                                                        {"finish-sender", o.finish_sender}})
    if (value.empty()) e << name << " must not be empty; ";
  if (o.pair_gap < 1) e << "pair-gap must be >= 1; ";
  if (o.buffer_frames <= o.pair_gap) e << "buffer-frames must be > pair-gap; ";
  if (o.pair_every < 1) e << "pair-every must be >= 1; ";
  if (!(o.max_pair_landmark_error_px >= 0)) e << "max_pair_landmark_error_px must be >= 0; ";
  if (o.voxel_map_every < 1) e << "voxel-map-every must be >= 1; ";
  if (o.max_map_voxels < 1) e << "max-map-voxels must be >= 1; ";
  if (o.carving_downsample < 1 || o.carving_downsample > 8) e << "carving_downsample must be in [1, 8]; ";
  if (o.max_stored_matches < 0) e << "max-stored-matches must be >= 0; ";
  if (o.max_central_track_ids < 1) e << "max_central_track_ids must be >= 1; ";
  if (o.max_carving_views < 2) e << "max_carving_views must be >= 2; ";
  if (!(o.target_margin_mm >= 0)) e << "target-margin must be >= 0; ";
  if (o.require_target && (!o.use_target_box || o.target_channel.empty()))
    e << "require-target needs use-target-box and a target channel; ";
  {
    RegionOfInterest box;
    std::string box_why;
    if (!ParseRoiBox(o.roi_box, &box, &box_why)) e << box_why << "; ";
    if (!ValidateAutoRoiOptions(o.roi, &box_why)) e << box_why << "; ";
  }
  if (o.image_queue_capacity < 1) e << "image-queue-capacity must be >= 1; ";
  if (o.threads < 1) e << "threads must be >= 1; ";
  if (!(o.status_period_s > 0) || !std::isfinite(o.status_period_s)) e << "status_period_s must be > 0; ";
  std::string model_why;
  if (!ValidateDenseModelOptions(o.model, &model_why)) e << model_why << "; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

namespace {
// Landmarks describe frames already seen: a seq further ahead of the newest image is forged.
constexpr int64_t kLandmarksSeqAheadOfImages = 300;

// The same track set: the same ids and pixels (a re-publication, not a second tracker's).
bool SameTracks(const TrackFrame& a, const TrackFrame& b) {
  if (a.features.size() != b.features.size()) return false;
  for (size_t i = 0; i < a.features.size(); ++i)
    if (a.features[i].id != b.features[i].id || a.features[i].u != b.features[i].u || a.features[i].v != b.features[i].v)
      return false;
  return true;
}

// The same pose within what a re-publication could change (a float round trip): 0.01 mm, 1e-6 rad.
bool SamePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() < 0.01 &&
         Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() < 1e-6;
}
const DenseModelerNodeOptions& ValidatedOrThrow(const DenseModelerNodeOptions& o) {
  std::string why;
  if (!ValidateDenseModelerNodeOptions(o, &why)) throw std::invalid_argument("dense_modeler node: " + why);
  return o;
}
bool UsableStatus(PoseStatus s) {
  return s == PoseStatus::kTracking || s == PoseStatus::kRelocalized || s == PoseStatus::kGroundTruth;
}
}  // namespace

// The pose solver publishes every frame's final pose at once at the end: LCM's default subscription queue (30)
// dropped most of a 200-frame burst while the modeler was busy (an image folder run re-voted 13 of 84 pairs with
// final poses). A pose_t is ~200 bytes: 65536 queued are ~13 MB at most.
constexpr int kFinalPoseQueueCapacity = 65536;

DenseModelerNode::DenseModelerNode(Bus& bus, const DenseModelerNodeOptions& options)
    : bus_(bus),
      options_(ValidatedOrThrow(options)),
      status_(&bus, options_.name, options_.status_channel, options_.status_period_s),
      grid_(options_.model.votes) {
  cv::setNumThreads(options_.threads);
  status_.SetState(+process_status_t::STATE_STARTING, "waiting for posed images");
  status_.SetValue("pairs_waiting", 0);         // pairs waiting for the region of interest
  status_.SetValue("pairs_without_region", 0);  // pairs run unrestricted although a region was expected
  if (options_.require_target) status_.SetValue("pairs_before_target", 0);
  auto malformed = [this](const std::string& what) { return status_.MalformedHandler(what); };
  bus_.SubscribeMessage<image_t>(
      options_.image_channel, [this](const image_t& m, const RawMessage&) { OnImage(m); }, malformed("image"),
      options_.image_queue_capacity);
  bus_.SubscribeMessage<camera_info_t>(
      options_.info_channel, [this](const camera_info_t& m, const RawMessage&) { OnCameraInfo(m); },
      malformed("camera_info"));
  bus_.SubscribeMessage<feature_tracks_t>(
      options_.tracks_channel, [this](const feature_tracks_t& m, const RawMessage&) { OnTracks(m); },
      malformed("tracks"));
  bus_.SubscribeMessage<pose_t>(
      options_.pose_channel, [this](const pose_t& m, const RawMessage&) { OnPose(m, false); }, malformed("pose"));
  if (!options_.final_pose_channel.empty())
    bus_.SubscribeMessage<pose_t>(
        options_.final_pose_channel, [this](const pose_t& m, const RawMessage&) { OnPose(m, true); },
        malformed("final pose"), kFinalPoseQueueCapacity);
  if (!options_.target_channel.empty())
    bus_.SubscribeMessage<target_t>(
        options_.target_channel, [this](const target_t& m, const RawMessage&) { OnTarget(m); }, malformed("target"));
  if (!options_.landmarks_channel.empty())
    bus_.SubscribeMessage<landmarks_t>(
        options_.landmarks_channel, [this](const landmarks_t& m, const RawMessage&) { OnLandmarks(m); },
        malformed("landmarks"));
  ParseRoiBox(options_.roi_box, &config_region_, nullptr);
  bus_.SubscribeMessage<control_t>(
      options_.control_channel, [this](const control_t& m, const RawMessage&) { OnControl(m); }, malformed("control"));
}

DenseModelerNode::FrameSlot* DenseModelerNode::Slot(int64_t seq) {
  if (auto found = frames_.find(seq); found != frames_.end()) return &found->second;
  if (static_cast<int>(frames_.size()) >= options_.buffer_frames && seq < frames_.begin()->first)
    return nullptr;  // older than every frame of a full buffer: it would be evicted at once
  frames_[seq];
  while (static_cast<int>(frames_.size()) > options_.buffer_frames) {
    auto oldest = frames_.begin();
    if (!waiting_pairs_.empty() && waiting_pairs_.front().first <= oldest->first)
      RunWaitingPairs(false, oldest->first);  // its pairs cannot wait any longer
    if (!oldest->second.pose && !oldest->second.processed)
      status_.Reject("frame: evicted without pose", "seq " + std::to_string(oldest->first));
    frames_.erase(oldest);
  }
  return &frames_.at(seq);
}

void DenseModelerNode::OnCameraInfo(const camera_info_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "camera_info")) return;  // another session on the bus
  PinholeCamera camera;
  std::string error;
  if (!CameraFromMessage(msg, &camera, &error)) {
    status_.Reject(error, "camera " + msg.camera_name);
    return;
  }
  if (camera_ && !SameCalibration(*camera_, camera)) {
    status_.Reject("camera_info: changed", "calibration of '" + msg.camera_name + "' differs from the first; ignored");
    return;
  }
  status_.CountIn();
  camera_ = camera;
}

void DenseModelerNode::OnImage(const image_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "image")) return;  // another session on the bus
  if (!camera_) {
    status_.Reject("image: no camera_info yet", "seq " + std::to_string(msg.seq), "image", msg.seq);
    return;
  }
  ImageFrame frame;
  std::string error;
  if (!ImageFromMessage(msg, &frame, &error, camera_->width, camera_->height)) {
    status_.Reject(error, "seq " + std::to_string(msg.seq), "image", msg.seq);  // received, not dropped
    return;
  }
  // Only a usable image moves the stream's sequence on (a rejected one with a wild seq must not block the rest).
  if (!status_.AcceptSeq("image", msg.seq, "image")) return;
  FrameSlot* slot = Slot(msg.seq);
  if (!slot) {
    status_.Reject("image: older than the ring buffer", "seq " + std::to_string(msg.seq));
    return;
  }
  newest_image_seq_ = std::max(newest_image_seq_, msg.seq);
  status_.CountIn();
  status_.SetLastDataUtime(msg.utime);
  if (frame.image.channels() == 1) cv::cvtColor(frame.image, frame.image, cv::COLOR_GRAY2BGR);
  slot->utime = msg.utime;
  slot->image = frame.image;
  TryProcess(msg.seq);
}

void DenseModelerNode::OnTracks(const feature_tracks_t& msg) {
  TrackFrame tracks;
  std::string error;
  if (!TracksFromMessage(msg, &tracks, &error)) {
    status_.Reject(error, "seq " + std::to_string(msg.seq));
    return;
  }
  FrameSlot* slot = Slot(msg.seq);
  if (!slot) {
    status_.Reject("tracks: older than the ring buffer", "seq " + std::to_string(msg.seq));
    return;
  }
  // One frame, one set of tracks (as for poses, OnPose): a second, different one makes the frame unusable.
  if (slot->conflicting_inputs) {
    status_.Reject("tracks: frame with conflicting inputs", "seq " + std::to_string(msg.seq));
    return;
  }
  if (slot->tracks) {
    if (!SameTracks(*slot->tracks, tracks)) {
      MarkConflicting(msg.seq, slot, "tracks: a second, different set for the frame (forged, or a second session)");
      return;
    }
    status_.CountIn();
    return;  // the same tracks again
  }
  status_.CountIn();
  slot->tracks = std::move(tracks);
  TryProcess(msg.seq);
}

void DenseModelerNode::MarkConflicting(int64_t seq, FrameSlot* slot, const std::string& reason) {
  status_.Reject(reason, "seq " + std::to_string(seq));
  slot->conflicting_inputs = true;
  carving_views_.erase(std::remove_if(carving_views_.begin(), carving_views_.end(),
                                      [&](const StoredView& v) { return v.seq == seq; }),
                       carving_views_.end());
}

void DenseModelerNode::OnPose(const pose_t& msg, bool final_pose) {
  CameraPoseEstimate pose;
  std::string error;
  if (!PoseFromMessage(msg, &pose, &error)) {
    status_.Reject(final_pose ? "final " + error : error, "seq " + std::to_string(msg.seq));
    return;
  }
  if (!UsableStatus(pose.status)) {
    status_.Reject(final_pose ? "final pose: not tracking" : "pose: not tracking",
                   "seq " + std::to_string(msg.seq) + " status " + std::to_string(static_cast<int>(pose.status)));
    return;
  }
  // One frame has one pose: the pose solver never sends a second, different usable pose for a frame (its late poses
  // replace only unusable first ones). A second one is forged or from a second session on the bus; which of the two
  // is true cannot be told, so the frame is used no more (the fuzz test's forged seq-1 poses had made the model's
  // p90 230 mm when one arrived before the true pose).
  const std::string at = "seq " + std::to_string(msg.seq);
  scale_source_ = pose.scale_source;
  if (final_pose) {
    if (conflicting_final_.count(msg.seq)) {
      status_.Reject("final pose: frame with conflicting poses", at);
      return;
    }
    auto f = final_poses_.find(msg.seq);
    if (f != final_poses_.end() && !SamePose(f->second, pose.world_from_camera)) {
      status_.Reject("final pose: a second, different pose for the frame (forged, or a second session)", at);
      final_poses_.erase(f);
      final_map_of_.erase(msg.seq);
      conflicting_final_.insert(msg.seq);
      return;
    }
    status_.CountIn();
    final_poses_[msg.seq] = pose.world_from_camera;
    final_map_of_[msg.seq] = pose.map_start_seq;
    return;
  }
  auto it = frames_.find(msg.seq);
  if (it == frames_.end() || it->second.image.empty()) {
    status_.Reject("pose: unknown frame", at);
    return;
  }
  FrameSlot& slot = it->second;
  if (slot.conflicting_inputs) {
    status_.Reject("pose: frame with conflicting poses", at);
    return;
  }
  if (slot.pose && !SamePose(slot.pose->world_from_camera, pose.world_from_camera)) {
    MarkConflicting(msg.seq, &slot, "pose: a second, different pose for the frame (forged, or a second session)");
    return;
  }
  status_.CountIn();
  if (slot.pose) return;  // the same pose again
  slot.pose = pose;
  TryProcess(msg.seq);
}

void DenseModelerNode::OnTarget(const target_t& msg) {
  bool finite = std::isfinite(msg.yaw_rad);
  for (int k = 0; k < 3; ++k) finite = finite && std::isfinite(msg.center_mm[k]) && std::isfinite(msg.size_mm[k]);
  if (!finite || msg.size_mm[0] < 0 || msg.size_mm[1] < 0 || msg.size_mm[2] < 0) {
    status_.Reject("target: malformed", "non-finite or negative box");
    return;
  }
  status_.CountIn();
  if (msg.state != target_t::STATE_CONFIRMED || !options_.use_target_box) return;
  const double c = std::abs(std::cos(msg.yaw_rad)), s = std::abs(std::sin(msg.yaw_rad));
  const Eigen::Vector3d half(0.5 * (c * msg.size_mm[0] + s * msg.size_mm[1]) + options_.target_margin_mm,
                             0.5 * (s * msg.size_mm[0] + c * msg.size_mm[1]) + options_.target_margin_mm,
                             0.5 * msg.size_mm[2] + options_.target_margin_mm);
  if (!(half.array() > 0).all()) {  // a flat box with no margin: no point could lie inside it
    status_.Reject("target: empty box", "size " + std::to_string(msg.size_mm[0]) + " x " +
                                            std::to_string(msg.size_mm[1]) + " x " + std::to_string(msg.size_mm[2]) +
                                            " mm and target-margin 0");
    return;
  }
  const Eigen::Vector3d center(msg.center_mm[0], msg.center_mm[1], msg.center_mm[2]);
  box_min_ = center - half;
  box_max_ = center + half;
  have_box_ = true;
  region_dirty_ = true;
}

void DenseModelerNode::OnLandmarks(const landmarks_t& msg) {
  const size_t n = static_cast<size_t>(std::max(0, msg.num_landmarks));
  if (msg.num_landmarks < 0 || msg.id.size() != n || msg.position_mm.size() != n) {
    status_.Reject("landmarks: malformed", "inconsistent counts");
    return;
  }
  if (!msg.frame.empty() && msg.frame != "world") {
    status_.Reject("landmarks: not in world frame", "frame " + msg.frame);
    return;
  }
  // Each message replaces the whole map: one from the past (older than the map in use) or about a frame not seen
  // yet (a forged seq) would replace it with something else (the fuzz test's 5 landmarks at (1, 2, 3) mm moved the
  // region of interest: model p90 434 mm).
  if (msg.seq < last_landmarks_seq_ || msg.seq > newest_image_seq_ + kLandmarksSeqAheadOfImages) {
    status_.Reject(msg.seq < last_landmarks_seq_ ? "landmarks: older than the map in use" : "landmarks: seq ahead of the images",
                   "seq " + std::to_string(msg.seq) + ", map in use " + std::to_string(last_landmarks_seq_) +
                       ", newest image " + std::to_string(newest_image_seq_));
    return;
  }
  last_landmarks_seq_ = msg.seq;
  landmarks_final_ = !final_poses_.empty();
  status_.CountIn();
  landmark_ids_.clear();
  landmark_points_.clear();
  landmark_by_id_.clear();
  landmark_ids_.reserve(n);
  landmark_points_.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p(msg.position_mm[i][0], msg.position_mm[i][1], msg.position_mm[i][2]);
    if (!p.allFinite()) continue;  // a bad point is skipped, not the whole map
    landmark_ids_.push_back(msg.id[i]);
    landmark_points_.push_back(p);
    landmark_by_id_[msg.id[i]] = p;
  }
  region_dirty_ = true;
}

void DenseModelerNode::UpdateRegion(bool force) {
  if (!region_dirty_ && !force) return;
  region_dirty_ = false;
  RegionOfInterest region;
  int source = 0;
  if (have_box_ || (config_region_.valid && !options_.require_target)) {
    source = have_box_ ? 1 : 2;
    region = have_box_ ? RegionOfInterest{} : config_region_;
    if (have_box_) {
      region.valid = true;
      region.box_min = box_min_;
      region.box_max = box_max_;
    }
    if (options_.roi.detect_floor)
      AddFloorNear(landmark_points_, 0.5 * (region.box_min + region.box_max), options_.roi, &region);
  } else if (options_.auto_roi && !options_.require_target &&
             AutoRegionOfInterest(landmark_ids_, landmark_points_, central_counts_, options_.roi, &region)) {
    source = 3;
  }
  region_ = region;
  region_source_ = source;
  status_.SetValue("roi_source", source);
  status_.SetValue("roi_floor", region_.has_floor ? 1.0 : 0.0);
}

AffineDenseOptions DenseModelerNode::DenseOptionsForNow() const {
  AffineDenseOptions d = options_.model.dense;
  d.region = region_;
  return d;
}

void DenseModelerNode::TryProcess(int64_t seq) {
  auto it = frames_.find(seq);
  if (it == frames_.end() || finished_) return;
  FrameSlot& slot = it->second;
  if (slot.processed || slot.image.empty() || !slot.tracks || !slot.pose) return;
  slot.processed = true;
  last_seq_ = std::max(last_seq_, seq);
  last_utime_ = std::max(last_utime_, slot.utime);
  // Copy for the final carving (bounded, deterministic thinning). Searching for its target, the robot looks
  // elsewhere: with require_target only frames that see the target box's centre are kept.
  bool carving_candidate = true;
  if (options_.require_target) {
    Eigen::Vector2d pixel;
    const Eigen::Vector3d center_in_camera = slot.pose->world_from_camera.inverse() * (0.5 * (box_min_ + box_max_));
    carving_candidate = have_box_ && camera_->Project(center_in_camera, &pixel) && camera_->InImage(pixel);
  }
  if (carving_candidate && complete_frames_ % carving_keep_stride_ == 0) {
    if (static_cast<int>(carving_views_.size()) >= options_.max_carving_views) {
      std::vector<StoredView> kept;
      for (size_t i = 0; i < carving_views_.size(); i += 2) kept.push_back(std::move(carving_views_[i]));
      carving_views_.swap(kept);
      carving_keep_stride_ *= 2;
    }
    if (complete_frames_ % carving_keep_stride_ == 0) {
      StoredView stored;
      stored.seq = seq;
      stored.view = MakeCarvingView(*camera_, slot.pose->world_from_camera, slot.image, options_.carving_downsample);
      carving_views_.push_back(std::move(stored));
    }
  }
  if (carving_candidate) ++complete_frames_;
  if (options_.auto_roi) {
    std::vector<std::pair<int64_t, Eigen::Vector2d>> tracks;
    tracks.reserve(slot.tracks->features.size());
    for (const TrackedFeature& f : slot.tracks->features) tracks.emplace_back(f.id, Eigen::Vector2d(f.u, f.v));
    CountCentralTracks(*camera_, tracks, options_.roi.central_fraction, &central_counts_);
    if (static_cast<int64_t>(central_counts_.size()) > options_.max_central_track_ids) {
      std::unordered_set<int64_t> current;
      for (const auto& t : tracks) current.insert(t.first);
      for (auto c = central_counts_.begin(); c != central_counts_.end();)
        c = (landmark_by_id_.count(c->first) || current.count(c->first)) ? std::next(c) : central_counts_.erase(c);
    }
    status_.SetValue("central_track_ids", static_cast<double>(central_counts_.size()));
    region_dirty_ = true;
  }
  status_.SetValue("carving_views", static_cast<double>(carving_views_.size()));
  if (!finished_ && status_.state() != +process_status_t::STATE_RUNNING)
    status_.SetState(+process_status_t::STATE_RUNNING);

  // A pair is queued when the second of its two frames is complete (frames can complete out of order).
  if (seq % options_.pair_every == 0) QueuePair(seq - options_.pair_gap, seq);
  if ((seq + options_.pair_gap) % options_.pair_every == 0) QueuePair(seq, seq + options_.pair_gap);
}

void DenseModelerNode::QueuePair(int64_t seq_a, int64_t seq_b) {
  auto ia = frames_.find(seq_a), ib = frames_.find(seq_b);
  if (ia == frames_.end() || ib == frames_.end()) return;
  FrameSlot& pa = ia->second;
  FrameSlot& pb = ib->second;
  if (pa.conflicting_inputs || pb.conflicting_inputs) return;
  if (!pa.processed || !pb.processed || pa.image.empty() || pb.image.empty()) return;
  if (options_.max_pair_landmark_error_px > 0 && !landmark_by_id_.empty()) {
    int na = 0, nb = 0;
    const double ea =
        MedianLandmarkReprojectionPx(*camera_, pa.pose->world_from_camera, *pa.tracks, landmark_by_id_, &na);
    const double eb =
        MedianLandmarkReprojectionPx(*camera_, pb.pose->world_from_camera, *pb.tracks, landmark_by_id_, &nb);
    if (std::max(ea, eb) > options_.max_pair_landmark_error_px) {
      ++pairs_skipped_inconsistent_;
      status_.SetValue("pairs_skipped_inconsistent", static_cast<double>(pairs_skipped_inconsistent_));
      LogInfo("pair " + std::to_string(seq_a) + "-" + std::to_string(seq_b) +
              " skipped: median landmark reprojection error " + std::to_string(ea) + " / " + std::to_string(eb) +
              " px");
      ReleaseGraysAfterPair(&pa, seq_b, &pb);
      return;
    }
  }
  // Oldest first (RunWaitingPairs runs the front ones before their older frame leaves the buffer).
  const std::pair<int64_t, int64_t> pair(seq_a, seq_b);
  waiting_pairs_.insert(std::upper_bound(waiting_pairs_.begin(), waiting_pairs_.end(), pair), pair);
  RunWaitingPairs(false);
}

bool DenseModelerNode::RegionExpected() const {
  return !region_.valid && ((options_.auto_roi && !options_.require_target && !options_.landmarks_channel.empty()) ||
                            (options_.use_target_box && !options_.target_channel.empty()));
}

void DenseModelerNode::RunWaitingPairs(bool force, int64_t evicting_seq) {
  UpdateRegion(false);  // (landmarks may have changed since: a region known by now is used)
  while (!waiting_pairs_.empty()) {
    const auto [seq_a, seq_b] = waiting_pairs_.front();
    if (RegionExpected() && !force && seq_a > evicting_seq) break;
    waiting_pairs_.pop_front();
    if (options_.require_target && !region_.valid) {
      ++pairs_before_target_;
      status_.SetValue("pairs_before_target", static_cast<double>(pairs_before_target_));
      continue;
    }
    if (RegionExpected()) {
      ++pairs_without_region_;
      status_.SetValue("pairs_without_region", static_cast<double>(pairs_without_region_));
      if (pairs_without_region_ == 1 || pairs_without_region_ % 100 == 0)
        LogWarning("pair " + std::to_string(seq_a) + "-" + std::to_string(seq_b) +
                   " runs without a region of interest (none yet, and its frame leaves the ring buffer or the final "
                   "phase started); " +
                   std::to_string(pairs_without_region_) + " such pairs so far");
    }
    if (!RunPair(seq_a, seq_b)) status_.Reject("pair: frame gone", std::to_string(seq_a) + "-" + std::to_string(seq_b));
  }
  status_.SetValue("pairs_waiting", static_cast<double>(waiting_pairs_.size()));
}

bool DenseModelerNode::RunPair(int64_t seq_a, int64_t seq_b) {
  auto ia = frames_.find(seq_a), ib = frames_.find(seq_b);
  if (ia == frames_.end() || ib == frames_.end() || ia->second.image.empty() || ib->second.image.empty()) return false;
  FrameSlot& pa = ia->second;
  FrameSlot& slot = ib->second;
  if (pa.conflicting_inputs || slot.conflicting_inputs) return true;  // counted where the conflict was found
  const int64_t seq = seq_b;
  const int64_t start_us = MonotonicMicros();
  // Each frame's grays are made once for its two pairs (the pair matcher's and the dense pair's).
  for (FrameSlot* f : {&pa, &slot}) {
    if (f->gray8.empty()) f->gray8 = Gray8(f->image);
    if (f->gray.empty()) f->gray8.convertTo(f->gray, CV_32F);
  }
  DenseView a, b;
  a.seq = seq_a;
  a.camera = *camera_;
  a.world_from_camera = pa.pose->world_from_camera;
  a.image = pa.image;
  a.gray8 = pa.gray8;
  a.gray = pa.gray;
  b.seq = seq;
  b.camera = *camera_;
  b.world_from_camera = slot.pose->world_from_camera;
  b.image = slot.image;
  b.gray8 = slot.gray8;
  b.gray = slot.gray;
  const AffineDenseOptions dense = DenseOptionsForNow();
  std::vector<PointMatch> matches = MatchTracks(*pa.tracks, *slot.tracks);
  const cv::Rect rect = DensePairRoi(a.camera, a.world_from_camera, dense);
  if (options_.model.pair_matches.enabled && rect.area() > 0) {
    PairMatchStats pm;
    const std::vector<PointMatch> extra =
        AddPairMatches(a, b, matches, rect, region_, options_.model.pair_matches, &pm);
    matches.insert(matches.end(), extra.begin(), extra.end());
    pair_matches_added_ += pm.added;
    status_.SetValue("pair_matches_added", static_cast<double>(pair_matches_added_));
  }
  DensePairStats stats;
  std::vector<DensePoint>& points = pair_points_;  // reused from pair to pair (no allocation, no page faults)
  const int64_t dense_start_us = MonotonicMicros();
  ComputeDensePair(a, b, matches, dense, &points, &stats);
  dense_ms_.Add((MonotonicMicros() - dense_start_us) * 1e-3);
  refine_searches_ += stats.refine_searches;
  refine_full_searches_ += stats.refine_full_searches;
  ReleaseGraysAfterPair(&pa, seq_b, &slot);
  const int64_t vote_start_us = MonotonicMicros();
  grid_.AddPoints(points);
  if (RevoteEnabled() && stored_complete_ && !points.empty()) {  // an empty pair has nothing to re-vote
    if (stored_matches_ + static_cast<int64_t>(points.size()) > options_.max_stored_matches) {
      stored_complete_ = false;
      std::vector<StoredPair>().swap(stored_pairs_);
      LogWarning("more than " + std::to_string(options_.max_stored_matches) +
                 " pixel matches (max-stored-matches): the final phase will keep the live votes");
    } else {
      StoredPair sp;
      sp.seq_a = a.seq;
      sp.seq_b = b.seq;
      sp.camera = *camera_;
      sp.world_from_a = a.world_from_camera;
      sp.world_from_b = b.world_from_camera;
      sp.matches = DenseMatchesOf(points);
      stored_matches_ += static_cast<int64_t>(points.size());
      stored_pairs_.push_back(std::move(sp));
    }
  }
  const int64_t end_us = MonotonicMicros();
  ++pairs_done_;
  dense_points_ += static_cast<int64_t>(points.size());
  if (!points.empty()) {  // the frames the model is built from (the session checks them against unjoined maps)
    model_first_seq_ = model_first_seq_ < 0 ? a.seq : std::min(model_first_seq_, a.seq);
    model_last_seq_ = std::max(model_last_seq_, b.seq);
    status_.SetValue("model_first_seq", static_cast<double>(model_first_seq_));
    status_.SetValue("model_last_seq", static_cast<double>(model_last_seq_));
  }
  status_.SetValue("pairs", static_cast<double>(pairs_done_));
  status_.SetValue("dense_points", static_cast<double>(dense_points_));
  status_.SetValue("refine_searches", static_cast<double>(refine_searches_));
  status_.SetValue("refine_full_searches", static_cast<double>(refine_full_searches_));
  status_.SetValue("voxels", static_cast<double>(grid_.num_voxels()));
  status_.SetValue("votes", static_cast<double>(grid_.total_votes()));
  const double pair_ms = (vote_start_us - start_us) * 1e-3;
  pair_ms_.Add(pair_ms);
  status_.SetValue("pair_ms", pair_ms);
  status_.SetValue("vote_ms", (end_us - vote_start_us) * 1e-3);
  status_.RecordLatencyMs((end_us - start_us) * 1e-3);
  if (pairs_done_ % options_.voxel_map_every == 0) PublishVoxelMap(slot.utime, seq, false, nullptr);
  return true;
}

void DenseModelerNode::ReleaseGraysAfterPair(FrameSlot* a, int64_t seq_b, FrameSlot* b) {
  a->gray8.release(), a->gray.release();
  if (b && (seq_b + options_.pair_gap) % options_.pair_every != 0) b->gray8.release(), b->gray.release();
}

void DenseModelerNode::PublishVoxelMap(int64_t utime, int64_t seq, bool is_final,
                                       const std::vector<VoxelRecord>* final_voxels) {
  std::vector<VoxelRecord> voxels = final_voxels ? *final_voxels : grid_.Extract(options_.model.vote_threshold);
  voxel_map_t msg;
  msg.utime = utime;
  msg.seq = seq;
  msg.frame = "world";
  msg.voxel_size_mm = grid_.voxel_size();
  msg.origin_mm[0] = msg.origin_mm[1] = msg.origin_mm[2] = 0;
  msg.vote_threshold = options_.model.vote_threshold;
  msg.is_final = is_final;
  msg.truncated = static_cast<int>(voxels.size()) > options_.max_map_voxels;
  if (msg.truncated) {  // strongest first, then (k, j, i): deterministic
    std::stable_sort(voxels.begin(), voxels.end(),
                     [](const VoxelRecord& x, const VoxelRecord& y) { return x.votes > y.votes; });
    voxels.resize(options_.max_map_voxels);
  }
  msg.num_voxels = static_cast<int32_t>(voxels.size());
  msg.ijk.resize(voxels.size());
  msg.votes.resize(voxels.size());
  msg.rgb.resize(voxels.size());
  for (size_t i = 0; i < voxels.size(); ++i) {
    msg.ijk[i] = {voxels[i].ijk.x(), voxels[i].ijk.y(), voxels[i].ijk.z()};
    msg.votes[i] = voxels[i].votes;
    msg.rgb[i] = {static_cast<uint8_t>(voxels[i].bgr[2]), static_cast<uint8_t>(voxels[i].bgr[1]),
                  static_cast<uint8_t>(voxels[i].bgr[0])};
  }
  if (bus_.PublishMessage(options_.voxel_map_channel, msg))
    status_.CountOut();
  else
    LogWarning("publishing on " + options_.voxel_map_channel + " failed");
}

namespace {
// mm: live votes kept while the final poses lie farther from the live ones than this is reported (and the session
// fails); a 2 mm voxel model within a few mm of the final frame is still the model of trajectory.txt's object.
constexpr double kLiveFinalOffsetWarnMm = 5.0;
}  // namespace

RegionOfInterest DenseModelerNode::RegionInFinalFrame(const std::vector<StoredPair>& pairs, std::string* note) const {
  note->clear();
  if (!region_.valid) return region_;
  std::map<int64_t, std::pair<Eigen::Vector3d, Eigen::Vector3d>> centres;  // seq -> (live, final) camera centre
  for (const StoredPair& sp : pairs)
    for (const auto& [seq, live] : {std::make_pair(sp.seq_a, &sp.world_from_a), std::make_pair(sp.seq_b, &sp.world_from_b)}) {
      auto f = final_poses_.find(seq);
      if (f != final_poses_.end()) centres[seq] = {live->translation(), f->second.translation()};
    }
  std::vector<Eigen::Vector3d> from, to;
  for (const auto& [seq, c] : centres) {
    from.push_back(c.first);
    to.push_back(c.second);
  }
  Sim3 sim;
  double rms = 0;
  if (from.size() < 10 || !AlignSimilarity(from, to, &sim, &rms)) return region_;
  const Eigen::Vector3d centre = 0.5 * (region_.box_min + region_.box_max);
  const double moved = (sim * centre - centre).norm();
  char text[320];
  // A region moved by less than a voxel stays (the final adjustment's sub-millimetre changes); a move that is not a
  // Sim(3) (the views' centres off it by more than 20 mm RMS) is not followed either.
  if (moved <= grid_.voxel_size()) return region_;
  // The automatic region is derived from the landmarks in use: from the final map's, it is in the final frame already.
  if (region_source_ == 3 && landmarks_final_) {
    std::snprintf(text, sizeof(text),
                  "final votes: the automatic region, derived from the final map's landmarks, stays (the final poses "
                  "moved its centre %.0f mm from the live frame)",
                  moved);
    *note = text;
    return region_;
  }
  if (rms > 20.0) {
    std::snprintf(text, sizeof(text),
                  "final votes: the region stays in the live frame: the final camera centres are no Sim(3) of the live "
                  "ones (%.1f mm RMS over %zu views; the region's centre would move %.0f mm)",
                  rms, from.size(), moved);
    *note = text;
    return region_;
  }
  std::snprintf(text, sizeof(text),
                "final votes: the region moved with the final poses by %.0f mm (Sim(3) of the live camera centres, scale "
                "%.4f, %.2f mm RMS over %zu views)",
                moved, sim.scale, rms, from.size());
  *note = text;
  RegionOfInterest moved_region = TransformRegion(region_, sim);
  // The floor. Fitted among the final map's landmarks (the pose solver sends them after its final poses, before its
  // FINISHED; UpdateRegion fitted region_'s floor among them) it is in the final frame already: moved as well it
  // would be off by the move's height (room_03, 7 Dec: the region moved 38 mm, Sim(3) 18 mm RMS; the floor band then
  // kept the floor ring 5-11 mm high up to 100 mm around the cylinder: mesh p90 29.3 mm, max 124 mm, target box +79 /
  // +45 mm). It is fitted again among them around the moved box (the floor near the live box may be another part of
  // the room, or none); when none is found there, region_'s (final) floor, if any, stays.
  if (landmarks_final_ && options_.roi.detect_floor) {
    RegionOfInterest refit = moved_region;  // region_'s (final) floor, unless one is found around the moved box
    refit.has_floor = region_.has_floor;
    refit.floor = region_.floor;
    const Eigen::Vector3d moved_centre = 0.5 * (moved_region.box_min + moved_region.box_max);
    const int inliers = AddFloorNear(landmark_points_, moved_centre, options_.roi, &refit);
    refit.floor_clearance_mm = region_.floor_clearance_mm;
    char more[220] = "; no floor among the final landmarks around it or the live box";
    if (refit.has_floor) {
      const double shift_mm = moved_region.has_floor ? std::abs(refit.HeightAboveFloor(moved_centre) -
                                                                moved_region.HeightAboveFloor(moved_centre))
                                                     : 0.0;
      if (inliers > 0)
        std::snprintf(more, sizeof(more),
                      "; floor fitted again among the final landmarks around it (%d points), %.1f mm from the moved "
                      "one at its centre", inliers, shift_mm);
      else
        std::snprintf(more, sizeof(more),
                      "; no floor among the final landmarks around it: the final floor near the live box kept, %.1f "
                      "mm from the moved one at its centre", shift_mm);
    }
    *note += more;
    moved_region = refit;
  }
  return moved_region;
}

int64_t DenseModelerNode::KeepOneMap(std::vector<StoredPair>* pairs) {
  std::vector<PairFrames> frames;
  frames.reserve(pairs->size());
  for (const StoredPair& sp : *pairs)
    frames.push_back({sp.seq_a, sp.seq_b, static_cast<int64_t>(sp.matches.size())});
  const ModelMapChoice choice = ChooseModelMap(frames, final_map_of_);
  model_map_start_seq_ = choice.map_start_seq;
  status_.SetValue("final_maps", choice.maps);
  status_.SetValue("final_model_map_start_seq", static_cast<double>(choice.map_start_seq));
  status_.SetValue("final_pairs_other_maps", static_cast<double>(choice.pairs_other_map + choice.pairs_across_maps));
  const int64_t live_votes = grid_.total_votes();
  // One map (or none known) and nothing dropped: every pair stays; the map still filters the carving views.
  if (choice.pairs_other_map + choice.pairs_across_maps == 0) return live_votes;
  std::vector<StoredPair> kept;
  for (size_t i = 0; i < pairs->size(); ++i)
    if (choice.keep[i]) kept.push_back(std::move((*pairs)[i]));
  pairs->swap(kept);
  const double kept_fraction = static_cast<double>(choice.matches_kept) /
                               static_cast<double>(std::max<int64_t>(1, choice.matches_kept + choice.matches_dropped));
  char text[420];
  std::snprintf(text, sizeof(text),
                "final votes from one map: the pose solver's final poses lie in %d maps never joined to each other; "
                "the model keeps the map that began at frame %lld (%zu pairs, %.0f %% of the matches) and drops %lld "
                "pairs of the other maps and %lld across two",
                choice.maps, static_cast<long long>(choice.map_start_seq), pairs->size(), 100.0 * kept_fraction,
                static_cast<long long>(choice.pairs_other_map), static_cast<long long>(choice.pairs_across_maps));
  LogWarning(text);
  return static_cast<int64_t>(kept_fraction * static_cast<double>(live_votes));
}

bool DenseModelerNode::RevoteWithFinalPoses() {
  status_.SetValue("final_revoted_pairs", 0);
  status_.SetValue("final_revote_rejected", 0);
  status_.SetValue("final_revote_s", 0);
  if (!RevoteEnabled()) return false;
  if (!stored_complete_) {
    LogWarning("final votes: the live ones (the pairs' matches exceeded max-stored-matches)");
    return false;
  }
  const int64_t start_us = MonotonicMicros();
  std::vector<StoredPair> pairs;
  pairs.swap(stored_pairs_);  // freed on return
  stored_matches_ = 0;
  const int64_t live_votes_kept_maps = KeepOneMap(&pairs);
  VoxelVoteGrid fresh(options_.model.votes);
  AffineDenseOptions dense = DenseOptionsForNow();
  // The region (the TARGET box, the automatic region) was found in the live poses' frame. When the final poses are
  // the live ones moved as a whole (an unjoined map restart rescaled by its floor: room_02, 7 Dec, final poses 351 mm
  // from the live ones, every re-voted point outside the live region, the model kept in the live frame), the region
  // moves with them.
  std::string region_note;
  const RegionOfInterest final_region = RegionInFinalFrame(pairs, &region_note);
  if (!region_note.empty()) LogInfo(region_note);
  dense.region = final_region;
  int64_t with_final = 0, points = 0, rejected = 0;
  for (const StoredPair& sp : pairs) {
    auto fa = final_poses_.find(sp.seq_a), fb = final_poses_.find(sp.seq_b);
    const bool final_pair = fa != final_poses_.end() && fb != final_poses_.end();
    int64_t pair_rejected = 0;
    const std::vector<DensePoint> pts =
        TriangulateDenseMatches(sp.camera, final_pair ? fa->second : sp.world_from_a, sp.camera,
                                final_pair ? fb->second : sp.world_from_b, sp.matches, dense, &pair_rejected);
    fresh.AddPoints(pts);
    with_final += final_pair;
    points += static_cast<int64_t>(pts.size());
    rejected += pair_rejected;
  }
  const double seconds = (MonotonicMicros() - start_us) * 1e-6;
  const std::string counts = std::to_string(pairs.size()) + " pairs, " + std::to_string(with_final) +
                             " with final poses: " + std::to_string(points) + " points, " + std::to_string(rejected) +
                             " matches rejected (final region, epipolar, angle, reprojection); live grid " +
                             std::to_string(grid_.total_votes()) + " votes, new " + std::to_string(fresh.total_votes());
  status_.SetValue("final_revote_rejected", static_cast<double>(rejected));
  status_.SetValue("final_revote_s", seconds);
  auto keep_live_votes = [this]() {  // the live grid (every map's votes) stays: no map was chosen after all
    model_map_start_seq_ = -1;
    status_.SetValue("final_model_map_start_seq", -1);
    status_.SetValue("final_pairs_other_maps", 0);
    return false;
  };
  if (with_final == 0) {
    LogInfo("final votes: the live ones (no pair has final poses)");
    return keep_live_votes();
  }
  // The live grid holds the dropped maps' votes too: the fresh one is compared with the kept maps' share of it.
  if (2 * fresh.total_votes() < live_votes_kept_maps) {
    LogWarning("final votes: the live ones, the final poses keep too few (" + counts + ")");
    return keep_live_votes();
  }
  if (10 * with_final < 9 * static_cast<int64_t>(pairs.size()))  // final poses missing: lost on the bus, or unposed
    LogWarning("final votes: only " + std::to_string(with_final) + " of " + std::to_string(pairs.size()) +
               " pairs have both final poses; the others keep their live poses (" + counts + ")");
  else
    LogInfo("final votes recomputed in " + std::to_string(seconds) + " s: " + counts);
  status_.SetValue("final_revoted_pairs", static_cast<double>(with_final));
  region_ = final_region;  // the model's region, as its votes
  grid_ = std::move(fresh);
  status_.SetValue("voxels", static_cast<double>(grid_.num_voxels()));
  status_.SetValue("votes", static_cast<double>(grid_.total_votes()));
  return true;
}

void DenseModelerNode::ReportLiveFinalOffset(bool use_final_poses) {
  // Live votes kept although final poses arrived: how far the final poses lie from the live ones the model was built
  // with (median camera centre offset over the views that have both). Far off, the model is not in trajectory.txt's
  // frame (room_02, 7 Dec: a re-vote that kept no point after an unjoined restart, the model 390 mm off): loud.
  double live_final_offset_mm = -1;
  if (!use_final_poses) {
    std::vector<double> offsets;
    for (const StoredView& sv : carving_views_) {
      auto it = final_poses_.find(sv.seq);
      if (it != final_poses_.end())
        offsets.push_back((it->second.translation() - sv.view.world_from_camera.translation()).norm());
    }
    if (!offsets.empty()) {
      std::nth_element(offsets.begin(), offsets.begin() + offsets.size() / 2, offsets.end());
      live_final_offset_mm = offsets[offsets.size() / 2];
      if (live_final_offset_mm > kLiveFinalOffsetWarnMm)
        LogWarning("the model is built from the live poses, which lie " + std::to_string(live_final_offset_mm) +
                   " mm (median over " + std::to_string(offsets.size()) +
                   " views) from the final poses of the same frames: it is not in trajectory.txt's frame");
    }
  }
  status_.SetValue("live_final_offset_mm", live_final_offset_mm);
  status_.SetValue("model_off_trajectory_frame", live_final_offset_mm > kLiveFinalOffsetWarnMm ? 1 : 0);
}

void DenseModelerNode::LogFinalModel(const FinalModel& model, size_t views, int final_used) const {
  LogInfo("vote ridge: " + std::to_string(model.ridge.ridge) + " ridge voxels of " + std::to_string(model.seeds) +
          " seeds, " + std::to_string(model.floor_band_dropped) + " facing up and " +
          std::to_string(model.crevice_band_dropped) + " facing down near the floor dropped, " +
          std::to_string(model.ridge.fragments_dropped) + " in small fragments dropped, " +
          std::to_string(model.ridge.crease_points_moved) +
          " surface points moved onto creases; mesh: " + std::to_string(model.visibility.vertices_removed) +
          " vertices hidden in " + std::to_string(model.visibility.views) + " views removed, " +
          std::to_string(model.ridge.curled_triangles_dropped) + " triangles of curled rims and " +
          std::to_string(model.ridge.border_triangles_dropped) + " of border rings peeled, " +
          std::to_string(model.ridge.mesh_triangles_dropped) + " in small pieces dropped, " +
          std::to_string(model.voxels_without_mesh) + " voxels off the final mesh dropped");
  if (options_.model.weak_refit.relative_votes > 0) {
    const WeakRefitStats& w = model.weak_refit;
    char line[512];
    std::snprintf(line, sizeof(line),
                  "weak vertices (< %.0f votes, median %.0f): %lld of %lld; %lld moved onto their strong neighbours' "
                  "surface (mean %.2f mm, max %.2f mm), %lld on flared rims removed (%lld triangles); left: %lld "
                  "close, %lld few neighbours, %lld not surrounded, %lld poor fit, %lld too far",
                  options_.model.weak_refit.relative_votes * w.median_votes, w.median_votes,
                  static_cast<long long>(w.weak), static_cast<long long>(w.vertices), static_cast<long long>(w.moved),
                  w.mean_abs_move_mm, w.max_abs_move_mm, static_cast<long long>(w.rim_vertices_dropped),
                  static_cast<long long>(w.rim_triangles_dropped), static_cast<long long>(w.close),
                  static_cast<long long>(w.few_neighbours), static_cast<long long>(w.not_surrounded),
                  static_cast<long long>(w.poor_fit), static_cast<long long>(w.too_far));
    LogInfo(line);
  }
  LogInfo("final phase: " + std::to_string(model.seeds) + " seeds, " + std::to_string(model.voxels.size()) +
          " voxels after carving (" + std::to_string(model.carving.removed) + " carved) with " +
          std::to_string(views) + " views (" + std::to_string(final_used) + " with final poses), " +
          std::to_string(model.mesh.triangles.size()) + " triangles; scale " + ScaleDescription(scale_source_));
  std::string per_pass;
  for (int64_t r : model.carving.removed_per_iteration) per_pass += (per_pass.empty() ? "" : " ") + std::to_string(r);
  LogInfo("carving: " + std::to_string(model.carving.iterations) + " passes, removed per pass: " + per_pass);
  char times[400];
  std::snprintf(
      times, sizeof(times),
      "final phase times: surface %.2f s, carving %.2f s, meshing %.2f s, visibility %.2f s, clean-up %.2f s",
      model.times.surface_s, model.times.carving_s, model.times.meshing_s, model.times.visibility_s,
      model.times.clean_up_s);
  LogInfo(times);
  if (!pair_ms_.empty()) {
    std::snprintf(times, sizeof(times),
                  "dense pairs: %zu, wall time per pair (pair matches + dense pair) p50 %.1f ms, "
                  "p90 %.1f ms (of the last %zu), max %.1f ms; the dense pair alone p50 %.1f ms, p90 %.1f ms; "
                  "epipolar searches %lld, of which every step scored %lld",
                  pair_ms_.total(), Percentile(pair_ms_.values(), 0.5), Percentile(pair_ms_.values(), 0.9),
                  pair_ms_.values().size(), pair_ms_.max(), Percentile(dense_ms_.values(), 0.5),
                  Percentile(dense_ms_.values(), 0.9), static_cast<long long>(refine_searches_),
                  static_cast<long long>(refine_full_searches_));
    LogInfo(times);
  }
}

void DenseModelerNode::ReportFinalState(const FinalModel& model, int64_t start_us) {
  status_.SetValue("final_ms", (MonotonicMicros() - start_us) * 1e-3);
  status_.SetValue("final_voxels", static_cast<double>(model.voxels.size()));
  status_.SetValue("final_seeds", static_cast<double>(model.seeds));
  status_.SetValue("final_triangles", static_cast<double>(model.mesh.triangles.size()));
  status_.SetValue("final_floor_band_dropped", static_cast<double>(model.floor_band_dropped));
  status_.SetValue("final_crevice_band_dropped", static_cast<double>(model.crevice_band_dropped));
  status_.SetValue("final_carved", static_cast<double>(model.carving.removed));
  status_.SetValue("final_hidden_vertices", static_cast<double>(model.visibility.vertices_removed));
  status_.SetValue("final_curled_triangles", static_cast<double>(model.ridge.curled_triangles_dropped));
  status_.SetValue("final_voxels_off_mesh", static_cast<double>(model.voxels_without_mesh));
  status_.SetValue("final_weak_vertices", static_cast<double>(model.weak_refit.weak));
  status_.SetValue("final_weak_moved", static_cast<double>(model.weak_refit.moved));
  status_.SetValue("final_rim_vertices_removed", static_cast<double>(model.weak_refit.rim_vertices_dropped));
  status_.SetValue("final_carving_s", model.times.carving_s);
  status_.SetValue("final_visibility_s", model.times.visibility_s);
  if (model.voxels.empty()) {
    // Loud: a run that ends without a model is a failure, not a success with empty files (the session fails on it).
    std::string why;
    if (options_.require_target && !have_box_) {
      why = "the final model is empty: no target was ever confirmed on " + options_.target_channel + " (" +
            std::to_string(pairs_before_target_) +
            " dense pairs waited for it); see the planner's and the object finder's status for why, and try more "
            "frames (objscan run --frames)";
    } else {
      why = "the final model is empty: " + std::to_string(pairs_done_) + " dense pairs";
      if (options_.require_target)
        why += " after the target was confirmed (" + std::to_string(pairs_before_target_) + " before)";
      why += " voted nothing inside the region; try more frames or more views of the object (objscan run --frames), "
             "and check the region of interest in logs/dense_modeler.log";
    }
    LogError(why);
    status_.SetState(+process_status_t::STATE_ERROR, why);
  } else if (const std::string inconsistent = CheckMapConsistency(); !inconsistent.empty()) {
    LogError(inconsistent);
    status_.SetState(+process_status_t::STATE_ERROR, inconsistent);
  } else {
    status_.SetState(+process_status_t::STATE_FINISHED, "model written");
  }
  status_.PublishIfDue(WallTimeMicros(), true);
}

std::string DenseModelerNode::CheckMapConsistency() {
  status_.SetValue("final_floor_thickness_mm", -1);
  status_.SetValue("final_floor_local_thickness_mm", -1);
  status_.SetValue("final_floor_points", 0);
  if (!region_.valid || !region_.has_floor || !landmarks_final_) return "";
  if (!final_votes_from_final_poses_) {  // region_ is the live one: a ring around it need not be the target's
    LogInfo("map consistency: not measured (the live votes were kept: the region is in the live frame)");
    return "";
  }
  const Eigen::Vector3d centre = 0.5 * (region_.box_min + region_.box_max);
  const double half_diagonal = 0.5 * (region_.box_max - region_.box_min).head<2>().norm();
  const FloorThicknessOptions options;
  const FloorThickness floor = MeasureFloorThickness(landmark_points_, centre, region_.floor, half_diagonal, options);
  status_.SetValue("final_floor_points", floor.points);
  if (!floor.measured) {
    LogInfo("map consistency: not measured (" + std::to_string(floor.points) +
            " floor landmarks around the target, " + std::to_string(options.min_points) + " needed)");
    return "";
  }
  status_.SetValue("final_floor_thickness_mm", floor.thickness_mm());
  status_.SetValue("final_floor_local_thickness_mm", floor.local_thickness_mm);
  char text[700];
  std::snprintf(text, sizeof(text),
                "the floor around the target is %.1f mm thick in the final map (p10 %.1f, p90 %.1f mm above the "
                "region's floor, %d floor landmarks %.0f-%.0f mm from the target), %.1f mm within a %.0f mm cell "
                "(median of %d cells)",
                floor.thickness_mm(), floor.p10_mm, floor.p90_mm, floor.points, floor.inner_radius_mm,
                floor.inner_radius_mm + options.ring_width_mm, floor.local_thickness_mm, options.cell_mm, floor.cells);
  if (!IsMetric(scale_source_) || !floor.Inconsistent(options)) {
    LogInfo(std::string("map consistency: ") + text);
    return "";
  }
  return std::string("the map is inconsistent around the target: ") + text +
         "; where the model held, room runs gave at most 4.7 mm and 4.1 mm in a cell. The passes of the run disagree "
         "(a map restart that was never joined, drift between the exploration and the orbit: see "
         "logs/pose_solver.log), so the model built from them is distorted (room runs: mesh p90 3-30 mm). The model "
         "files are written; do not trust them: run again (a start facing open floor, or a smaller room), and check "
         "the pose solver's restarts";
}

void DenseModelerNode::RunFinalPhase(int64_t utime) {
  if (finished_) return;
  const int64_t start_us = MonotonicMicros();
  UpdateRegion(true);
  RunWaitingPairs(true);
  if (region_.valid) {
    std::ostringstream r;
    r << "region of interest (source " << region_source_ << "): box [" << region_.box_min.transpose() << "] .. ["
      << region_.box_max.transpose() << "] mm";
    if (region_.has_floor)
      r << ", floor normal [" << region_.floor.normal.transpose() << "] offset " << region_.floor.offset_mm
        << " mm (height = normal.x + offset)";
    LogInfo(r.str());
  } else {
    LogWarning("no region of interest: the model is not restricted");
  }
  // Carving and the mesh's views take the poses the votes were cast with: the final ones when the votes were
  // recomputed with them, else the live ones (a grid from live poses carved with final ones in another frame lost
  // 80 % of room_01's target).
  const bool use_final_poses = RevoteWithFinalPoses();
  final_votes_from_final_poses_ = use_final_poses;
  std::vector<CarvingView> views;
  int final_used = 0;
  int other_map_views = 0;
  for (const StoredView& sv : carving_views_) {
    CarvingView v = sv.view;
    auto it = final_poses_.find(sv.seq);
    auto map = final_map_of_.find(sv.seq);
    if (use_final_poses && model_map_start_seq_ >= 0 && map != final_map_of_.end() && map->second >= 0 &&
        map->second != model_map_start_seq_) {
      ++other_map_views;  // in another frame than the votes: it would carve the model where it does not see it
      continue;
    }
    if (use_final_poses && it != final_poses_.end()) {
      v.world_from_camera = it->second;
      ++final_used;
    }
    views.push_back(std::move(v));
  }
  final_poses_used_ = final_used;
  if (other_map_views > 0)
    LogInfo("carving: " + std::to_string(other_map_views) + " views of the other maps left out");
  ReportLiveFinalOffset(use_final_poses);
  const FinalModel model = BuildFinalModel(grid_, views, options_.model, region_);
  LogFinalModel(model, views.size(), final_used);
  ModelPaths paths;
  if (!options_.output_dir.empty()) {
    std::string error;
    if (!WriteModelFiles(options_.output_dir, model, grid_.voxel_size(), scale_source_, &paths, &error)) {
      LogError("writing the model failed: " + error);
      paths = ModelPaths{};
    }
  }
  std::vector<VoxelRecord> final_records;
  for (const CarvedVoxel& v : model.voxels) {
    VoxelRecord r;
    r.ijk = v.ijk;
    r.votes = v.votes;
    r.bgr = v.bgr;
    final_records.push_back(r);
  }
  const int64_t data_utime = last_seq_ >= 0 ? last_utime_ : utime;
  PublishVoxelMap(data_utime, last_seq_, true, &final_records);
  model_t m;
  m.utime = data_utime;
  m.voxels_ply_path = paths.voxels_ply;
  m.mesh_ply_path = paths.mesh_ply;
  m.octomap_path = paths.octomap;
  m.voxel_size_mm = grid_.voxel_size();
  m.num_voxels = static_cast<int32_t>(model.voxels.size());
  m.num_voxels_carved = static_cast<int32_t>(model.carving.removed);
  m.num_mesh_triangles = static_cast<int32_t>(model.mesh.triangles.size());
  m.num_views = static_cast<int32_t>(views.size());
  for (int k = 0; k < 3; ++k) {
    m.bbox_min_mm[k] = model.bbox_min[k];
    m.bbox_max_mm[k] = model.bbox_max[k];
  }
  if (bus_.PublishMessage(options_.model_channel, m)) status_.CountOut();
  PublishFinished(bus_, status_, options_.control_channel, options_.name, data_utime, last_seq_,
                  paths.voxels_ply.empty() ? "" : options_.output_dir);
  finished_ = true;
  ReportFinalState(model, start_us);
}

bool DenseModelerNode::SaveSnapshot(const std::string& path) {
  std::string error;
  std::error_code ec;
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  if (!grid_.SaveSnapshot(path, &error)) {
    status_.Reject("snapshot: write failed", error);
    return false;
  }
  LogInfo("vote snapshot written to " + path);
  return true;
}

void DenseModelerNode::OnControl(const control_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "control")) return;  // another session on the bus
  if (!msg.target.empty() && msg.target != "*" && msg.target != options_.name) return;
  if (msg.command == control_t::COMMAND_SNAPSHOT) {
    status_.CountIn();
    std::string path = msg.argument;
    if (path.empty() && !options_.output_dir.empty())
      path = (std::filesystem::path(options_.output_dir) / "votes_snapshot.bin").string();
    if (path.empty()) {
      status_.Reject("snapshot: no path", "neither argument nor output-dir");
      return;
    }
    SaveSnapshot(path);
    return;
  }
  const bool finish = (msg.command == control_t::COMMAND_FINISHED && msg.sender == options_.finish_sender) ||
                      IsFinalizeRequest(msg, options_.name);
  if (!finish) return;
  status_.CountIn();
  if (finished_) return;  // answered already
  LogInfo("final phase requested by " + msg.sender + (msg.argument.empty() ? "" : " (" + msg.argument + ")"));
  RunFinalPhase(msg.utime);
}

void DenseModelerNode::Tick(int64_t wall_utime) { status_.PublishIfDue(wall_utime); }

void DenseModelerNode::OnShutdown() {
  if (!options_.output_dir.empty())
    SaveSnapshot((std::filesystem::path(options_.output_dir) / "votes_snapshot.bin").string());
  status_.PublishIfDue(WallTimeMicros(), true);
}

}  // namespace objscan

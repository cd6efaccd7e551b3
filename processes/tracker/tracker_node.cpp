#include "processes/tracker/tracker_node.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/log.h"
#include "common/options.h"
#include "common/time.h"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/process_status_t.hpp"

namespace objscan {

void AddTrackerNodeOptions(OptionParser& p, TrackerNodeOptions* o) {
  // Only what a user sets (issue 27): plumbing, the image queue and threads, and the descriptor tracking of the
  // wide-baseline profile (scripts/profiles). Every other field keeps its default here (the status period, the KLT
  // track budget, corner quality and LK window among them); tests and tools set the struct directly.
  p.Add("name", &o->name, "process name (status name, sender of control messages)");
  p.AddChannel(&o->image_channel, "input image channel (image_t)");
  p.AddChannel(&o->info_channel, "optional camera_info_t channel that fixes the image size (\"\" = ignore)");
  p.AddChannel(&o->tracks_channel, "output channel for feature_tracks_t");
  p.AddChannel(&o->control_channel, "control_t channel (end of stream in, finished out)");
  p.AddChannel(&o->status_channel, "process_status_t channel");
  p.Add("image-queue-capacity", &o->image_queue_capacity, "frames buffered by the image subscription (>= 1)");
  p.Add("exit-when-finished", &o->exit_when_finished, "exit after answering end of stream");
  KltTrackerOptions* k = &o->tracker;
  p.Add("threads", &k->threads, "OpenCV threads (cv::setNumThreads)");
  p.Add("descriptor-tracking", &o->descriptor_tracking,
        "off (KLT) | on (descriptor matching only, wide-baseline image sets) | auto (KLT, switch to descriptors "
        "when KLT continues < descriptor_auto_keep_fraction of the tracks)");
  p.Add("descriptor-kind", &o->descriptor_kind, "sift | akaze | orb");
  DescriptorTrackerOptions* d = &o->descriptor;
  p.Add("descriptor-max-features", &d->max_features, "keypoints kept per frame (strongest first)");
  p.Add("descriptor-sift-contrast", &d->sift_contrast_threshold, "SIFT contrast threshold (lower = more keypoints)");
  p.Add("descriptor-history", &d->history_frames, "earlier frames matched against (2 = also the one before), [1, 10]");
}

bool ValidateTrackerNodeOptions(const TrackerNodeOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.name.empty()) e << "name must not be empty; ";
  if (o.image_channel.empty()) e << "image-channel must not be empty; ";
  if (o.tracks_channel.empty()) e << "tracks-channel must not be empty; ";
  if (o.control_channel.empty()) e << "control-channel must not be empty; ";
  if (o.status_channel.empty()) e << "status-channel must not be empty; ";
  if (o.image_queue_capacity < 1) e << "image-queue-capacity must be >= 1; ";
  if (!(o.status_period_s > 0.0) || !std::isfinite(o.status_period_s)) e << "status_period_s must be > 0; ";
  std::string tracker_why;
  if (!ValidateKltTrackerOptions(o.tracker, &tracker_why)) e << tracker_why << "; ";
  if (o.descriptor_tracking != "off" && o.descriptor_tracking != "on" && o.descriptor_tracking != "auto")
    e << "descriptor-tracking must be off, on or auto; ";
  DescriptorKind kind;
  if (!ParseDescriptorKind(o.descriptor_kind, &kind)) e << "descriptor-kind must be sift, akaze or orb; ";
  if (!(o.descriptor_auto_keep_fraction > 0 && o.descriptor_auto_keep_fraction < 1))
    e << "descriptor_auto_keep_fraction must be in (0, 1); ";
  std::string descriptor_why;
  if (!ValidateDescriptorTrackerOptions(o.descriptor, &descriptor_why)) e << "descriptor: " << descriptor_why << "; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

namespace {
const TrackerNodeOptions& ValidatedOrThrow(const TrackerNodeOptions& o) {
  std::string why;
  if (!ValidateTrackerNodeOptions(o, &why)) throw std::invalid_argument("tracker node: " + why);
  return o;
}
}  // namespace

TrackerNode::TrackerNode(Bus& bus, const TrackerNodeOptions& options)
    : bus_(bus),
      options_(ValidatedOrThrow(options)),
      tracker_(options_.tracker),
      status_(&bus, options_.name, options_.status_channel, options_.status_period_s) {
  if (options_.descriptor_tracking != "off") {
    DescriptorTrackerOptions d = options_.descriptor;
    ParseDescriptorKind(options_.descriptor_kind, &d.kind);  // validated above
    d.threads = options_.tracker.threads;
    descriptor_ = std::make_unique<DescriptorTracker>(d);
    descriptor_active_ = options_.descriptor_tracking == "on";
  }
  status_.SetState(+process_status_t::STATE_STARTING, "waiting for images on " + options_.image_channel);
  bus_.SubscribeMessage<image_t>(
      options_.image_channel, [this](const image_t& msg, const RawMessage&) { OnImage(msg); },
      status_.MalformedHandler("image"), options_.image_queue_capacity);
  if (!options_.info_channel.empty()) {
    bus_.SubscribeMessage<camera_info_t>(
        options_.info_channel, [this](const camera_info_t& msg, const RawMessage&) { OnCameraInfo(msg); },
        status_.MalformedHandler("camera_info"));
  }
  bus_.SubscribeMessage<control_t>(
      options_.control_channel, [this](const control_t& msg, const RawMessage&) { OnControl(msg); },
      status_.MalformedHandler("control"));
}

void TrackerNode::OnCameraInfo(const camera_info_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "camera_info")) return;  // another session on the bus
  PinholeCamera camera;
  std::string error;
  if (!CameraFromMessage(msg, &camera, &error)) {
    status_.Reject(error, "camera " + msg.camera_name);
    return;
  }
  status_.CountIn();
  if (!size_from_info_ || camera.width != expected_width_ || camera.height != expected_height_) {
    if (expected_width_ > 0 && (camera.width != expected_width_ || camera.height != expected_height_))
      LogWarning("camera_info size " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                 " replaces " + std::to_string(expected_width_) + "x" + std::to_string(expected_height_));
    expected_width_ = camera.width;
    expected_height_ = camera.height;
    size_from_info_ = true;
  }
}

void TrackerNode::OnImage(const image_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "image")) return;  // another session on the bus
  const int64_t start_us = MonotonicMicros();
  ImageFrame frame;
  std::string error;
  if (!ImageFromMessage(msg, &frame, &error, expected_width_, expected_height_)) {
    std::string detail = "seq " + std::to_string(msg.seq) + ", " + std::to_string(msg.width) + "x" +
                         std::to_string(msg.height) + " encoding " + std::to_string(static_cast<int>(msg.encoding));
    if (expected_width_ > 0)
      detail += ", expected " + std::to_string(expected_width_) + "x" + std::to_string(expected_height_) +
                (size_from_info_ ? " (camera_info)" : " (first frame)");
    status_.Reject(error, detail, "image", msg.seq);  // received, not dropped
    return;
  }
  // Only a usable image moves the stream's sequence on (a rejected one with a wild seq must not block the rest).
  if (!status_.AcceptSeq("image", msg.seq, "image")) return;
  status_.CountIn();
  status_.SetLastDataUtime(msg.utime);
  if (expected_width_ == 0) {
    expected_width_ = frame.image.cols;
    expected_height_ = frame.image.rows;
  }
  if (frames_tracked_ == 0 && msg.seq > 0) {
    // Joining a stream under way (a restarted tracker, a log cut): track ids from seq << 32, above every id a
    // tracker that started at an earlier frame can have given (it would need 2^32 tracks per frame between), so
    // the pose solver never takes a new track for an old one. A stream from seq 0 keeps ids 0, 1, 2, ...
    tracker_.set_first_id(msg.seq << 32);
    LogInfo("first frame seq " + std::to_string(msg.seq) + ": joining a stream under way, track ids from " +
            std::to_string(msg.seq << 32));
  }
  TrackFrame tracks;
  const int64_t track_start_us = MonotonicMicros();
  try {
    if (descriptor_active_) {
      tracks = descriptor_->Track(frame);
    } else {
      tracks = tracker_.Track(frame);
      if (descriptor_) {  // auto: KLT until it cannot follow the motion
        const KltTrackStats& k = tracker_.last_stats();
        const bool switch_now = frames_tracked_ > 0 && !k.reset && previous_live_ >= 20 &&
                                previous_live_ - k.lost < options_.descriptor_auto_keep_fraction * previous_live_;
        if (switch_now)
          LogInfo("KLT continued " + std::to_string(previous_live_ - k.lost) + " of " + std::to_string(previous_live_) +
                  " tracks at seq " + std::to_string(msg.seq) + ": switching to descriptor tracking (" +
                  options_.descriptor_kind + ")");
        previous_live_ = k.live;
        if (switch_now) {
          descriptor_->set_first_id(tracker_.next_id());
          for (const ImageFrame& f : recent_frames_) descriptor_->Track(f);
          recent_frames_.clear();
          descriptor_active_ = true;
          tracks = descriptor_->Track(frame);
        } else {
          recent_frames_.push_back(frame);
          while (static_cast<int>(recent_frames_.size()) > options_.descriptor.history_frames)
            recent_frames_.pop_front();
        }
      }
    }
  } catch (const std::exception& e) {  // cannot happen for a decoded frame; never let it stop the process
    status_.Reject("image: tracker error", e.what());
    return;
  }
  const double track_ms = (MonotonicMicros() - track_start_us) * 1e-3;
  if (bus_.PublishMessage(options_.tracks_channel, TracksToMessage(tracks)))
    status_.CountOut();
  else
    LogWarning("publishing on " + options_.tracks_channel + " failed");
  last_seq_ = msg.seq;
  last_utime_ = msg.utime;
  ++frames_tracked_;
  if (!descriptor_active_) {
    const KltTrackStats& s = tracker_.last_stats();
    status_.SetValue("live_tracks", s.live);
    status_.SetValue("new_tracks", s.born);
    status_.SetValue("lost_tracks", s.lost);
    status_.SetValue("track_ms", track_ms);
    status_.SetValue("lk_ms", s.lk_ms);
    status_.SetValue("detect_ms", s.detect_ms);
    status_.SetValue("refine_ms", s.refine_ms);
    status_.SetValue("anchor_rejected", s.anchor_rejected);
    status_.SetValue("reanchored", s.reanchored);
  } else {
    status_.SetValue("live_tracks", static_cast<double>(tracks.features.size()));
    status_.SetValue("new_tracks", descriptor_->last_stats().born);
    status_.SetValue("track_ms", track_ms);
  }
  status_.SetValue("frames_tracked", static_cast<double>(frames_tracked_));
  if (descriptor_) {
    status_.SetValue("descriptor_active", descriptor_active_ ? 1.0 : 0.0);
    if (descriptor_active_) {
      const DescriptorTrackStats& d = descriptor_->last_stats();
      status_.SetValue("descriptor_keypoints", d.keypoints);
      status_.SetValue("descriptor_continued", d.continued);
      status_.SetValue("descriptor_ms", d.detect_ms + d.match_ms);
    }
  }
  if (!finished_ && status_.state() != +process_status_t::STATE_RUNNING)
    status_.SetState(+process_status_t::STATE_RUNNING);
  status_.RecordLatencyMs((MonotonicMicros() - start_us) * 1e-3);
}

void TrackerNode::OnControl(const control_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "control")) return;  // another session on the bus
  if (!IsFinalizeRequest(msg, options_.name)) {
    if (msg.command != control_t::COMMAND_END_OF_STREAM) return;  // other commands are not for the tracker
    if (!msg.target.empty() && msg.target != "*" && msg.target != options_.name) return;
  }
  status_.CountIn();
  if (finished_) return;  // answered already
  LogInfo("end of stream from " + msg.sender + " (last_seq " + std::to_string(msg.last_seq) + "), tracked " +
          std::to_string(frames_tracked_) + " frames, last seq " + std::to_string(last_seq_));
  PublishFinished(bus_, status_, options_.control_channel, options_.name, last_seq_ >= 0 ? last_utime_ : msg.utime,
                  last_seq_);
  finished_ = true;
  status_.SetState(+process_status_t::STATE_FINISHED, "end of stream answered");
  status_.PublishIfDue(WallTimeMicros(), true);
}

void TrackerNode::Tick(int64_t wall_utime) { status_.PublishIfDue(wall_utime); }

void TrackerNode::OnShutdown() { status_.PublishIfDue(WallTimeMicros(), true); }

}  // namespace objscan

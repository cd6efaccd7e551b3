// TrackerNode: the "tracker" process. Subscribes CAMERA_IMAGE (and optionally CAMERA_INFO), runs the KLT tracker on
// every good frame and publishes one feature_tracks_t per frame on FEATURE_TRACKS (utime/seq/camera_name copied
// from the image). Bad input is rejected and counted in PROCESS_STATUS (the node never stops on it):
//   "image: malformed"                 message on the image channel that does not decode as image_t
//   "image: out of order or repeated"  seq <= the last seq seen (seq gaps count as dropped inputs instead)
//   "image: implausible seq jump"      seq far from the stream's (common/status.h SeqResult): one forged seq never
//                                      blocks the stream; three consecutive ones are a new run and followed
//   "image: wrong size"                size differs from CAMERA_INFO (when received) or from the first good frame
//   "image: unknown encoding" / "image: truncated data" / "image: bad stride" / "image: bad size" /
//   "image: undecodable jpeg" / "image: jpeg size mismatch"   (from common/adapters.h ImageFromMessage)
//   "camera_info: malformed" and the CameraFromMessage reasons, "control: malformed"
// End of stream: control_t COMMAND_END_OF_STREAM on OBJSCAN_CONTROL (target "*", "" or this process) makes it
// publish control_t COMMAND_FINISHED (sender = process name, last_seq = seq of the last frame tracked, -1 if none,
// utime = that frame's utime) and, with exit_when_finished, Finished() becomes true.
// Status values: live_tracks, new_tracks, lost_tracks, track_ms, lk_ms, detect_ms (wall clock), frames_tracked;
// with descriptor tracking also descriptor_active (0/1), descriptor_keypoints, descriptor_continued, descriptor_ms.
// Descriptor tracking (descriptor_seeding.h), option descriptor_tracking:
//   "off"  (default) KLT only.
//   "on"   descriptor tracks only (SIFT/AKAZE/ORB matching against the last frames): wide-baseline image sets
//          (turntables, Middlebury rings) where KLT cannot follow the steps.
//   "auto" KLT until the first frame in which KLT continues fewer than descriptor_auto_keep_fraction of the previous
//          frame's tracks (>= 20 tracks before), then descriptor tracks for the rest of the stream (latched). The
//          descriptor tracker is primed with the frames kept since then (descriptor.history_frames), so its tracks
//          continue theirs, but those frames were published with KLT ids: downstream the switch looks like a
//          fresh set of tracks. Descriptor ids start above every KLT id (never reused).
// Handlers run inside Bus::Handle() on the caller's thread; not thread-safe.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include "common/node.h"
#include "common/status.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/image_t.hpp"
#include "processes/tracker/descriptor_seeding.h"
#include "processes/tracker/klt_tracker.h"

namespace objscan {

class Bus;
class OptionParser;

struct TrackerNodeOptions {
  std::string name = "tracker";                     // process name (status name, control sender)
  std::string image_channel = "CAMERA_IMAGE";       // input images (image_t)
  std::string info_channel = "CAMERA_INFO";         // optional camera calibration (camera_info_t); "" = ignore
  std::string tracks_channel = "FEATURE_TRACKS";    // output tracks (feature_tracks_t)
  std::string control_channel = "OBJSCAN_CONTROL";  // end of stream in, finished out (control_t)
  std::string status_channel = "PROCESS_STATUS";    // process status (process_status_t)
  int image_queue_capacity = 30;                    // frames the image subscription buffers before dropping (>= 1)
  double status_period_s = 1.0;                     // s, status publication period (> 0)
  bool exit_when_finished = true;                   // Finished() turns true after end of stream was answered
  KltTrackerOptions tracker;                        // the KLT tracker's options
  std::string descriptor_tracking = "off";          // "off" | "on" | "auto" (see above)
  std::string descriptor_kind = "sift";             // "sift" | "akaze" | "orb" (overrides descriptor.kind)
  double descriptor_auto_keep_fraction = 0.2;       // auto: switch when KLT continues fewer than this fraction of
                                                    // the previous frame's tracks, (0, 1)
  DescriptorTrackerOptions descriptor;              // the descriptor tracker's options (kind and threads are
                                                    // taken from descriptor_kind and tracker.threads)
};

// Registers the options a user sets on the command line (KLT options with prefix "klt-"; the rest keep their
// defaults: code and tests set the struct's fields directly).
void AddTrackerNodeOptions(OptionParser& parser, TrackerNodeOptions* options);
// True when usable; otherwise false with *why set.
bool ValidateTrackerNodeOptions(const TrackerNodeOptions& options, std::string* why);

class TrackerNode : public Node {
 public:
  // Subscribes on bus (which must outlive the node). Throws std::invalid_argument on invalid options.
  TrackerNode(Bus& bus, const TrackerNodeOptions& options);

  void Tick(int64_t wall_utime) override;
  bool Finished() const override { return finished_ && options_.exit_when_finished; }
  void OnShutdown() override;

  const StatusReporter& status() const { return status_; }
  // True once end of stream has been answered (independent of exit_when_finished).
  bool end_of_stream_answered() const { return finished_; }
  int64_t last_tracked_seq() const { return last_seq_; }

 private:
  void OnImage(const image_t& msg);
  void OnCameraInfo(const camera_info_t& msg);
  void OnControl(const control_t& msg);

  Bus& bus_;
  TrackerNodeOptions options_;
  KltTracker tracker_;
  std::unique_ptr<DescriptorTracker> descriptor_;  // null with descriptor_tracking "off"
  bool descriptor_active_ = false;                 // descriptor tracks are published ("on", or "auto" after the switch)
  std::deque<ImageFrame> recent_frames_;           // "auto" before the switch: the last frames, to prime the tracker
  int previous_live_ = 0;                          // KLT tracks of the previous frame
  StatusReporter status_;
  int expected_width_ = 0;   // px, from CAMERA_INFO or the first good frame (0 = unknown yet)
  int expected_height_ = 0;  // px
  bool size_from_info_ = false;
  int64_t last_seq_ = -1;   // seq of the last frame tracked
  int64_t last_utime_ = 0;  // utime of the last frame tracked
  int64_t frames_tracked_ = 0;
  bool finished_ = false;
};

}  // namespace objscan

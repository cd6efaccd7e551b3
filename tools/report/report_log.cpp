#include "tools/report/report_log.h"

#include <cmath>
#include <map>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/lcm_log.h"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/pose_t.hpp"

namespace objscan {

bool ReadFrameSeries(const std::string& log_path, FrameSeries* frames, std::vector<StampedPose>* truth,
                     std::string* damage, std::string* error) {
  *frames = FrameSeries{};
  if (truth) truth->clear();
  LcmLogReader log;
  if (!log.Open(log_path, error)) return false;
  struct Frame {
    int64_t utime = 0, image_logged_us = -1, tracks_logged_us = -1, pose_logged_us = -1;
    int tracks = -1;
  };
  std::map<int64_t, Frame> by_seq;
  LcmLogEvent e;
  while (log.Next(&e)) {
    const int size = static_cast<int>(e.data.size());
    int64_t seq = 0, utime = 0;
    if (!RawMessageSeq(e.data.data(), size, &seq) || !RawMessageUtime(e.data.data(), size, &utime)) continue;
    if (e.channel == "CAMERA_IMAGE") {
      Frame& f = by_seq[seq];
      if (f.image_logged_us >= 0) continue;  // a repeated seq (a restarted driver): keep the first
      f.utime = utime;
      f.image_logged_us = e.timestamp_us;
    } else if (e.channel == "FEATURE_TRACKS") {
      auto it = by_seq.find(seq);
      if (it == by_seq.end() || it->second.tracks_logged_us >= 0) continue;
      feature_tracks_t msg;
      if (!DecodeMessage(e.data.data(), size, &msg, nullptr)) continue;
      it->second.tracks = msg.num_tracks;
      it->second.tracks_logged_us = e.timestamp_us;
    } else if (e.channel == "GROUND_TRUTH_POSE" && truth) {
      pose_t msg;
      CameraPoseEstimate pose;
      std::string why;
      if (DecodeMessage(e.data.data(), size, &msg, nullptr) && PoseFromMessage(msg, &pose, &why))
        truth->push_back({utime * 1e-6, pose.world_from_camera});
    } else if (e.channel == "CAMERA_POSE") {
      auto it = by_seq.find(seq);
      if (it != by_seq.end() && it->second.pose_logged_us < 0) it->second.pose_logged_us = e.timestamp_us;
    }
  }
  *damage = log.damage().Describe();
  for (const auto& [seq, f] : by_seq) {
    if (f.image_logged_us < 0) continue;
    frames->t_s.push_back(f.utime * 1e-6);
    frames->tracks.push_back(f.tracks);
    frames->tracks_latency_ms.push_back(f.tracks_logged_us >= 0 ? (f.tracks_logged_us - f.image_logged_us) * 1e-3
                                                                 : std::nan(""));
    frames->pose_latency_ms.push_back(f.pose_logged_us >= 0 ? (f.pose_logged_us - f.image_logged_us) * 1e-3
                                                             : std::nan(""));
  }
  return true;
}

}  // namespace objscan

// Checks of a received message's declared array sizes against its byte count, before decoding: LCM's generated C++
// decoders resize each array from its count field before checking it against the buffer, so a corrupted count
// allocates and zero-fills up to gigabytes before the decode fails. These walk the raw bytes (LCM encoding: 8-byte
// type hash, big-endian fields, strings as int32 length incl. the NUL, then the bytes) without allocating.
// They return false with *why ("wrong type", "truncated", "declared 1000000 landmarks in 120 bytes") and never throw.
// SubscribeChecked subscribes with such a check in front of the decode (rejections counted as "<what>: malformed").
// The checks cover the types the object finder and the planner take (issue 28 extends them to every input).
#pragma once

#include <exception>
#include <string>

#include "common/bus.h"
#include "common/status.h"

namespace objscan {

// landmarks_t: hash, utime, seq, frame, num_landmarks n >= 0, then exactly 31 * n bytes (id 8, position 12,
// num_observations 4, reprojection_error_px 4, rgb 3 per landmark).
bool CheckLandmarksMessageSize(const void* data, int size, std::string* why);

// camera_info_t: hash, utime, camera_name, width, height, fx fy cx cy skew, distortion_model, num_distortion n >= 0,
// then exactly 8 * n bytes.
bool CheckCameraInfoMessageSize(const void* data, int size, std::string* why);

// voxel_map_t: hash, utime, seq, frame, voxel_size_mm, origin_mm[3], vote_threshold, is_final, truncated,
// num_voxels n >= 0, then exactly 19 * n bytes (ijk 12, votes 4, rgb 3 per voxel).
bool CheckVoxelMapMessageSize(const void* data, int size, std::string* why);

// Subscribes handler(const Msg&) to channel; a message that fails check or does not decode to its whole size is
// rejected on status as "<what>: malformed" (with the reason and channel) and never reaches the handler. status
// must outlive the subscription. queue_capacity as in Bus::Subscribe (0 = the bus default).
template <class Msg, class Handler>
void SubscribeChecked(Bus& bus, StatusReporter& status, const std::string& channel, const std::string& what,
                      bool (*check)(const void*, int, std::string*), Handler handler, int queue_capacity = 0) {
  bus.Subscribe(
      channel,
      [&status, what, check, handler](const RawMessage& raw) {
        std::string why;
        bool ok = check(raw.data, raw.size, &why);
        Msg msg;
        if (ok) {
          try {
            ok = msg.decode(raw.data, 0, raw.size) == raw.size;
          } catch (const std::exception&) {
            ok = false;
          }
          if (!ok) why = "does not decode (" + std::to_string(raw.size) + " bytes)";
        }
        if (!ok) {
          status.Reject(what + ": malformed", why + " on " + raw.channel);
          return;
        }
        handler(msg);
      },
      queue_capacity);
}

}  // namespace objscan

// One guarded decode for every bus message, in every process and tool. LCM's generated C++ decoders resize each
// array from its count field before checking it against the buffer, so a corrupted or forged count allocates and
// zero-fills up to gigabytes before the decode fails (and a string length of 0 or less throws). The checks here walk
// the raw bytes of the types with variable-length arrays (LCM encoding: 8-byte type hash, big-endian fields, strings
// as int32 length incl. the NUL, then the bytes) without allocating; DecodeMessage runs the type's check, then the
// decode inside a try, and wants the whole message consumed.
// They return false with *why ("wrong type", "truncated", "declared 1000000 landmarks in 120 bytes",
// "does not decode as pose_t (60 bytes)") and never throw. No bus dependency (common/bus.h uses this).
#pragma once

#include <exception>
#include <string>

namespace objscan {

class camera_info_t;
class feature_tracks_t;
class image_t;
class landmarks_t;
class process_status_t;
class procman_deputy_t;
class procman_orders_t;
class voxel_map_t;

// landmarks_t: hash, utime, seq, frame, num_landmarks n >= 0, then exactly 31 * n bytes (id 8, position 12,
// num_observations 4, reprojection_error_px 4, rgb 3 per landmark).
bool CheckLandmarksMessageSize(const void* data, int size, std::string* why);

// camera_info_t: hash, utime, camera_name, width, height, fx fy cx cy skew, distortion_model, num_distortion n >= 0,
// then exactly 8 * n bytes.
bool CheckCameraInfoMessageSize(const void* data, int size, std::string* why);

// voxel_map_t: hash, utime, seq, frame, voxel_size_mm, origin_mm[3], vote_threshold, is_final, truncated,
// num_voxels n >= 0, then exactly 19 * n bytes (ijk 12, votes 4, rgb 3 per voxel).
bool CheckVoxelMapMessageSize(const void* data, int size, std::string* why);

// feature_tracks_t: hash, utime, seq, camera_name, image_width, image_height, num_tracks n >= 0, then exactly 20 * n
// bytes (track_id 8, u 4, v 4, age 4 per track).
bool CheckFeatureTracksMessageSize(const void* data, int size, std::string* why);

// image_t: hash, utime, seq, camera_name, width, height, stride, encoding, size n >= 0, then exactly n bytes.
bool CheckImageMessageSize(const void* data, int size, std::string* why);

// process_status_t: the header fields, num_rejection_reasons n >= 0 with n strings and 8 * n bytes, four fixed
// fields, num_values m >= 0 with m strings and 8 * m bytes, and nothing after.
bool CheckProcessStatusMessageSize(const void* data, int size, std::string* why);

// procman_orders_t: hash, utime, seq, 3 strings, num_processes n >= 0, n strings, then exactly 6 * n bytes.
bool CheckProcmanOrdersMessageSize(const void* data, int size, std::string* why);
// procman_deputy_t: hash, utime, seq, 2 strings, 2 counters, 1 string, num_processes n >= 0, 3 * n strings, then
// exactly 42 * n bytes.
bool CheckProcmanDeputyMessageSize(const void* data, int size, std::string* why);

// The check of a type: the ones above, none (true) for types without variable-length arrays.
template <class Msg>
bool CheckMessageSize(const Msg*, const void*, int, std::string*) {
  return true;
}
inline bool CheckMessageSize(const landmarks_t*, const void* d, int n, std::string* w) {
  return CheckLandmarksMessageSize(d, n, w);
}
inline bool CheckMessageSize(const camera_info_t*, const void* d, int n, std::string* w) {
  return CheckCameraInfoMessageSize(d, n, w);
}
inline bool CheckMessageSize(const voxel_map_t*, const void* d, int n, std::string* w) {
  return CheckVoxelMapMessageSize(d, n, w);
}
inline bool CheckMessageSize(const feature_tracks_t*, const void* d, int n, std::string* w) {
  return CheckFeatureTracksMessageSize(d, n, w);
}
inline bool CheckMessageSize(const image_t*, const void* d, int n, std::string* w) {
  return CheckImageMessageSize(d, n, w);
}
inline bool CheckMessageSize(const process_status_t*, const void* d, int n, std::string* w) {
  return CheckProcessStatusMessageSize(d, n, w);
}

inline bool CheckMessageSize(const procman_orders_t*, const void* d, int n, std::string* w) {
  return CheckProcmanOrdersMessageSize(d, n, w);
}
inline bool CheckMessageSize(const procman_deputy_t*, const void* d, int n, std::string* w) {
  return CheckProcmanDeputyMessageSize(d, n, w);
}

// Decodes a whole message of type Msg after its size check; false with *why (may be null) otherwise.
template <class Msg>
bool DecodeMessage(const void* data, int size, Msg* msg, std::string* why) {
  std::string local;
  std::string* reason = why ? why : &local;
  if (data == nullptr || size <= 0) {
    *reason = "empty";
    return false;
  }
  if (!CheckMessageSize(static_cast<const Msg*>(nullptr), data, size, reason)) return false;
  bool ok = false;
  try {
    ok = msg->decode(data, 0, size) == size;
  } catch (const std::exception&) {
    ok = false;
  }
  if (!ok) *reason = "does not decode as " + std::string(Msg::getTypeName()) + " (" + std::to_string(size) + " bytes)";
  return ok;
}

}  // namespace objscan

#include "common/message_size_check.h"

#include <cstdint>

#include "objscan/camera_info_t.hpp"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/procman_deputy_t.hpp"
#include "objscan/procman_orders_t.hpp"
#include "objscan/voxel_map_t.hpp"

namespace objscan {

namespace {

// Reads big-endian fields from a byte buffer; every read checks the remaining size first.
class WireReader {
 public:
  WireReader(const void* data, int size) : data_(static_cast<const uint8_t*>(data)), size_(size > 0 ? size : 0) {}
  bool Int64(int64_t* v) {
    if (remaining() < 8) return false;
    uint64_t x = 0;
    for (int i = 0; i < 8; ++i) x = (x << 8) | data_[pos_ + i];
    pos_ += 8;
    *v = static_cast<int64_t>(x);
    return true;
  }
  bool Int32(int32_t* v) {
    if (remaining() < 4) return false;
    uint32_t x = 0;
    for (int i = 0; i < 4; ++i) x = (x << 8) | data_[pos_ + i];
    pos_ += 4;
    *v = static_cast<int32_t>(x);
    return true;
  }
  bool Skip(int64_t bytes) {
    if (bytes < 0 || remaining() < bytes) return false;
    pos_ += bytes;
    return true;
  }
  bool String() {
    int32_t length = 0;
    return Int32(&length) && length >= 1 && Skip(length);
  }
  int64_t remaining() const { return static_cast<int64_t>(size_) - pos_; }

 private:
  const uint8_t* data_;
  int size_;
  int64_t pos_ = 0;
};

bool Fail(std::string* why, const std::string& text) {
  if (why) *why = text;
  return false;
}

// A count field that is >= 0 (for the strings and arrays that follow).
bool Count(WireReader& r, const char* what, int32_t* count, std::string* why) {
  if (!r.Int32(count)) return Fail(why, "truncated");
  if (*count < 0) return Fail(why, "negative " + std::string(what) + " count " + std::to_string(*count));
  return true;
}

// count strings (each at least its 4-byte length: a count beyond remaining / 4 cannot fit), then count * item bytes.
bool Strings(WireReader& r, int32_t count, int64_t bytes_per_item, const char* what, int size, std::string* why) {
  if (count > r.remaining() / 4)
    return Fail(why, "declared " + std::to_string(count) + " " + what + " in " + std::to_string(size) + " bytes");
  for (int32_t i = 0; i < count; ++i)
    if (!r.String()) return Fail(why, "truncated");
  if (!r.Skip(bytes_per_item * count)) return Fail(why, "truncated");
  return true;
}

// The count field, then exactly bytes_per_item * count bytes.
bool CheckArray(WireReader& r, int64_t bytes_per_item, const char* what, int size, std::string* why) {
  int32_t count = 0;
  if (!r.Int32(&count)) return Fail(why, "truncated");
  if (count < 0) return Fail(why, "negative " + std::string(what) + " count " + std::to_string(count));
  if (r.remaining() != bytes_per_item * count)
    return Fail(why, "declared " + std::to_string(count) + " " + what + " in " + std::to_string(size) + " bytes");
  return true;
}

}  // namespace

bool CheckLandmarksMessageSize(const void* data, int size, std::string* why) {
  WireReader r(data, size);
  int64_t hash = 0, skip = 0;
  if (!r.Int64(&hash)) return Fail(why, "truncated");
  if (hash != landmarks_t::getHash()) return Fail(why, "wrong type");
  if (!r.Int64(&skip) || !r.Int64(&skip) || !r.String()) return Fail(why, "truncated");
  return CheckArray(r, 8 + 12 + 4 + 4 + 3, "landmarks", size, why);
}

bool CheckCameraInfoMessageSize(const void* data, int size, std::string* why) {
  WireReader r(data, size);
  int64_t hash = 0;
  if (!r.Int64(&hash)) return Fail(why, "truncated");
  if (hash != camera_info_t::getHash()) return Fail(why, "wrong type");
  // utime, session_id, camera_name, width, height, fx fy cx cy skew, distortion_model
  if (!r.Skip(8 + 8) || !r.String() || !r.Skip(4 + 4 + 5 * 8) || !r.String()) return Fail(why, "truncated");
  return CheckArray(r, 8, "distortion coefficients", size, why);
}

bool CheckVoxelMapMessageSize(const void* data, int size, std::string* why) {
  WireReader r(data, size);
  int64_t hash = 0;
  if (!r.Int64(&hash)) return Fail(why, "truncated");
  if (hash != voxel_map_t::getHash()) return Fail(why, "wrong type");
  // utime, seq, frame, voxel_size_mm, origin_mm[3], vote_threshold, is_final, truncated
  if (!r.Skip(8 + 8) || !r.String() || !r.Skip(8 + 24 + 4 + 1 + 1)) return Fail(why, "truncated");
  return CheckArray(r, 12 + 4 + 3, "voxels", size, why);
}

bool CheckFeatureTracksMessageSize(const void* data, int size, std::string* why) {
  WireReader r(data, size);
  int64_t hash = 0;
  if (!r.Int64(&hash)) return Fail(why, "truncated");
  if (hash != feature_tracks_t::getHash()) return Fail(why, "wrong type");
  if (!r.Skip(8 + 8) || !r.String() || !r.Skip(4 + 4)) return Fail(why, "truncated");
  return CheckArray(r, 8 + 4 + 4 + 4, "tracks", size, why);
}

bool CheckImageMessageSize(const void* data, int size, std::string* why) {
  WireReader r(data, size);
  int64_t hash = 0;
  if (!r.Int64(&hash)) return Fail(why, "truncated");
  if (hash != image_t::getHash()) return Fail(why, "wrong type");
  // utime, seq, session_id, camera_name, width, height, stride, encoding
  if (!r.Skip(8 + 8 + 8) || !r.String() || !r.Skip(4 + 4 + 4 + 1)) return Fail(why, "truncated");
  return CheckArray(r, 1, "data bytes", size, why);
}

bool CheckProcessStatusMessageSize(const void* data, int size, std::string* why) {
  WireReader r(data, size);
  int64_t hash = 0;
  if (!r.Int64(&hash)) return Fail(why, "truncated");
  if (hash != process_status_t::getHash()) return Fail(why, "wrong type");
  // utime, seq, name, host, pid, state, state_detail, last_data_utime, messages_in, messages_out, messages_rejected
  if (!r.Skip(8 + 8) || !r.String() || !r.String() || !r.Skip(4 + 1) || !r.String() || !r.Skip(4 * 8))
    return Fail(why, "truncated");
  int32_t reasons = 0, values = 0;
  if (!Count(r, "rejection reason", &reasons, why) ||
      !Strings(r, reasons, 8, "rejection reasons", size, why))
    return false;
  // dropped_inputs, latency_p50_ms, latency_p99_ms
  if (!r.Skip(3 * 8)) return Fail(why, "truncated");
  if (!Count(r, "value", &values, why) || !Strings(r, values, 8, "values", size, why)) return false;
  if (r.remaining() != 0) return Fail(why, std::to_string(r.remaining()) + " bytes after the message");
  return true;
}

bool CheckProcmanOrdersMessageSize(const void* data, int size, std::string* why) {
  WireReader r(data, size);
  int64_t hash = 0;
  if (!r.Int64(&hash)) return Fail(why, "truncated");
  if (hash != procman_orders_t::getHash()) return Fail(why, "wrong type");
  // utime, seq, sheriff, host, config_hash
  if (!r.Skip(8 + 8) || !r.String() || !r.String() || !r.String()) return Fail(why, "truncated");
  int32_t n = 0;
  // name[n], then run (1), run_id (4), follow_output (1) per process
  if (!Count(r, "process", &n, why) || !Strings(r, n, 1 + 4 + 1, "processes", size, why)) return false;
  if (r.remaining() != 0) return Fail(why, std::to_string(r.remaining()) + " bytes after the message");
  return true;
}

bool CheckProcmanDeputyMessageSize(const void* data, int size, std::string* why) {
  WireReader r(data, size);
  int64_t hash = 0;
  if (!r.Int64(&hash)) return Fail(why, "truncated");
  if (hash != procman_deputy_t::getHash()) return Fail(why, "wrong type");
  // utime, seq, host, config_hash, orders_accepted, orders_refused, last_refusal
  if (!r.Skip(8 + 8) || !r.String() || !r.String() || !r.Skip(8 + 8) || !r.String()) return Fail(why, "truncated");
  int32_t n = 0;
  if (!Count(r, "process", &n, why)) return false;
  if (n > r.remaining() / 12)  // three strings of at least 4 bytes each per process
    return Fail(why, "declared " + std::to_string(n) + " processes in " + std::to_string(size) + " bytes");
  // name, group, message; then state 1, desired_run 1, desired_run_id, run_id, pid, exit_code, exit_signal,
  // restarts 4 each, cpu_percent 4, rss_kb 8, uptime_s 4
  if (!Strings(r, 3 * n, 0, "process strings", size, why)) return false;
  if (!r.Skip(int64_t{42} * n)) return Fail(why, "truncated");
  if (r.remaining() != 0) return Fail(why, std::to_string(r.remaining()) + " bytes after the message");
  return true;
}

}  // namespace objscan

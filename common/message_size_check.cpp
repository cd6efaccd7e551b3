#include "common/message_size_check.h"

#include <cstdint>

#include "objscan/camera_info_t.hpp"
#include "objscan/landmarks_t.hpp"
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
  if (!r.Skip(8) || !r.String() || !r.Skip(4 + 4 + 5 * 8) || !r.String()) return Fail(why, "truncated");
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

}  // namespace objscan

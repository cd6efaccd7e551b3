#include "processes/planner/voxel_map_size_check.h"

#include <cstdint>

#include "objscan/voxel_map_t.hpp"

namespace objscan {
namespace {

bool Fail(std::string* why, const std::string& text) {
  if (why) *why = text;
  return false;
}

int64_t ReadBigEndian(const uint8_t* p, int bytes) {
  uint64_t x = 0;
  for (int i = 0; i < bytes; ++i) x = (x << 8) | p[i];
  return bytes == 4 ? static_cast<int64_t>(static_cast<int32_t>(x)) : static_cast<int64_t>(x);
}

}  // namespace

bool CheckVoxelMapMessageSize(const void* data, int size, std::string* why) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  if (data == nullptr || size < 8 + 8 + 8 + 4) return Fail(why, "truncated");
  if (ReadBigEndian(bytes, 8) != static_cast<int64_t>(voxel_map_t::getHash())) return Fail(why, "wrong type");
  int64_t pos = 8 + 8 + 8;  // hash, utime, seq
  const int64_t frame_length = ReadBigEndian(bytes + pos, 4);
  pos += 4;
  if (frame_length < 1 || frame_length > size - pos) return Fail(why, "truncated");
  pos += frame_length + 8 + 24 + 4 + 1 + 1;  // frame, voxel_size_mm, origin_mm, vote_threshold, is_final, truncated
  if (size - pos < 4) return Fail(why, "truncated");
  const int64_t count = ReadBigEndian(bytes + pos, 4);
  pos += 4;
  if (count < 0) return Fail(why, "negative voxel count " + std::to_string(count));
  if (size - pos != 19 * count)
    return Fail(why, "declared " + std::to_string(count) + " voxels in " + std::to_string(size) + " bytes");
  return true;
}

}  // namespace objscan

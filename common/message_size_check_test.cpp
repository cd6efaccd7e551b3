#include "common/message_size_check.h"

#include <gtest/gtest.h>

#include <vector>

#include "objscan/landmarks_t.hpp"
#include "objscan/voxel_map_t.hpp"

namespace objscan {
namespace {

template <class Msg>
std::vector<uint8_t> Encode(const Msg& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// Writes a big-endian int32 at offset (a forged count field).
void Poke32(std::vector<uint8_t>* b, size_t offset, int32_t v) {
  for (int i = 0; i < 4; ++i) (*b)[offset + i] = static_cast<uint8_t>(static_cast<uint32_t>(v) >> (24 - 8 * i));
}

TEST(MessageSizeCheck, VoxelMapCountMustMatchTheBytes) {
  voxel_map_t m{};
  m.frame = "world";
  m.num_voxels = 3;
  m.ijk.assign(3, {{1, 2, 3}});
  m.votes.assign(3, 7);
  m.rgb.assign(3, {{1, 2, 3}});
  std::vector<uint8_t> b = Encode(m);
  std::string why;
  EXPECT_TRUE(CheckVoxelMapMessageSize(b.data(), static_cast<int>(b.size()), &why)) << why;
  const size_t count_at = b.size() - 3 * 19 - 4;
  Poke32(&b, count_at, 1 << 30);  // 2^30 voxels declared in a 100-byte message
  EXPECT_FALSE(CheckVoxelMapMessageSize(b.data(), static_cast<int>(b.size()), &why));
  EXPECT_NE(why.find("declared 1073741824 voxels"), std::string::npos) << why;
  Poke32(&b, count_at, -1);
  EXPECT_FALSE(CheckVoxelMapMessageSize(b.data(), static_cast<int>(b.size()), &why));
  EXPECT_NE(why.find("negative"), std::string::npos) << why;
  EXPECT_FALSE(CheckVoxelMapMessageSize(b.data(), 20, &why));  // cut inside the header
  EXPECT_EQ(why, "truncated");
  const std::vector<uint8_t> other = Encode(landmarks_t{});
  EXPECT_FALSE(CheckVoxelMapMessageSize(other.data(), static_cast<int>(other.size()), &why));
  EXPECT_EQ(why, "wrong type");
}

TEST(MessageSizeCheck, LandmarksCountMustMatchTheBytes) {
  landmarks_t m{};
  m.frame = "world";
  m.num_landmarks = 2;
  m.id = {1, 2};
  m.position_mm.assign(2, {{0, 0, 0}});
  m.num_observations = {3, 3};
  m.reprojection_error_px = {0.5f, 0.5f};
  m.rgb.assign(2, {{1, 1, 1}});
  std::vector<uint8_t> b = Encode(m);
  std::string why;
  EXPECT_TRUE(CheckLandmarksMessageSize(b.data(), static_cast<int>(b.size()), &why)) << why;
  b.pop_back();
  EXPECT_FALSE(CheckLandmarksMessageSize(b.data(), static_cast<int>(b.size()), &why));
}

}  // namespace
}  // namespace objscan

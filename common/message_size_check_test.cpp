#include "common/message_size_check.h"

#include <gtest/gtest.h>

#include <limits>
#include <vector>

#include "common/bus.h"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/procman_deputy_t.hpp"
#include "objscan/procman_orders_t.hpp"
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

// Issue 28's messages: a 60-byte FEATURE_TRACKS with num_tracks = -1 (crashed the session supervisor), 2^25 declared
// tracks and a 63-byte image declaring 2^31-1 bytes (made every subscriber allocate first). DecodeMessage refuses
// them from the bytes, without allocating or throwing.
TEST(MessageSizeCheck, DecodeMessageRefusesForgedSizesWithoutAllocating) {
  feature_tracks_t t{};
  t.camera_name = "sim";
  t.num_tracks = 2;
  t.track_id = {1, 2};
  t.u = {1, 2};
  t.v = {1, 2};
  t.age = {0, 0};
  std::vector<uint8_t> b = Encode(t);
  feature_tracks_t out;
  std::string why;
  EXPECT_TRUE(DecodeMessage(b.data(), static_cast<int>(b.size()), &out, &why)) << why;
  EXPECT_EQ(out.num_tracks, 2);
  const size_t count_at = b.size() - 2 * 20 - 4;
  for (int32_t forged : {-1, 1 << 25, std::numeric_limits<int32_t>::max()}) {
    Poke32(&b, count_at, forged);
    EXPECT_FALSE(DecodeMessage(b.data(), static_cast<int>(b.size()), &out, &why)) << forged;
    EXPECT_FALSE(why.empty());
  }
  image_t image{};
  image.camera_name = "sim";
  image.size = 0;
  std::vector<uint8_t> ib = Encode(image);
  Poke32(&ib, ib.size() - 4, std::numeric_limits<int32_t>::max());
  image_t image_out;
  EXPECT_FALSE(DecodeMessage(ib.data(), static_cast<int>(ib.size()), &image_out, &why));
  EXPECT_NE(why.find("declared 2147483647 data bytes"), std::string::npos) << why;
  EXPECT_TRUE(image_out.data.empty());  // nothing was allocated
  // Random bytes after a valid fingerprint, an empty message, another type's bytes.
  std::vector<uint8_t> garbage = b;
  for (size_t i = 8; i < garbage.size(); ++i) garbage[i] = static_cast<uint8_t>(i * 37 + 11);
  EXPECT_FALSE(DecodeMessage(garbage.data(), static_cast<int>(garbage.size()), &out, &why));
  EXPECT_FALSE(DecodeMessage(b.data(), 0, &out, &why));
  pose_t pose;
  EXPECT_FALSE(DecodeMessage(b.data(), static_cast<int>(b.size()), &pose, &why));  // wrong type
}

TEST(MessageSizeCheck, ProcessStatusStringArraysMustFit) {
  process_status_t m{};
  m.name = "tracker";
  m.host = "robot";
  m.state_detail = "ok";
  m.num_rejection_reasons = 1;
  m.rejection_reason = {"image: wrong size"};
  m.rejection_count = {3};
  m.num_values = 2;
  m.value_name = {"a", "b"};
  m.value = {1, 2};
  std::vector<uint8_t> b = Encode(m);
  std::string why;
  EXPECT_TRUE(CheckProcessStatusMessageSize(b.data(), static_cast<int>(b.size()), &why)) << why;
  const size_t values_at = b.size() - (4 + 2) - (4 + 2) - 2 * 8 - 4;  // two strings "a", "b" then 2 doubles
  Poke32(&b, values_at, 1 << 28);
  EXPECT_FALSE(CheckProcessStatusMessageSize(b.data(), static_cast<int>(b.size()), &why));
  EXPECT_NE(why.find("declared 268435456 values"), std::string::npos) << why;
  process_status_t out;
  EXPECT_FALSE(DecodeMessage(b.data(), static_cast<int>(b.size()), &out, &why));
}

// The procman's orders and reports: a forged process count is refused before any allocation.
TEST(MessageSizeCheck, ProcmanOrdersAndReportsCountsMustFit) {
  procman_orders_t o{};
  o.sheriff = "s";
  o.host = "robot";
  o.config_hash = "0123456789abcdef";
  o.num_processes = 2;
  o.name = {"tracker", "robot_sim"};
  o.run = {1, 0};
  o.run_id = {3, 4};
  o.follow_output = {0, 1};
  std::vector<uint8_t> b = Encode(o);
  std::string why;
  procman_orders_t decoded;
  EXPECT_TRUE(DecodeMessage(b.data(), static_cast<int>(b.size()), &decoded, &why)) << why;
  EXPECT_EQ(decoded.name[1], "robot_sim");
  const size_t count_at = 8 + 16 + (4 + 2) + (4 + 6) + (4 + 17);
  Poke32(&b, count_at, 1 << 29);
  EXPECT_FALSE(DecodeMessage(b.data(), static_cast<int>(b.size()), &decoded, &why));
  EXPECT_NE(why.find("declared 536870912 processes"), std::string::npos) << why;
  Poke32(&b, count_at, -1);
  EXPECT_FALSE(DecodeMessage(b.data(), static_cast<int>(b.size()), &decoded, &why));
  EXPECT_NE(why.find("negative process count"), std::string::npos) << why;

  procman_deputy_t d{};
  d.host = "robot";
  d.config_hash = "0123456789abcdef";
  d.last_refusal = "";
  d.num_processes = 1;
  d.name = {"tracker"};
  d.group = {"robot"};
  d.message = {"started run 3"};
  d.state = {1};
  d.desired_run = {1};
  d.desired_run_id = {3};
  d.run_id = {3};
  d.pid = {4242};
  d.exit_code = {0};
  d.exit_signal = {0};
  d.restarts = {0};
  d.cpu_percent = {12.5f};
  d.rss_kb = {20480};
  d.uptime_s = {1.5f};
  b = Encode(d);
  procman_deputy_t report;
  EXPECT_TRUE(DecodeMessage(b.data(), static_cast<int>(b.size()), &report, &why)) << why;
  EXPECT_EQ(report.pid[0], 4242);
  const size_t n_at = 8 + 16 + (4 + 6) + (4 + 17) + 16 + (4 + 1);
  Poke32(&b, n_at, 1 << 28);
  EXPECT_FALSE(DecodeMessage(b.data(), static_cast<int>(b.size()), &report, &why));
  EXPECT_NE(why.find("declared 268435456 processes"), std::string::npos) << why;
  Poke32(&b, n_at, 2);  // more than the bytes hold
  EXPECT_FALSE(DecodeMessage(b.data(), static_cast<int>(b.size()), &report, &why));
  b = Encode(d);
  b.push_back(0);
  EXPECT_FALSE(DecodeMessage(b.data(), static_cast<int>(b.size()), &report, &why));
  EXPECT_NE(why.find("1 bytes after the message"), std::string::npos) << why;
}

// Bus::SubscribeMessage decodes through DecodeMessage: a forged message reaches on_malformed with the reason.
TEST(MessageSizeCheck, SubscribeMessageReportsWhy) {
  auto bus = MakeLcmBus("memq://");
  int good = 0;
  std::vector<std::string> reasons;
  bus->SubscribeMessage<feature_tracks_t>(
      "FEATURE_TRACKS", [&](const feature_tracks_t&, const RawMessage&) { ++good; },
      [&](const RawMessage& raw) { reasons.push_back(raw.why); });
  feature_tracks_t t{};
  t.camera_name = "sim";
  std::vector<uint8_t> b = Encode(t);
  ASSERT_TRUE(bus->Publish("FEATURE_TRACKS", b.data(), static_cast<int>(b.size())));
  Poke32(&b, b.size() - 4, -1);
  ASSERT_TRUE(bus->Publish("FEATURE_TRACKS", b.data(), static_cast<int>(b.size())));
  while (bus->Handle(0) > 0) {
  }
  EXPECT_EQ(good, 1);
  ASSERT_EQ(reasons.size(), 1u);
  EXPECT_NE(reasons[0].find("negative tracks count -1"), std::string::npos) << reasons[0];
}

}  // namespace
}  // namespace objscan

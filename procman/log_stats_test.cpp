#include "procman/log_stats.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include "common/bus.h"
#include "objscan/image_t.hpp"
#include "objscan/pose_t.hpp"

namespace objscan {
namespace {

TEST(LogStatsTest, CountsEventsAndDataTimes) {
  const std::string path = ::testing::TempDir() + "objscan_log_stats_" + std::to_string(getpid()) + ".lcmlog";
  {
    auto writer = MakeLcmBus("file://" + path + "?mode=w");
    for (int i = 0; i < 7; ++i) {
      pose_t p{};
      p.utime = 1000 + i * 33333;
      p.seq = i;
      p.orientation[0] = 1;
      ASSERT_TRUE(writer->PublishMessage("CAMERA_POSE", p));
    }
    image_t img{};
    img.utime = 42;
    img.seq = 99;
    ASSERT_TRUE(writer->PublishMessage("CAMERA_IMAGE", img));
  }
  std::map<std::string, ChannelStats> stats;
  std::string error;
  ASSERT_TRUE(ReadLogStats(path, &stats, &error)) << error;
  ASSERT_EQ(stats.size(), 2u);
  EXPECT_EQ(stats["CAMERA_POSE"].count, 7);
  EXPECT_EQ(stats["CAMERA_POSE"].first_utime, 1000);
  EXPECT_EQ(stats["CAMERA_POSE"].last_utime, 1000 + 6 * 33333);
  EXPECT_EQ(stats["CAMERA_IMAGE"].count, 1);
  EXPECT_FALSE(ReadLogStats("/nonexistent.lcmlog", &stats, &error));
  std::remove(path.c_str());
}

TEST(LogStatsTest, RawFieldsDecodeFromMessageBytes) {
  pose_t p{};
  p.utime = 123456789012;
  p.seq = 77;
  p.orientation[0] = 1;
  std::vector<uint8_t> bytes(p.getEncodedSize());
  p.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  int64_t utime = 0, seq = 0;
  ASSERT_TRUE(RawMessageUtime(bytes.data(), static_cast<int>(bytes.size()), &utime));
  ASSERT_TRUE(RawMessageSeq(bytes.data(), static_cast<int>(bytes.size()), &seq));
  EXPECT_EQ(utime, 123456789012);
  EXPECT_EQ(seq, 77);
  EXPECT_FALSE(RawMessageSeq(bytes.data(), 20, &seq));
}

}  // namespace
}  // namespace objscan

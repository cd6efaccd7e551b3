#include "tools/logtool/log_compare.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include "common/bus.h"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/process_status_t.hpp"

namespace objscan {
namespace {

std::string Temp(const std::string& name) { return ::testing::TempDir() + "objscan_logcmp_" + std::to_string(getpid()) + name; }

void WriteTracksLog(const std::string& path, float shift, bool skip_frame_2, int64_t status_utime) {
  auto bus = MakeLcmBus("file://" + path + "?mode=w");
  for (int f = 0; f < 4; ++f) {
    if (skip_frame_2 && f == 2) continue;
    feature_tracks_t t{};
    t.utime = f * 33333;
    t.seq = f;
    for (int k = 0; k < 3; ++k) {
      t.track_id.push_back(k);
      t.u.push_back(10.f * k + (k == 1 ? shift : 0.f));
      t.v.push_back(5.f);
      t.age.push_back(f);
    }
    t.num_tracks = 3;
    ASSERT_TRUE(bus->PublishMessage("FEATURE_TRACKS", t));
    process_status_t s{};
    s.utime = status_utime;  // wall clock differs between runs
    s.name = "tracker";
    ASSERT_TRUE(bus->PublishMessage("PROCESS_STATUS", s));
  }
}

TEST(LogCompareTest, BytesIgnoreStatusButCatchAnyChange) {
  WriteTracksLog(Temp("a"), 0.f, false, 1);
  WriteTracksLog(Temp("b"), 0.f, false, 2);
  WriteTracksLog(Temp("c"), 0.001f, false, 1);
  std::string error;
  EXPECT_TRUE(CompareLogBytes(Temp("a"), Temp("b"), {"PROCESS_STATUS"}, &error).identical);
  EXPECT_FALSE(CompareLogBytes(Temp("a"), Temp("b"), {}, &error).identical);
  const auto r = CompareLogBytes(Temp("a"), Temp("c"), {"PROCESS_STATUS"}, &error);
  EXPECT_FALSE(r.identical);
  EXPECT_NE(r.first_difference.find("FEATURE_TRACKS"), std::string::npos);
}

TEST(LogCompareTest, TracksWithinToleranceAndGapsDetected) {
  WriteTracksLog(Temp("a"), 0.f, false, 1);
  WriteTracksLog(Temp("d"), 0.3f, true, 1);
  TracksComparison r;
  std::string error;
  ASSERT_TRUE(CompareLogTracks(Temp("a"), Temp("d"), "FEATURE_TRACKS", 0.25, &r, &error)) << error;
  EXPECT_EQ(r.frames_a, 4);
  EXPECT_EQ(r.frames_b, 3);
  EXPECT_EQ(r.frames_matched, 3);
  EXPECT_FALSE(r.contiguous_b);
  EXPECT_EQ(r.tracks_compared, 9);
  EXPECT_EQ(r.tracks_within_tolerance, 6);
  EXPECT_NEAR(r.max_difference_px, 0.3, 1e-6);
  for (const char* n : {"a", "b", "c", "d"}) std::remove(Temp(n).c_str());
}

}  // namespace
}  // namespace objscan

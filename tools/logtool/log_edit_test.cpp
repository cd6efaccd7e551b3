#include "tools/logtool/log_edit.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace objscan {
namespace {

constexpr double kForever = std::numeric_limits<double>::infinity();
constexpr int64_t kStartUs = 1'700'000'000'000'000;

// An objscan-like message: 8-byte fingerprint, then big-endian utime and seq, then a payload byte.
std::vector<uint8_t> Message(int64_t utime, int64_t seq, uint8_t payload) {
  std::vector<uint8_t> m(8, 0xAB);
  for (int64_t v : {utime, seq})
    for (int s = 56; s >= 0; s -= 8) m.push_back(static_cast<uint8_t>(static_cast<uint64_t>(v) >> s));
  m.push_back(payload);
  return m;
}

struct Event {
  std::string channel;
  int64_t t_us;  // from kStartUs
  int64_t seq;
};

class LogEditTest : public ::testing::Test {
 protected:
  std::string Path(const std::string& name) {
    const std::string p = ::testing::TempDir() + "log_edit_test_" + std::to_string(::getpid()) + "_" + name;
    paths_.push_back(p);
    return p;
  }
  std::string WriteLog(const std::string& name, const std::vector<Event>& events) {
    const std::string path = Path(name);
    LcmLogWriter w;
    std::string error;
    EXPECT_TRUE(w.Open(path, &error)) << error;
    for (const auto& e : events) {
      LcmLogEvent le;
      le.channel = e.channel;
      le.timestamp_us = kStartUs + e.t_us;
      le.data = Message(le.timestamp_us, e.seq, static_cast<uint8_t>(e.seq));
      EXPECT_TRUE(w.Write(le, &error)) << error;
    }
    EXPECT_TRUE(w.Close(&error)) << error;
    return path;
  }
  static std::vector<LcmLogEvent> ReadAll(const std::string& path) {
    LcmLogReader r;
    std::string error;
    std::vector<LcmLogEvent> events;
    if (!r.Open(path, &error)) {
      ADD_FAILURE() << error;
      return events;
    }
    LcmLogEvent e;
    while (r.Next(&e)) events.push_back(e);
    EXPECT_FALSE(r.damage().Any()) << r.damage().Describe();
    return events;
  }
  // A 2 s session: images and odometry at 30 Hz, poses (outputs) at 30 Hz, status at 1 Hz.
  std::vector<Event> Session() {
    std::vector<Event> events;
    for (int i = 0; i < 60; ++i) {
      const int64_t t = i * 33'333;
      events.push_back({"CAMERA_IMAGE", t, i});
      events.push_back({"ROBOT_ODOMETRY", t + 100, i});
      events.push_back({"CAMERA_POSE", t + 20'000, i});
      if (i % 30 == 0) events.push_back({"PROCESS_STATUS", t + 50, i / 30});
    }
    return events;
  }
  void TearDown() override {
    for (const auto& p : paths_) std::remove(p.c_str());
  }
  std::vector<std::string> paths_;
};

TEST_F(LogEditTest, InfoCountsChannelsRatesGapsAndLostSequenceNumbers) {
  std::vector<Event> events;
  for (int i = 0; i < 100; ++i) {
    if (i >= 40 && i < 43) continue;                      // 3 images lost: seq 40..42 missing, a 0.13 s hole
    const int64_t t = i * 33'333 + (i >= 70 ? 2'000'000 : 0);  // a 2 s gap before image 70
    events.push_back({"CAMERA_IMAGE", t, i});
    if (i % 10 == 0) events.push_back({"LANDMARKS", t, i});  // keyframes: seq jumps by 10, not a loss
  }
  LogInfo info;
  std::string error;
  ASSERT_TRUE(ReadLogInfo(WriteLog("info.lcmlog", events), &info, &error)) << error;
  EXPECT_EQ(info.events, 97 + 9);  // keyframe 40 was among the lost
  ASSERT_EQ(info.channels.size(), 2u);
  const LogChannelInfo& images = info.channels.at("CAMERA_IMAGE");
  EXPECT_EQ(images.count, 97);
  EXPECT_NEAR(images.median_interval_s, 0.0333, 1e-3);
  EXPECT_NEAR(images.max_gap_s, 2.0333, 1e-3);
  EXPECT_NEAR(images.max_gap_at_s, 69 * 0.033333, 1e-3);
  EXPECT_EQ(images.gaps, 1);  // the 0.13 s hole is under 0.5 s
  EXPECT_TRUE(images.has_seq);
  EXPECT_EQ(images.seq_missing, 3);
  EXPECT_EQ(images.seq_backwards, 0);
  EXPECT_FALSE(info.channels.at("LANDMARKS").has_seq);
  const std::string text = FormatLogInfo("info.lcmlog", info);
  EXPECT_NE(text.find("CAMERA_IMAGE skips 3 sequence numbers"), std::string::npos) << text;
  EXPECT_NE(text.find("the longest 2.033 s"), std::string::npos) << text;
  EXPECT_EQ(text.find("DAMAGED"), std::string::npos) << text;
}

TEST_F(LogEditTest, InfoSeesARestartedSenderAndDamage) {
  std::vector<Event> events;
  for (int i = 0; i < 50; ++i) events.push_back({"CAMERA_IMAGE", i * 33'333, i < 30 ? i : i - 30});
  const std::string path = WriteLog("restart.lcmlog", events);
  std::ofstream(path, std::ios::binary | std::ios::app) << "garbage that is no event";
  LogInfo info;
  std::string error;
  ASSERT_TRUE(ReadLogInfo(path, &info, &error)) << error;
  EXPECT_EQ(info.channels.at("CAMERA_IMAGE").seq_backwards, 1);
  EXPECT_TRUE(info.damage.Any());
  const std::string text = FormatLogInfo(path, info);
  EXPECT_NE(text.find("restart: CAMERA_IMAGE"), std::string::npos) << text;
  EXPECT_NE(text.find("DAMAGED"), std::string::npos) << text;
  EXPECT_FALSE(ReadLogInfo(Path("missing.lcmlog"), &info, &error));
}

TEST_F(LogEditTest, FilterKeepsTheSensorChannelsByteForByteInOrder) {
  const std::string in = WriteLog("session.lcmlog", Session());
  const std::string out = Path("sensors.lcmlog");
  ChannelSelection selection;
  std::string error;
  ASSERT_TRUE(ParseChannelPatterns("CAMERA_*,ROBOT_ODOMETRY,NO_SUCH", &selection.keep, &error)) << error;
  ASSERT_TRUE(ParseChannelPatterns("CAMERA_POSE", &selection.drop, &error)) << error;
  LogEditResult r;
  ASSERT_TRUE(FilterLog(in, out, selection, 0, kForever, &r, &error)) << error;
  EXPECT_EQ(r.events_in, 182);
  EXPECT_EQ(r.events_out, 120);
  EXPECT_EQ(r.channels_out.size(), 2u);
  EXPECT_EQ(r.patterns_never_matched, std::vector<std::string>{"NO_SUCH"});
  EXPECT_TRUE(r.damage.empty());
  const auto all = ReadAll(in);
  const auto kept = ReadAll(out);
  ASSERT_EQ(kept.size(), 120u);
  size_t k = 0;
  for (const auto& e : all) {
    if (e.channel != "CAMERA_IMAGE" && e.channel != "ROBOT_ODOMETRY") continue;
    ASSERT_LT(k, kept.size());
    EXPECT_EQ(kept[k].channel, e.channel);
    EXPECT_EQ(kept[k].timestamp_us, e.timestamp_us);
    EXPECT_EQ(kept[k].data, e.data);
    EXPECT_EQ(kept[k].event_number, static_cast<int64_t>(k));
    ++k;
  }
  EXPECT_EQ(k, kept.size());
  std::ifstream partial(out + ".partial");
  EXPECT_FALSE(partial.good());
}

TEST_F(LogEditTest, CutKeepsAWindowOfSecondsFromTheFirstEvent) {
  const std::string in = WriteLog("session.lcmlog", Session());
  const std::string out = Path("cut.lcmlog");
  LogEditResult r;
  std::string error;
  ASSERT_TRUE(FilterLog(in, out, ChannelSelection{}, 0.5, 1.0, &r, &error)) << error;
  const auto kept = ReadAll(out);
  ASSERT_FALSE(kept.empty());
  for (const auto& e : kept) {
    EXPECT_GE(e.timestamp_us - kStartUs, 500'000);
    EXPECT_LT(e.timestamp_us - kStartUs, 1'000'000);
  }
  // Images 15..29 lie in [0.5, 1.0) s.
  EXPECT_EQ(r.channels_out.at("CAMERA_IMAGE"), 15);
  EXPECT_FALSE(FilterLog(in, out, ChannelSelection{}, 1.0, 0.5, &r, &error));
  EXPECT_NE(error.find("from < to"), std::string::npos) << error;
}

TEST_F(LogEditTest, MergeInterleavesByTimeAndKeepsEachInputsOrder) {
  std::vector<Event> a, b;
  for (int i = 0; i < 10; ++i) a.push_back({"CAMERA_IMAGE", i * 100, i});
  for (int i = 0; i < 10; ++i) b.push_back({"CAMERA_POSE", i * 100 + 50, i});
  b.push_back({"CAMERA_POSE", 120, 10});  // goes back in time: stays after its predecessor
  a.push_back({"CAMERA_IMAGE", 950, 10});
  const std::string out = Path("merged.lcmlog");
  LogEditResult r;
  std::string error;
  ASSERT_TRUE(MergeLogs({WriteLog("a.lcmlog", a), WriteLog("b.lcmlog", b)}, out, &r, &error)) << error;
  EXPECT_EQ(r.events_in, 22);
  EXPECT_EQ(r.events_out, 22);
  const auto merged = ReadAll(out);
  ASSERT_EQ(merged.size(), 22u);
  int64_t last_image = -1, last_pose = -1;
  for (size_t i = 0; i < merged.size(); ++i) {
    const auto seq = merged[i].data[23];  // low byte of seq
    int64_t* last = merged[i].channel == "CAMERA_IMAGE" ? &last_image : &last_pose;
    EXPECT_EQ(seq, *last + 1) << i;
    *last = seq;
  }
  // Image 0 (t=0) first, then pose 0 (t=50), image 1 (t=100), ...
  EXPECT_EQ(merged[0].channel, "CAMERA_IMAGE");
  EXPECT_EQ(merged[1].channel, "CAMERA_POSE");
  EXPECT_EQ(merged[2].channel, "CAMERA_IMAGE");
}

TEST_F(LogEditTest, ADamagedInputIsReportedAndEveryReadableEventKept) {
  const std::string in = WriteLog("damaged.lcmlog", Session());
  {
    // Splice garbage into the middle: the reader resynchronises at the next event.
    std::fstream f(in, std::ios::binary | std::ios::in | std::ios::out);
    f.seekp(5000);
    f << "XXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXX";
  }
  const std::string out = Path("out.lcmlog");
  LogEditResult r;
  std::string error;
  ASSERT_TRUE(FilterLog(in, out, ChannelSelection{}, 0, kForever, &r, &error)) << error;
  ASSERT_EQ(r.damage.size(), 1u);
  EXPECT_NE(r.damage[0].find("skipped"), std::string::npos) << r.damage[0];
  EXPECT_GT(r.events_out, 170);
  EXPECT_LT(r.events_out, 182);
  EXPECT_EQ(r.events_out, r.events_in);
}

TEST_F(LogEditTest, RefusesToOverwriteItsInputAndBadPatternLists) {
  const std::string in = WriteLog("session.lcmlog", Session());
  LogEditResult r;
  std::string error;
  EXPECT_FALSE(FilterLog(in, in, ChannelSelection{}, 0, kForever, &r, &error));
  EXPECT_NE(error.find("is the input"), std::string::npos) << error;
  EXPECT_FALSE(MergeLogs({in}, in, &r, &error));
  EXPECT_NE(error.find("one of the inputs"), std::string::npos) << error;
  EXPECT_EQ(ReadAll(in).size(), 182u);
  std::vector<std::string> patterns;
  for (const char* bad : {"", ",", "A,,B", "A,"}) {
    EXPECT_FALSE(ParseChannelPatterns(bad, &patterns, &error)) << bad;
  }
  ASSERT_TRUE(ParseChannelPatterns("A,B*", &patterns, &error));
  EXPECT_EQ(patterns.size(), 2u);
}

}  // namespace
}  // namespace objscan

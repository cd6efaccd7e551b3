#include "common/lcm_log.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace objscan {
namespace {

void Put32(std::vector<uint8_t>* b, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) b->push_back(static_cast<uint8_t>(v >> s));
}
void Put64(std::vector<uint8_t>* b, uint64_t v) {
  Put32(b, static_cast<uint32_t>(v >> 32));
  Put32(b, static_cast<uint32_t>(v));
}
std::vector<uint8_t> Event(int64_t n, const std::string& channel, size_t data_bytes) {
  std::vector<uint8_t> b;
  Put32(&b, 0xEDA1DA01u);
  Put64(&b, static_cast<uint64_t>(n));
  Put64(&b, static_cast<uint64_t>(1000 * n));
  Put32(&b, static_cast<uint32_t>(channel.size()));
  Put32(&b, static_cast<uint32_t>(data_bytes));
  b.insert(b.end(), channel.begin(), channel.end());
  for (size_t i = 0; i < data_bytes; ++i) b.push_back(static_cast<uint8_t>(i * 7 + n));
  return b;
}

class LcmLogTest : public ::testing::Test {
 protected:
  std::string Write(const std::vector<uint8_t>& bytes) {
    const std::string path = ::testing::TempDir() + "lcm_log_test_" + std::to_string(::getpid()) + ".lcmlog";
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    paths_.push_back(path);
    return path;
  }
  void TearDown() override {
    for (const auto& p : paths_) std::remove(p.c_str());
  }
  // Reads all events; returns their numbers.
  static std::vector<int64_t> ReadAll(LcmLogReader* r) {
    std::vector<int64_t> n;
    LcmLogEvent e;
    while (r->Next(&e)) n.push_back(e.event_number);
    return n;
  }
  std::vector<std::string> paths_;
};

std::vector<uint8_t> FiveEvents(std::vector<size_t>* starts) {
  std::vector<uint8_t> log;
  for (int n = 0; n < 5; ++n) {
    starts->push_back(log.size());
    const auto e = Event(n, "CHANNEL_" + std::to_string(n), 100 + 10 * n);
    log.insert(log.end(), e.begin(), e.end());
  }
  return log;
}

TEST_F(LcmLogTest, ReadsAnIntactLog) {
  std::vector<size_t> starts;
  LcmLogReader r;
  std::string error;
  ASSERT_TRUE(r.Open(Write(FiveEvents(&starts)), &error)) << error;
  LcmLogEvent e;
  ASSERT_TRUE(r.Next(&e));
  EXPECT_EQ(e.channel, "CHANNEL_0");
  EXPECT_EQ(e.timestamp_us, 0);
  EXPECT_EQ(e.data.size(), 100u);
  EXPECT_EQ(ReadAll(&r), (std::vector<int64_t>{1, 2, 3, 4}));
  EXPECT_FALSE(r.damage().Any());
  EXPECT_EQ(r.damage().Describe(), "");
}

TEST_F(LcmLogTest, ReadsPastSplicedGarbage) {
  std::vector<size_t> starts;
  std::vector<uint8_t> log = FiveEvents(&starts);
  std::vector<uint8_t> garbage(4096);
  for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<uint8_t>((i * 2654435761u) >> 13);
  garbage[100] = 0xED;  // a stray magic with absurd lengths after it
  garbage[101] = 0xA1;
  garbage[102] = 0xDA;
  garbage[103] = 0x01;
  log.insert(log.begin() + static_cast<long>(starts[2]), garbage.begin(), garbage.end());
  LcmLogReader r;
  std::string error;
  ASSERT_TRUE(r.Open(Write(log), &error)) << error;
  EXPECT_EQ(ReadAll(&r), (std::vector<int64_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(r.damage().skipped_bytes, 4096);
  EXPECT_EQ(r.damage().skipped_regions, 1);
  EXPECT_EQ(r.damage().first_offset, static_cast<int64_t>(starts[2]));
  EXPECT_NE(r.damage().Describe().find("4096 bytes"), std::string::npos) << r.damage().Describe();
}

TEST_F(LcmLogTest, ACutLastEventIsReportedAndTheRestRead) {
  std::vector<size_t> starts;
  std::vector<uint8_t> log = FiveEvents(&starts);
  for (size_t cut : {starts[4] + 10, starts[4] + 40, log.size() - 1}) {
    std::vector<uint8_t> part(log.begin(), log.begin() + static_cast<long>(cut));
    LcmLogReader r;
    std::string error;
    ASSERT_TRUE(r.Open(Write(part), &error)) << error;
    EXPECT_EQ(ReadAll(&r), (std::vector<int64_t>{0, 1, 2, 3})) << cut;
    EXPECT_TRUE(r.damage().truncated_tail) << cut;
    EXPECT_NE(r.damage().Describe().find("cut short"), std::string::npos);
  }
}

TEST_F(LcmLogTest, RefusesFilesThatAreNoLog) {
  LcmLogReader empty, png, missing;
  std::string error;
  EXPECT_FALSE(empty.Open(Write({}), &error));
  EXPECT_NE(error.find("empty"), std::string::npos) << error;
  EXPECT_FALSE(png.Open(Write({0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13}), &error));
  EXPECT_NE(error.find("not an LCM log"), std::string::npos) << error;
  EXPECT_FALSE(missing.Open("/nonexistent/objscan.lcmlog", &error));
  EXPECT_NE(error.find("no such file"), std::string::npos) << error;
}

TEST_F(LcmLogTest, WrittenEventsReadBackByteForByteAndRenumbered) {
  const std::string path = Write({});
  LcmLogWriter w;
  std::string error;
  ASSERT_TRUE(w.Open(path, &error)) << error;
  std::vector<LcmLogEvent> written;
  for (int i = 0; i < 4; ++i) {
    LcmLogEvent e;
    e.event_number = 100 + 7 * i;  // ignored: the writer numbers 0, 1, 2, ...
    e.timestamp_us = 1'700'000'000'000'000 + 33'333 * i;
    e.channel = i % 2 ? "CAMERA_IMAGE" : "ROBOT_ODOMETRY";
    for (int b = 0; b < 10 * i; ++b) e.data.push_back(static_cast<uint8_t>(b * 31 + i));
    ASSERT_TRUE(w.Write(e, &error)) << error;
    written.push_back(e);
  }
  LcmLogEvent nameless;
  EXPECT_FALSE(w.Write(nameless, &error));
  EXPECT_NE(error.find("cannot be written"), std::string::npos) << error;
  EXPECT_EQ(w.events(), 4);
  ASSERT_TRUE(w.Close(&error)) << error;

  LcmLogReader r;
  ASSERT_TRUE(r.Open(path, &error)) << error;
  LcmLogEvent e;
  for (size_t i = 0; i < written.size(); ++i) {
    ASSERT_TRUE(r.Next(&e)) << i;
    EXPECT_EQ(e.event_number, static_cast<int64_t>(i));
    EXPECT_EQ(e.timestamp_us, written[i].timestamp_us);
    EXPECT_EQ(e.channel, written[i].channel);
    EXPECT_EQ(e.data, written[i].data);
  }
  EXPECT_FALSE(r.Next(&e));
  EXPECT_FALSE(r.damage().Any());
}

TEST_F(LcmLogTest, AWriterThatCannotCreateItsFileSaysSo) {
  LcmLogWriter w;
  std::string error;
  EXPECT_FALSE(w.Open("/nonexistent/dir/out.lcmlog", &error));
  EXPECT_NE(error.find("cannot create"), std::string::npos) << error;
}

}  // namespace
}  // namespace objscan

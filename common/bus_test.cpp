#include "common/bus.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <string>

#include <lcm/eventlog.h>

#include "objscan/control_t.hpp"
#include "objscan/odometry_t.hpp"

namespace objscan {
namespace {

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "objscan_bus_test_" + std::to_string(getpid()) + "_" + name;
}

TEST(BusTest, MemqDeliversTypedMessagesInOrder) {
  auto bus = MakeLcmBus("memq://");
  std::vector<int64_t> seqs;
  bus->SubscribeMessage<odometry_t>("ODOM", [&](const odometry_t& m, const RawMessage& raw) {
    EXPECT_EQ(raw.channel, "ODOM");
    seqs.push_back(m.seq);
  });
  for (int i = 0; i < 5; ++i) {
    odometry_t m{};
    m.seq = i;
    m.x_mm = i * 10.0;
    ASSERT_TRUE(bus->PublishMessage("ODOM", m));
  }
  while (bus->Handle(0) > 0) {
  }
  EXPECT_EQ(seqs, (std::vector<int64_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(bus->Handle(0), 0);  // nothing left: timeout, not end of stream
}

TEST(BusTest, MalformedMessageGoesToErrorHandler) {
  auto bus = MakeLcmBus("memq://");
  int good = 0, bad = 0;
  bus->SubscribeMessage<odometry_t>(
      "ODOM", [&](const odometry_t&, const RawMessage&) { ++good; }, [&](const RawMessage&) { ++bad; });
  const char junk[] = "not an odometry message";
  ASSERT_TRUE(bus->Publish("ODOM", junk, sizeof(junk)));
  control_t wrong_type{};  // a valid message of another type: fingerprint mismatch
  wrong_type.sender = "x";
  ASSERT_TRUE(bus->PublishMessage("ODOM", wrong_type));
  while (bus->Handle(0) > 0) {
  }
  EXPECT_EQ(good, 0);
  EXPECT_EQ(bad, 2);
}

TEST(BusTest, CorruptedArrayCountIsMalformedNotACrash) {
  auto bus = MakeLcmBus("memq://");
  int good = 0, bad = 0;
  bus->SubscribeMessage<control_t>(
      "CTRL", [&](const control_t&, const RawMessage&) { ++good; }, [&](const RawMessage&) { ++bad; });
  control_t m{};
  m.sender = "abc";
  std::vector<uint8_t> bytes(m.getEncodedSize());
  ASSERT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  // The sender string's length field follows the fingerprint and utime: claim ~2 GB.
  bytes[16] = 0x7f;
  bytes[17] = 0xff;
  ASSERT_TRUE(bus->Publish("CTRL", bytes.data(), static_cast<int>(bytes.size())));
  while (bus->Handle(0) > 0) {
  }
  EXPECT_EQ(good, 0);
  EXPECT_EQ(bad, 1);
}

TEST(BusTest, LogWriteThenReplayToEndSplitBus) {
  const std::string path = TempPath("log.lcmlog");
  {
    auto writer = MakeLcmBus("file://" + path + "?mode=w");
    for (int i = 0; i < 20; ++i) {
      odometry_t m{};
      m.utime = i * 1000;
      m.seq = i;
      ASSERT_TRUE(writer->PublishMessage("ODOM", m));
    }
  }
  // Replay the log into a memq output: handlers see every message, publishing goes to the output side.
  auto bus = MakeBus("file://" + path + "?speed=0", "memq://");
  int count = 0;
  int64_t last = -1;
  bus->SubscribeMessage<odometry_t>("ODOM", [&](const odometry_t& m, const RawMessage&) {
    EXPECT_EQ(m.seq, last + 1);
    last = m.seq;
    ++count;
    control_t ack{};
    ack.sender = "test";
    EXPECT_TRUE(bus->PublishMessage("ACK", ack));  // would fail on a read-mode file:// bus
  });
  int status = 0;
  int iterations = 0;
  while ((status = bus->Handle(100)) >= 0 && iterations++ < 1000) {
  }
  EXPECT_EQ(status, -1);  // end of log
  EXPECT_EQ(count, 20);
  std::remove(path.c_str());
}

TEST(BusTest, DataLogStampsEventsWithDataTimeAndSkipsStatus) {
  const std::string path = TempPath("data.lcmlog");
  {
    auto writer = MakeLcmBus("datalog://" + path);
    for (int i = 0; i < 3; ++i) {
      odometry_t m{};
      m.utime = 1000000 + i * 33333;
      m.seq = i;
      ASSERT_TRUE(writer->PublishMessage("ODOM", m));
      ASSERT_TRUE(writer->PublishMessage("PROCESS_STATUS", m));  // excluded by default
    }
  }
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "r");
  ASSERT_NE(log, nullptr);
  std::vector<int64_t> stamps;
  while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log)) {
    EXPECT_EQ(std::string(e->channel, e->channellen), "ODOM");
    stamps.push_back(e->timestamp);
    lcm_eventlog_free_event(e);
  }
  lcm_eventlog_destroy(log);
  EXPECT_EQ(stamps, (std::vector<int64_t>{1000000, 1033333, 1066666}));
  // A far-off utime (garbage) does not move the clock.
  {
    auto writer = MakeLcmBus("datalog://" + path);
    odometry_t m{};
    m.utime = 1000;
    ASSERT_TRUE(writer->PublishMessage("ODOM", m));
    m.utime = int64_t{1} << 60;
    ASSERT_TRUE(writer->PublishMessage("ODOM", m));
    m.utime = 2000;
    ASSERT_TRUE(writer->PublishMessage("ODOM", m));
  }
  log = lcm_eventlog_create(path.c_str(), "r");
  ASSERT_NE(log, nullptr);
  stamps.clear();
  while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log)) {
    stamps.push_back(e->timestamp);
    lcm_eventlog_free_event(e);
  }
  lcm_eventlog_destroy(log);
  EXPECT_EQ(stamps, (std::vector<int64_t>{1000, 1000, 2000}));
  std::remove(path.c_str());
}

TEST(BusTest, BadUrlThrows) { EXPECT_THROW(MakeLcmBus("nonsense://what"), std::runtime_error); }

// A bus that only says whether it is a network transport.
class FakeNetworkBus final : public Bus {
 public:
  explicit FakeNetworkBus(bool network) : network_(network) {}
  bool Publish(const std::string&, const void*, int) override { return true; }
  void Subscribe(const std::string&, RawHandler, int) override {}
  int Handle(int) override { return 0; }
  std::string Describe() const override { return "fake"; }
  bool IsNetwork() const override { return network_; }

 private:
  bool network_;
};

TEST(BusTest, LocalTransportsAreNotNetwork) {
  EXPECT_FALSE(MakeLcmBus("memq://")->IsNetwork());
  const std::string path = TempPath("net.lcmlog");
  EXPECT_FALSE(MakeLcmBus("datalog://" + path)->IsNetwork());
  EXPECT_FALSE(MakeBus("memq://", "file://" + path + "?mode=w")->IsNetwork());
  std::remove(path.c_str());
}

TEST(BusTest, BurstPacerPausesOnlyOnNetworkBuses) {
  FakeNetworkBus network(true), local(false);
  BurstPacer paced(network, 3, 1), unpaced(local, 3, 1);
  for (int i = 0; i < 7; ++i) {
    paced.After();
    unpaced.After();
  }
  EXPECT_EQ(paced.pauses(), 2);  // after messages 3 and 6
  EXPECT_EQ(unpaced.pauses(), 0);
}

}  // namespace
}  // namespace objscan

#include "procman/deputy_node.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <random>

#include "objscan/procman_deputy_t.hpp"
#include "procman/procman_messages.h"

namespace objscan {
namespace {

// Hostile input on PROCMAN_ORDERS: garbage, forged counts, orders for another config, an entry of another host.
// The deputy counts and refuses them, starts nothing, keeps reporting, and still obeys good orders afterwards.
TEST(DeputyNode, HostileOrdersAreCountedAndChangeNothing) {
  const std::string dir = ::testing::TempDir() + "deputy_node_test_" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  ProcmanConfig config;
  std::string error;
  ASSERT_TRUE(ParseProcmanConfig("process sleeper\n host = robot\n command = sleep 30\n"
                                 "process other\n host = ws\n command = sleep 30\n",
                                 "test.cfg", &config, &error))
      << error;
  auto bus = MakeLcmBus("memq://");
  std::vector<procman_deputy_t> reports;
  bus->SubscribeMessage<procman_deputy_t>(kProcmanDeputyChannel,
                                          [&](const procman_deputy_t& m, const RawMessage&) { reports.push_back(m); });
  DeputyOptions options;
  options.host = "robot";
  options.log_dir = dir;
  DeputyNode node(*bus, config, options);
  auto drain = [&] {
    while (bus->Handle(0) > 0) {
    }
  };
  std::mt19937 rng(3);
  for (int i = 0; i < 200; ++i) {  // random bytes, some starting with the type's fingerprint
    std::vector<uint8_t> junk(static_cast<size_t>(rng() % 200 + 1));
    for (auto& b : junk) b = static_cast<uint8_t>(rng());
    if (i % 2 == 0 && junk.size() >= 8) {
      const int64_t hash = procman_orders_t::getHash();
      for (int k = 0; k < 8; ++k) junk[k] = static_cast<uint8_t>(static_cast<uint64_t>(hash) >> (56 - 8 * k));
    }
    bus->Publish(kProcmanOrdersChannel, junk.data(), static_cast<int>(junk.size()));
  }
  DeputyOrders forged;
  forged.host = "robot";
  forged.config_hash = "0000000000000000";
  forged.sheriff = "intruder";
  forged.processes = {{"sleeper", true, 1, false}};
  bus->PublishMessage(kProcmanOrdersChannel, OrdersToMessage(forged, 0, 0));
  forged.config_hash = config.hash;
  forged.processes = {{"other", true, 1, false}};
  bus->PublishMessage(kProcmanOrdersChannel, OrdersToMessage(forged, 0, 1));
  drain();
  node.Tick(0);
  drain();
  EXPECT_EQ(node.malformed_orders(), 200);
  ASSERT_FALSE(reports.empty());
  EXPECT_EQ(reports.back().orders_refused, 2);
  EXPECT_EQ(reports.back().orders_accepted, 0);
  EXPECT_EQ(reports.back().state[0], +procman_deputy_t::STATE_STOPPED);
  // Good orders still work.
  forged.processes = {{"sleeper", true, 1, false}};
  bus->PublishMessage(kProcmanOrdersChannel, OrdersToMessage(forged, 0, 2));
  drain();
  node.Tick(0);
  EXPECT_EQ(node.deputy().Report(0).processes[0].state, ProcessState::kRunning);
  node.OnShutdown();
  EXPECT_EQ(node.deputy().Report(0).processes[0].state, ProcessState::kStopped);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace objscan

#include "common/status.h"

#include <gtest/gtest.h>

#include "common/bus.h"
#include "objscan/process_status_t.hpp"

namespace objscan {
namespace {

TEST(StatusTest, CountsGapsRejectionsAndPublishesFullState) {
  auto bus = MakeLcmBus("memq://");
  std::vector<process_status_t> published;
  bus->SubscribeMessage<process_status_t>(
      "PROCESS_STATUS", [&](const process_status_t& m, const RawMessage&) { published.push_back(m); });
  StatusReporter status(bus.get(), "unit");
  EXPECT_EQ(status.ObserveSeq("img", 5), SeqResult::kFirst);
  EXPECT_EQ(status.ObserveSeq("img", 6), SeqResult::kNext);
  EXPECT_EQ(status.ObserveSeq("img", 9), SeqResult::kGap);
  EXPECT_EQ(status.ObserveSeq("img", 9), SeqResult::kRepeatedOrOld);
  EXPECT_EQ(status.ObserveSeq("img", 3), SeqResult::kRepeatedOrOld);
  EXPECT_EQ(status.dropped_inputs(), 2);
  status.Reject("image: wrong size", "640x480 expected");
  status.Reject("image: wrong size");
  status.Reject("image: unknown encoding");
  EXPECT_EQ(status.rejected("image: wrong size"), 2);
  EXPECT_EQ(status.rejected_total(), 3);
  for (int i = 1; i <= 100; ++i) status.RecordLatencyMs(i);
  status.SetValue("live_tracks", 812);
  status.SetValue("live_tracks", 900);
  status.SetState(process_status_t::STATE_RUNNING, "ok");

  status.PublishIfDue(10'000'000);
  status.PublishIfDue(10'500'000);  // within the period: not published
  status.PublishIfDue(11'000'000);
  while (bus->Handle(0) > 0) {
  }
  ASSERT_EQ(published.size(), 2u);
  const process_status_t& m = published[0];
  EXPECT_EQ(m.name, "unit");
  EXPECT_EQ(m.seq, 0);
  EXPECT_EQ(published[1].seq, 1);
  EXPECT_EQ(m.state, +process_status_t::STATE_RUNNING);  // unary + : LCM constants have no definition
  EXPECT_EQ(m.messages_rejected, 3);
  EXPECT_EQ(m.num_rejection_reasons, 2);
  EXPECT_EQ(m.dropped_inputs, 2);
  EXPECT_NEAR(m.latency_p50_ms, 50.5, 1.0);
  EXPECT_NEAR(m.latency_p99_ms, 99, 1.0);
  ASSERT_EQ(m.num_values, 1);
  EXPECT_EQ(m.value_name[0], "live_tracks");
  EXPECT_EQ(m.value[0], 900);
}

}  // namespace
}  // namespace objscan

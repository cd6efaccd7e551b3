#include "common/status.h"

#include <gtest/gtest.h>

#include <limits>

#include "common/bus.h"
#include "objscan/process_status_t.hpp"

namespace objscan {
namespace {

// A rejected input was received, not dropped, and does not move the stream on (a wild seq would block it).
TEST(StatusTest, RejectedSeqsAreNeitherDroppedNorMoveTheStreamOn) {
  StatusReporter status(nullptr, "unit");
  status.NoteRejectedSeq("img", 7);  // before the first usable one: no baseline, ignored
  EXPECT_EQ(status.ObserveSeq("img", 1), SeqResult::kFirst);
  status.NoteRejectedSeq("img", 2);
  status.NoteRejectedSeq("img", 2);  // the same twice
  status.NoteRejectedSeq("img", int64_t{1} << 50);
  EXPECT_EQ(status.ObserveSeq("img", 3), SeqResult::kNext);  // 2 came (rejected)
  EXPECT_EQ(status.dropped_inputs(), 0);
  status.NoteRejectedSeq("img", 1);                         // behind the stream: nothing
  EXPECT_EQ(status.ObserveSeq("img", 6), SeqResult::kGap);  // 4 and 5 never came
  EXPECT_EQ(status.dropped_inputs(), 2);
  for (int64_t s = 100; s < 300; ++s) status.NoteRejectedSeq("img", s);  // only the nearest 64 are kept
  EXPECT_EQ(status.ObserveSeq("img", 300), SeqResult::kGap);
  EXPECT_EQ(status.dropped_inputs(), 2 + (299 - 6) - 64);
}

// One forged or corrupted seq (INT64_MAX, a wild negative one) neither becomes the stream's reference (which would
// reject every later real input as old) nor counts billions of drops; a source that really jumped (restarted,
// replaced) is followed after kNewRunInputs consecutive inputs.
TEST(StatusTest, ForgedSequenceNumbersDoNotPoisonTheStream) {
  StatusReporter status(nullptr, "unit");
  EXPECT_EQ(status.ObserveSeq("img", 10), SeqResult::kFirst);
  EXPECT_EQ(status.ObserveSeq("img", std::numeric_limits<int64_t>::max()), SeqResult::kImplausibleJump);
  EXPECT_EQ(status.ObserveSeq("img", std::numeric_limits<int64_t>::min()), SeqResult::kImplausibleJump);
  EXPECT_EQ(status.ObserveSeq("img", 11), SeqResult::kNext);
  EXPECT_EQ(status.ObserveSeq("img", 13), SeqResult::kGap);
  EXPECT_EQ(status.dropped_inputs(), 1);
  EXPECT_EQ(status.ObserveSeq("img", 13 - kSeqReorderWindow), SeqResult::kRepeatedOrOld);  // late, not forged
  // A restarted source: 0, 1, 2 -> followed from the third on, nothing dropped.
  EXPECT_EQ(status.ObserveSeq("img", -kSeqReorderWindow - 100), SeqResult::kImplausibleJump);
  EXPECT_EQ(status.ObserveSeq("img", 14), SeqResult::kNext);  // the stream itself still goes on
  EXPECT_EQ(status.ObserveSeq("img", 100000000), SeqResult::kImplausibleJump);
  EXPECT_EQ(status.ObserveSeq("img", 100000001), SeqResult::kImplausibleJump);
  EXPECT_EQ(status.ObserveSeq("img", 100000002), SeqResult::kNewRun);
  EXPECT_EQ(status.ObserveSeq("img", 100000003), SeqResult::kNext);
  EXPECT_EQ(status.ObserveSeq("img", 14), SeqResult::kImplausibleJump);  // the old run's seqs are now far behind
  EXPECT_EQ(status.dropped_inputs(), 1);
  // INT64_MAX three times in a row is no run (no successor).
  EXPECT_EQ(status.ObserveSeq("odo", -1), SeqResult::kFirst);
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(status.ObserveSeq("odo", std::numeric_limits<int64_t>::max()), SeqResult::kImplausibleJump);
  EXPECT_EQ(status.ObserveSeq("odo", 1), SeqResult::kGap);
  EXPECT_EQ(status.dropped_inputs(), 2);
}

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

TEST(StatusTest, KeepsToTheFirstSessionAndRefusesOthers) {
  StatusReporter status(nullptr, "unit");
  EXPECT_EQ(status.session_id(), 0);
  EXPECT_TRUE(status.AcceptSession(0, "image"));  // unstamped: taken, latches nothing
  EXPECT_EQ(status.session_id(), 0);
  EXPECT_TRUE(status.AcceptSession(0x1234, "image"));  // the first stamped id is the session
  EXPECT_EQ(status.session_id(), 0x1234);
  EXPECT_TRUE(status.AcceptSession(0x1234, "odometry"));
  EXPECT_TRUE(status.AcceptSession(0, "odometry"));
  EXPECT_FALSE(status.AcceptSession(0x5678, "image"));  // another session on the bus
  EXPECT_FALSE(status.AcceptSession(0x5678, "image"));
  EXPECT_FALSE(status.AcceptSession(-7, "odometry"));
  EXPECT_EQ(status.session_id(), 0x1234);  // never moves to the intruder
  EXPECT_EQ(status.rejected("image: foreign session"), 2);
  EXPECT_EQ(status.rejected("odometry: foreign session"), 1);
}

TEST(StatusTest, SessionIdsFromText) {
  int64_t a = 0, b = 0, id = 0;
  std::string error;
  ASSERT_TRUE(SessionIdFromText("", &a, &error));
  ASSERT_TRUE(SessionIdFromText("", &b, &error));
  EXPECT_NE(a, 0);
  EXPECT_NE(a, b);  // drawn at random
  ASSERT_TRUE(SessionIdFromText("0x00ff", &id, &error));
  EXPECT_EQ(id, 255);
  ASSERT_TRUE(SessionIdFromText("ffffffffffffffff", &id, &error));
  EXPECT_EQ(id, -1);
  EXPECT_EQ(SessionIdText(id), "ffffffffffffffff");
  EXPECT_EQ(SessionIdText(255), "00000000000000ff");
  for (const char* bad : {"0", "0x", "xyz", "12345678901234567", "-5", "12 "}) {
    EXPECT_FALSE(SessionIdFromText(bad, &id, &error)) << bad;
    EXPECT_NE(error.find("hex digits"), std::string::npos) << bad;
  }
}

}  // namespace
}  // namespace objscan

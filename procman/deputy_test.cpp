#include "procman/deputy.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <thread>

namespace objscan {
namespace {

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Steps the deputy every 20 ms until done() or timeout_s; true when done.
bool StepUntil(Deputy* d, const std::function<bool()>& done, double timeout_s) {
  const double end = Now() + timeout_s;
  while (Now() < end) {
    d->Step(Now());
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

ProcessReport State(Deputy* d, const std::string& name) {
  for (const auto& p : d->Report(Now()).processes)
    if (p.name == name) return p;
  return ProcessReport();
}

class DeputyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "deputy_test_" + std::to_string(getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::unique_ptr<Deputy> Make(const std::string& text, const std::string& host = "robot") {
    std::string error;
    EXPECT_TRUE(ParseProcmanConfig(text, "test.cfg", &config_, &error)) << error;
    DeputyOptions o;
    o.host = host;
    o.log_dir = dir_;
    o.vars = {{"DIR", dir_}};
    o.first_respawn_delay_s = 0.3;
    return std::make_unique<Deputy>(config_, o);
  }
  DeputyOrders Orders(std::vector<ProcessOrder> processes, const std::string& host = "robot") {
    DeputyOrders o;
    o.host = host;
    o.config_hash = config_.hash;
    o.sheriff = "test";
    o.processes = std::move(processes);
    return o;
  }
  std::string dir_;
  ProcmanConfig config_;
};

const char* kTwoHosts =
    "process sleeper\n host = robot\n command = sleep 30\n"
    "process other\n host = workstation\n command = sleep 30\n";

TEST_F(DeputyTest, RunsOnlyItsHostsEntriesAndStartsAndStopsOnOrder) {
  auto d = Make(kTwoHosts);
  EXPECT_EQ(d->Entries(), std::vector<std::string>{"sleeper"});
  d->Step(Now());
  EXPECT_EQ(State(d.get(), "sleeper").state, ProcessState::kStopped);  // nothing runs before orders
  std::string error;
  ASSERT_TRUE(d->HandleOrders(Orders({{"sleeper", true, 1}}), Now(), &error)) << error;
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "sleeper").state == ProcessState::kRunning; }, 2));
  const ProcessReport running = State(d.get(), "sleeper");
  EXPECT_GT(running.pid, 0);
  EXPECT_EQ(running.run_id, 1);
  EXPECT_EQ(kill(running.pid, 0), 0);
  // The same orders again (stateless repetition) change nothing.
  ASSERT_TRUE(d->HandleOrders(Orders({{"sleeper", true, 1}}), Now(), &error));
  d->Step(Now());
  EXPECT_EQ(State(d.get(), "sleeper").pid, running.pid);
  // Orders for the other host are not this deputy's business: ignored, not refused.
  ASSERT_TRUE(d->HandleOrders(Orders({{"other", true, 1}}, "workstation"), Now(), &error));
  EXPECT_EQ(d->Report(Now()).orders_refused, 0);
  ASSERT_TRUE(d->HandleOrders(Orders({{"sleeper", false, 1}}), Now(), &error));
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "sleeper").state == ProcessState::kStopped; }, 3));
  EXPECT_NE(kill(running.pid, 0), 0);
  EXPECT_EQ(d->Report(Now()).orders_accepted, 3);
}

TEST_F(DeputyTest, RefusesOrdersForAnotherConfigOrAnotherHostsEntry) {
  auto d = Make(kTwoHosts);
  std::string error;
  DeputyOrders forged = Orders({{"sleeper", true, 1}});
  forged.config_hash = "0123456789abcdef";
  EXPECT_FALSE(d->HandleOrders(forged, Now(), &error));
  EXPECT_NE(error.find("same config file"), std::string::npos) << error;
  EXPECT_FALSE(d->HandleOrders(Orders({{"other", true, 1}}), Now(), &error));
  EXPECT_NE(error.find("an entry of host workstation"), std::string::npos) << error;
  EXPECT_FALSE(d->HandleOrders(Orders({{"rm -rf /", true, 1}}), Now(), &error));
  EXPECT_NE(error.find("not in the config"), std::string::npos) << error;
  // A refused order changes nothing, even for the valid entries it names.
  EXPECT_FALSE(d->HandleOrders(Orders({{"sleeper", true, 1}, {"nope", true, 1}}), Now(), &error));
  d->Step(Now());
  const DeputyReport r = d->Report(Now());
  EXPECT_EQ(r.orders_refused, 4);
  EXPECT_EQ(r.orders_accepted, 0);
  EXPECT_NE(r.last_refusal.find("nope"), std::string::npos);
  EXPECT_EQ(r.processes[0].state, ProcessState::kStopped);
}

TEST_F(DeputyTest, ACrashIsRespawnedWithBackOffOnlyWhenTheEntrySaysSo) {
  auto d = Make(
      "process flaky\n host = robot\n command = sh -c 'exit 3'\n respawn = true\n"
      "process fragile\n host = robot\n command = sh -c 'kill -9 $$'\n");
  std::string error;
  ASSERT_TRUE(d->HandleOrders(Orders({{"flaky", true, 1}, {"fragile", true, 1}}), Now(), &error)) << error;
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "flaky").restarts >= 2; }, 5));
  const ProcessReport flaky = State(d.get(), "flaky");
  EXPECT_EQ(flaky.exit_code, 3);
  EXPECT_EQ(flaky.run_id, 1);
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "fragile").state == ProcessState::kCrashed; }, 2));
  const ProcessReport fragile = State(d.get(), "fragile");
  EXPECT_EQ(fragile.exit_signal, SIGKILL);
  EXPECT_NE(fragile.message.find("SIGKILL"), std::string::npos) << fragile.message;
  EXPECT_EQ(fragile.restarts, 0);
  // Back-off: 0.3, 0.6, 1.2 s ... the third restart cannot come within 0.8 s of the second.
  const double second = Now();
  StepUntil(d.get(), [&] { return State(d.get(), "flaky").restarts >= 3; }, 3);
  EXPECT_GE(Now() - second, 0.8);
  // A stop order cancels a pending respawn; a new run id starts the crashed one again.
  ASSERT_TRUE(d->HandleOrders(Orders({{"flaky", false, 1}, {"fragile", true, 2}}), Now(), &error));
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "fragile").run_id == 2; }, 2));
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "flaky").state == ProcessState::kStopped; }, 2));
}

TEST_F(DeputyTest, AProcessIgnoringItsStopSignalIsKilledAfterItsGraceTime) {
  auto d = Make(
      "process stubborn\n host = robot\n command = sh -c 'trap \"\" INT; echo ready; while true; do sleep 0.05; done'\n"
      " grace_s = 0.5\n");
  std::string error;
  ASSERT_TRUE(d->HandleOrders(Orders({{"stubborn", true, 1}}), Now(), &error));
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "stubborn").state == ProcessState::kRunning; }, 2));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the trap is set
  ASSERT_TRUE(d->HandleOrders(Orders({{"stubborn", false, 1}}), Now(), &error));
  const double stop = Now();
  d->Step(Now());
  EXPECT_EQ(State(d.get(), "stubborn").state, ProcessState::kStopping);
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "stubborn").state == ProcessState::kStopped; }, 3));
  EXPECT_GE(Now() - stop, 0.5);
  EXPECT_NE(State(d.get(), "stubborn").message.find("SIGKILL"), std::string::npos);
}

TEST_F(DeputyTest, ANewRunIdRestartsARunningProcess) {
  auto d = Make("process sleeper\n host = robot\n command = sleep 30\n");
  std::string error;
  ASSERT_TRUE(d->HandleOrders(Orders({{"sleeper", true, 1}}), Now(), &error));
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "sleeper").state == ProcessState::kRunning; }, 2));
  const int first = State(d.get(), "sleeper").pid;
  ASSERT_TRUE(d->HandleOrders(Orders({{"sleeper", true, 2}}), Now(), &error));
  ASSERT_TRUE(StepUntil(d.get(), [&] {
    const ProcessReport r = State(d.get(), "sleeper");
    return r.state == ProcessState::kRunning && r.run_id == 2;
  }, 3));
  EXPECT_NE(State(d.get(), "sleeper").pid, first);
  EXPECT_NE(kill(first, 0), 0);
  EXPECT_EQ(State(d.get(), "sleeper").restarts, 0);  // ordered, not a respawn
}

TEST_F(DeputyTest, EnvironmentWorkingDirectoryAndFollowedOutput) {
  auto d = Make(
      "process talker\n host = robot\n command = sh -c 'echo \"$GREETING from $(pwd)\"; sleep 30'\n"
      " cwd = ${DIR}\n env = GREETING=hello\n");
  std::string error;
  ASSERT_TRUE(d->HandleOrders(Orders({{"talker", true, 1, /*follow_output=*/true}}), Now(), &error));
  std::string text;
  ASSERT_TRUE(StepUntil(d.get(), [&] {
    for (const auto& [name, chunk] : d->TakeOutput(4096)) text += chunk;
    return text.find('\n') != std::string::npos;
  }, 3)) << text;
  EXPECT_EQ(text, "hello from " + std::filesystem::canonical(dir_).string() + "\n");
  EXPECT_TRUE(d->TakeOutput(4096).empty());  // nothing new
}

TEST_F(DeputyTest, WhatCannotStartIsReportedAsFailed) {
  auto d = Make(
      "process missing\n host = robot\n command = /nonexistent/tracker\n"
      "process unset\n host = robot\n command = ${BIN}/tracker\n"
      "process nowhere\n host = robot\n command = sleep 1\n cwd = /nonexistent\n");
  std::string error;
  ASSERT_TRUE(d->HandleOrders(Orders({{"missing", true, 1}, {"unset", true, 1}, {"nowhere", true, 1}}), Now(), &error));
  d->Step(Now());
  const ProcessReport missing = State(d.get(), "missing"), unset = State(d.get(), "unset"),
                      nowhere = State(d.get(), "nowhere");
  EXPECT_EQ(missing.state, ProcessState::kFailed);
  EXPECT_NE(missing.message.find("not an executable"), std::string::npos) << missing.message;
  EXPECT_EQ(unset.state, ProcessState::kFailed);
  EXPECT_NE(unset.message.find("${BIN}"), std::string::npos) << unset.message;
  EXPECT_EQ(nowhere.state, ProcessState::kFailed);
  EXPECT_NE(nowhere.message.find("/nonexistent"), std::string::npos) << nowhere.message;
  // Not retried for the same run.
  d->Step(Now());
  EXPECT_EQ(State(d.get(), "missing").restarts, 0);
}

TEST_F(DeputyTest, StopAllStopsEverythingAndReportsUsage) {
  auto d = Make("process a\n host = robot\n command = sleep 30\nprocess b\n host = robot\n command = sleep 30\n");
  std::string error;
  ASSERT_TRUE(d->HandleOrders(Orders({{"a", true, 1}, {"b", true, 1}}), Now(), &error));
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "b").state == ProcessState::kRunning; }, 2));
  // Usage is read from /proc when reported: a child still in its exec reads 0 kB (the full ctest, 7 Dec), so the
  // report is awaited, not assumed at the first running step.
  ASSERT_TRUE(StepUntil(d.get(), [&] { return State(d.get(), "a").rss_kb > 0; }, 2)) << "no memory usage reported";
  const ProcessReport a = State(d.get(), "a");
  d->StopAll();
  EXPECT_NE(kill(a.pid, 0), 0);
  for (const auto& p : d->Report(Now()).processes) EXPECT_EQ(p.state, ProcessState::kStopped) << p.name;
}

}  // namespace
}  // namespace objscan

#include "procman/sheriff.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <thread>

namespace objscan {
namespace {

const char* kConfig =
    "group robot\n"
    "process sim\n host = robot\n command = sleep 30\n after = tracker\n"
    "process tracker\n host = robot\n command = sleep 30\n respawn = true\n"
    "group workstation\n"
    "process modeler\n host = workstation\n command = sleep 30\n";

ProcmanConfig Config(const char* text = kConfig) {
  ProcmanConfig c;
  std::string error;
  EXPECT_TRUE(ParseProcmanConfig(text, "test.cfg", &c, &error)) << error;
  return c;
}

const ProcessOrder* Find(const std::vector<DeputyOrders>& orders, const std::string& name) {
  for (const auto& o : orders)
    for (const auto& p : o.processes)
      if (p.name == name) return &p;
  return nullptr;
}

TEST(Sheriff, StartsInOrderWaitingForAfterProcessesToReport) {
  Sheriff s(Config(), {});
  EXPECT_TRUE(s.Orders(0).empty());  // nothing touched, nothing heard: no orders (a running system stays as it is)
  std::string error;
  ASSERT_TRUE(s.Start("all", 1.0, &error)) << error;
  const auto orders = s.Orders(1.0);
  ASSERT_EQ(orders.size(), 2u);
  EXPECT_EQ(orders[0].host, "robot");
  EXPECT_EQ(orders[0].config_hash, s.config().hash);
  ASSERT_NE(Find(orders, "tracker"), nullptr);
  EXPECT_TRUE(Find(orders, "tracker")->run);
  EXPECT_TRUE(Find(orders, "modeler")->run);
  EXPECT_FALSE(Find(orders, "sim")->run);  // waits for the tracker's PROCESS_STATUS
  EXPECT_EQ(s.Entries(1.0)[0].waiting_for, std::vector<std::string>{"tracker"});
  s.OnProcessStatus("tracker", 0.5);  // heard before the tracker's start: an old run's
  EXPECT_FALSE(Find(s.Orders(1.0), "sim")->run);
  s.OnProcessStatus("tracker", 2.0);
  EXPECT_TRUE(Find(s.Orders(2.0), "sim")->run);
  EXPECT_TRUE(s.Entries(2.0)[0].waiting_for.empty());
}

TEST(Sheriff, StopAndRestartAGroupOrAProcessAndNameWhatIsUnknown) {
  Sheriff s(Config(), {});
  std::string error;
  ASSERT_TRUE(s.Start("all", 1.0, &error));
  const int32_t first = Find(s.Orders(1), "modeler")->run_id;
  ASSERT_TRUE(s.Stop("robot", 2.0, &error));
  EXPECT_FALSE(Find(s.Orders(2), "tracker")->run);
  EXPECT_TRUE(Find(s.Orders(2), "modeler")->run);
  ASSERT_TRUE(s.Restart("modeler", 3.0, &error));
  EXPECT_GT(Find(s.Orders(3), "modeler")->run_id, first);
  EXPECT_FALSE(s.Start("trackr", 3.0, &error));
  EXPECT_NE(error.find("'trackr' is neither a process nor a group"), std::string::npos) << error;
  EXPECT_NE(error.find("robot workstation"), std::string::npos) << error;
  EXPECT_FALSE(s.Follow("nope", &error));
  ASSERT_TRUE(s.Follow("modeler", &error));
  EXPECT_TRUE(Find(s.Orders(3), "modeler")->follow_output);
  EXPECT_FALSE(Find(s.Orders(3), "tracker")->follow_output);
}

TEST(Sheriff, ANewSheriffTakesOverRunningProcessesInsteadOfRestartingThem) {
  Sheriff s(Config(), {});
  DeputyReport report;
  report.host = "workstation";
  report.config_hash = s.config().hash;
  ProcessReport modeler;
  modeler.name = "modeler";
  modeler.state = ProcessState::kRunning;
  modeler.desired_run = true;
  modeler.desired_run_id = 7;
  modeler.run_id = 7;
  report.processes.push_back(modeler);
  s.OnDeputyReport(report, 1.0);
  const auto orders = s.Orders(1.0);
  ASSERT_NE(Find(orders, "modeler"), nullptr);
  EXPECT_TRUE(Find(orders, "modeler")->run);
  EXPECT_EQ(Find(orders, "modeler")->run_id, 7);
  EXPECT_EQ(Find(orders, "tracker"), nullptr);  // its deputy not heard yet: left alone
  std::string error;
  ASSERT_TRUE(s.Start("all", 2.0, &error));
  EXPECT_EQ(Find(s.Orders(2.0), "modeler")->run_id, 7);  // running: start keeps it
  EXPECT_GT(Find(s.Orders(2.0), "tracker")->run_id, 7);  // new run ids above every one seen
}

TEST(Sheriff, SilentAndForeignDeputies) {
  SheriffOptions o;
  o.deputy_timeout_s = 3.0;
  Sheriff s(Config(), o);
  DeputyReport robot;
  robot.host = "robot";
  robot.config_hash = s.config().hash;
  robot.orders_refused = 2;
  robot.last_refusal = "orders for config x";
  s.OnDeputyReport(robot, 10.0);
  DeputyReport other;
  other.host = "robot2";
  other.config_hash = "ffffffffffffffff";
  s.OnDeputyReport(other, 10.0);
  auto deputies = s.Deputies(12.0);
  ASSERT_EQ(deputies.size(), 3u);
  EXPECT_EQ(deputies[0].host, "robot");
  EXPECT_FALSE(deputies[0].silent);
  EXPECT_EQ(deputies[0].orders_refused, 2);
  EXPECT_EQ(deputies[1].host, "workstation");
  EXPECT_TRUE(deputies[1].silent);  // never heard
  EXPECT_FALSE(deputies[1].heard);
  EXPECT_TRUE(deputies[2].foreign);
  EXPECT_TRUE(s.Deputies(13.5)[0].silent);
  std::string error;
  ASSERT_TRUE(s.Start("all", 11.0, &error));
  for (const auto& orders : s.Orders(11.0)) EXPECT_NE(orders.host, "robot2");
}

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The sheriff and two deputies wired directly (no bus): start all, the tracker is killed and respawned, the sim starts
// only after the tracker "reports", stop all.
TEST(Sheriff, DrivesTwoDeputies) {
  const std::string dir = ::testing::TempDir() + "sheriff_test_" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  const ProcmanConfig config = Config();
  Sheriff s(config, {});
  DeputyOptions ro, wo;
  ro.host = "robot";
  wo.host = "workstation";
  ro.log_dir = wo.log_dir = dir;
  ro.first_respawn_delay_s = 0.2;
  Deputy robot(config, ro), workstation(config, wo);
  auto cycle = [&] {
    const double now = Now();
    std::string error;
    for (const auto& o : s.Orders(now)) {
      EXPECT_TRUE(robot.HandleOrders(o, now, &error)) << error;
      EXPECT_TRUE(workstation.HandleOrders(o, now, &error)) << error;
    }
    robot.Step(now);
    workstation.Step(now);
    s.OnDeputyReport(robot.Report(now), now);
    s.OnDeputyReport(workstation.Report(now), now);
  };
  auto until = [&](const std::function<bool()>& done, double timeout_s) {
    const double end = Now() + timeout_s;
    while (Now() < end) {
      cycle();
      if (done()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  };
  std::string error;
  ASSERT_TRUE(s.Start("all", Now(), &error));
  ASSERT_TRUE(until([&] { return s.Running("tracker") && s.Running("modeler"); }, 3));
  EXPECT_FALSE(s.Running("sim"));
  s.OnProcessStatus("tracker", Now());
  ASSERT_TRUE(until([&] { return s.Running("all"); }, 3));
  const int tracker_pid = s.Entries(Now())[1].report.pid;
  ASSERT_GT(tracker_pid, 0);
  kill(tracker_pid, SIGKILL);
  ASSERT_TRUE(until([&] {
    const auto e = s.Entries(Now())[1];
    return e.report.restarts == 1 && e.report.state == ProcessState::kRunning;
  }, 3));
  EXPECT_NE(s.Entries(Now())[1].report.pid, tracker_pid);
  ASSERT_TRUE(s.Stop("all", Now(), &error));
  ASSERT_TRUE(until([&] {
    for (const auto& e : s.Entries(Now()))
      if (e.report.state != ProcessState::kStopped) return false;
    return true;
  }, 8));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace objscan

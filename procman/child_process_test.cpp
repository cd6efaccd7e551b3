#include "procman/child_process.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <thread>

namespace objscan {
namespace {

std::string TempLog(const std::string& name) { return ::testing::TempDir() + "objscan_cp_test_" + std::to_string(getpid()) + name; }

TEST(ChildProcessTest, ReportsExitCodeAndCapturesOutput) {
  ChildProcess p("sh", {"/bin/sh", "-c", "echo hello from child; exit 3"}, TempLog("a.log"));
  std::string error;
  ASSERT_TRUE(p.Start(&error)) << error;
  for (int i = 0; i < 500 && p.Running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_FALSE(p.Running());
  EXPECT_EQ(p.exit_code(), 3);
  EXPECT_NE(p.LogTail(5).find("hello from child"), std::string::npos);
}

TEST(ChildProcessTest, StopEscalatesFromSigintToSigkill) {
  // Ignores SIGINT and SIGTERM: Stop must still end it.
  ChildProcess p("stubborn", {"/bin/sh", "-c", "trap '' INT TERM; while true; do sleep 0.05; done"},
                 TempLog("b.log"));
  std::string error;
  ASSERT_TRUE(p.Start(&error)) << error;
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(p.Running());
  p.Stop(200);
  EXPECT_FALSE(p.Running());
  EXPECT_EQ(p.exit_code(), 128 + 9);
}

TEST(ChildProcessTest, MissingExecutableIsAClearError) {
  ChildProcess p("ghost", {"/nonexistent/bin/ghost"}, TempLog("c.log"));
  std::string error;
  EXPECT_FALSE(p.Start(&error));
  EXPECT_NE(error.find("not an executable"), std::string::npos);
}

}  // namespace
}  // namespace objscan

#include "procman/config.h"

#include <gtest/gtest.h>
#include <signal.h>

#include <cstdlib>

namespace objscan {
namespace {

const char* kConfig = R"(# two hosts
group robot
process robot_sim
  host = robot
  command = ${BIN}/robot_sim --lcm-url '${LCM_URL}' --scene room_01   # the simulator
  after = tracker
process tracker
  host = robot
  command = ${BIN}/tracker --lcm-url ${LCM_URL}
  respawn = true
  stop_signal = SIGTERM
  grace_s = 2.5
group workstation
process dense_modeler
  host = workstation
  command = ${BIN}/dense_modeler
  cwd = ${OUT}
  env = OMP_NUM_THREADS=1
  env = OBJSCAN_OUT=${OUT}
)";

TEST(ProcmanConfig, ParsesGroupsHostsAndEveryKey) {
  ProcmanConfig c;
  std::string error;
  ASSERT_TRUE(ParseProcmanConfig(kConfig, "test.cfg", &c, &error)) << error;
  ASSERT_EQ(c.entries.size(), 3u);
  EXPECT_EQ(c.Hosts(), (std::vector<std::string>{"robot", "workstation"}));
  EXPECT_EQ(c.Groups(), (std::vector<std::string>{"robot", "workstation"}));
  const ProcmanEntry* sim = c.Find("robot_sim");
  ASSERT_NE(sim, nullptr);
  EXPECT_EQ(sim->line, 3);
  EXPECT_EQ(sim->after, std::vector<std::string>{"tracker"});
  EXPECT_FALSE(sim->respawn);
  EXPECT_EQ(sim->stop_signal, SIGINT);
  EXPECT_DOUBLE_EQ(sim->grace_s, 5.0);
  const ProcmanEntry* tracker = c.Find("tracker");
  EXPECT_TRUE(tracker->respawn);
  EXPECT_EQ(tracker->stop_signal, SIGTERM);
  EXPECT_DOUBLE_EQ(tracker->grace_s, 2.5);
  EXPECT_EQ(c.Find("dense_modeler")->env.size(), 2u);
  EXPECT_EQ(c.hash, ConfigHash(kConfig));
  EXPECT_EQ(c.hash.size(), 16u);
  EXPECT_NE(c.hash, ConfigHash(std::string(kConfig) + " "));
}

TEST(ProcmanConfig, ResolvesVariablesPerHostAndNamesAMissingOne) {
  ProcmanConfig c;
  std::string error;
  ASSERT_TRUE(ParseProcmanConfig(kConfig, "test.cfg", &c, &error)) << error;
  ResolvedCommand r;
  const std::map<std::string, std::string> vars = {
      {"BIN", "/opt/objscan/bin"}, {"LCM_URL", "udpm://239.255.76.67:7667?ttl=1"}, {"OUT", "/data/run 1"}};
  ASSERT_TRUE(ResolveCommand(*c.Find("robot_sim"), vars, &r, &error)) << error;
  EXPECT_EQ(r.argv, (std::vector<std::string>{"/opt/objscan/bin/robot_sim", "--lcm-url",
                                              "udpm://239.255.76.67:7667?ttl=1", "--scene", "room_01"}));
  ASSERT_TRUE(ResolveCommand(*c.Find("dense_modeler"), vars, &r, &error)) << error;
  EXPECT_EQ(r.cwd, "/data/run 1");
  EXPECT_EQ(r.env, (std::vector<std::string>{"OMP_NUM_THREADS=1", "OBJSCAN_OUT=/data/run 1"}));
  EXPECT_FALSE(ResolveCommand(*c.Find("tracker"), {{"BIN", "/b"}}, &r, &error));
  EXPECT_NE(error.find("${LCM_URL}"), std::string::npos) << error;
  EXPECT_NE(error.find("line 7"), std::string::npos) << error;
  EXPECT_NE(error.find("add LCM_URL=... to its command line"), std::string::npos) << error;
}

TEST(ProcmanConfig, BadFilesGiveTheLineAndWhatIsWrong) {
  struct Case {
    const char* text;
    const char* expected;  // part of the error
  };
  const Case cases[] = {
      {"process a\n  host = h\n  comand = x\n", "test.cfg:3: unknown key 'comand'"},
      {"process a\n  command = x\n", "test.cfg:1: process a has no 'host = ...'"},
      {"process a\n  host = h\n", "test.cfg:1: process a has no 'command = ...'"},
      {"process a\n host = h\n command = x\nprocess a\n host = h\n command = y\n", "test.cfg:4: process a is defined twice"},
      {"process a\n host = h\n command = x\n stop_signal = SIGSTOP\n", "test.cfg:4: stop_signal must be"},
      {"process a\n host = h\n command = x\n grace_s = 0\n", "test.cfg:4: grace_s must be"},
      {"process a\n host = h\n command = x\n grace_s = 2s\n", "test.cfg:4: grace_s must be"},
      {"process a\n host = h\n command = x\n respawn = yes\n", "test.cfg:4: respawn must be true or false"},
      {"process a\n host = h\n command = x\n after = b\n", "test.cfg:1: process a: after names unknown process 'b'"},
      {"process a\n host = h\n command = x\n after = b\nprocess b\n host = h\n command = y\n after = a\n",
       "'after' forms a cycle"},
      {"host = h\n", "test.cfg:1: 'host = ...' outside a process"},
      {"process a\n host = two words\n command = x\n", "test.cfg:2: host takes one value"},
      {"process a\n host = h\n command = 'x\n", "test.cfg:3: unterminated quote"},
      {"process a b\n", "test.cfg:1: expected 'process NAME'"},
      {"proces a\n", "test.cfg:1: expected 'group NAME', 'process NAME' or 'KEY = VALUE'"},
      {"process a\n host = h\n command = x\n env = =1\n", "test.cfg:4: env must be KEY=VALUE"},
      {"# nothing\n\n", "test.cfg:2: no process defined"},
  };
  for (const Case& c : cases) {
    ProcmanConfig config;
    std::string error;
    EXPECT_FALSE(ParseProcmanConfig(c.text, "test.cfg", &config, &error)) << c.text;
    EXPECT_NE(error.find(c.expected), std::string::npos) << "got: " << error << "\nexpected: " << c.expected;
  }
  ProcmanConfig config;
  std::string error;
  EXPECT_FALSE(ReadProcmanConfig("/nonexistent/x.cfg", &config, &error));
  EXPECT_NE(error.find("cannot read procman config /nonexistent/x.cfg"), std::string::npos);
}

// The configs the project ships parse, and every command resolves with the variables their users give.
TEST(ProcmanConfig, ShippedConfigsAreValid) {
  const char* source = std::getenv("OBJSCAN_SOURCE_DIR");
  ASSERT_NE(source, nullptr) << "run through ctest (OBJSCAN_SOURCE_DIR)";
  const std::map<std::string, std::string> vars = {
      {"BIN", "/b"}, {"LCM_URL", "udpm://239.255.76.67:7667?ttl=1"}, {"OUT", "/o"}, {"SCENE", "room_01"},
      {"FRAMES", "100"}};
  for (const char* name : {"single_host.cfg", "robot_workstation.cfg"}) {
    ProcmanConfig c;
    std::string error;
    ASSERT_TRUE(ReadProcmanConfig(std::string(source) + "/procman/" + name, &c, &error)) << error;
    for (const auto& e : c.entries) {
      ResolvedCommand r;
      EXPECT_TRUE(ResolveCommand(e, vars, &r, &error)) << name << ": " << error;
    }
  }
}

}  // namespace
}  // namespace objscan

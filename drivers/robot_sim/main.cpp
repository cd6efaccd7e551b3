// robot_sim: the simulated robot. Renders the camera view of a scene while driving an orbit around the target (or
// following ROBOT_COMMAND) and publishes CAMERA_IMAGE, CAMERA_INFO, ROBOT_ODOMETRY, GROUND_TRUTH_POSE and
// END_OF_STREAM. The node publishes from Tick(); RunNode with a 1 ms tick drives it (see robot_sim_node.h).
#include <cstdio>
#include <exception>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "common/options.h"
#include "drivers/robot_sim/robot_sim_node.h"

int main(int argc, char** argv) {
  using namespace objscan;
  RobotSimNodeOptions options;
  std::string lcm_url = kDefaultLcmUrl;
  std::string lcm_url_out;
  OptionParser parser("robot_sim",
                      "Simulated robot: publishes CAMERA_IMAGE, CAMERA_INFO, ROBOT_ODOMETRY, GROUND_TRUTH_POSE per "
                      "frame and END_OF_STREAM on OBJSCAN_CONTROL; follows ROBOT_COMMAND in --mode command.");
  parser.Add("lcm-url", &lcm_url, "LCM URL of the bus (input, and output unless --lcm-url-out is set)");
  parser.Add("lcm-url-out", &lcm_url_out, "separate LCM URL for the output (empty = --lcm-url)");
  AddRobotSimNodeOptions(parser, &options);
  int exit_code = 0;
  if (!ParseCommandLineOrExit(parser, argc, argv, &exit_code)) return exit_code;
  std::string why;
  if (!ValidateRobotSimNodeOptions(options, &why)) {
    std::fprintf(stderr, "error: %s\n", why.c_str());
    return 2;
  }
  std::fprintf(stderr, "%s", parser.Effective().c_str());
  SetLogName(RobotSimNode::kProcessName);
  try {
    auto bus = MakeBus(lcm_url, lcm_url_out);
    RobotSimNode node(*bus, options);
    RunOptions run;
    run.tick_ms = 1;
    run.stop_at_end_of_log = false;  // the input bus only carries commands / lockstep messages
    return RunNode(*bus, node, run);
  } catch (const std::exception& e) {
    LogError(e.what());
    return 1;
  }
}

// pose_solver: FEATURE_TRACKS + CAMERA_INFO + ROBOT_ODOMETRY in, CAMERA_POSE / LANDMARKS / CAMERA_POSE_FINAL out.
#include <cstdio>
#include <exception>
#include <string>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "common/options.h"
#include "processes/pose_solver/pose_solver_node.h"

int main(int argc, char** argv) {
  objscan::PoseSolverNodeOptions options;
  std::string lcm_url = objscan::kDefaultLcmUrl;
  std::string lcm_url_out;
  objscan::OptionParser parser("pose_solver",
                               "camera poses and sparse landmarks from feature tracks (+ odometry): FEATURE_TRACKS "
                               "in, CAMERA_POSE and LANDMARKS out");
  parser.Add("lcm-url", &lcm_url, "LCM URL to read (and write, unless --lcm-url-out is set)");
  parser.Add("lcm-url-out", &lcm_url_out, "separate LCM URL for output (e.g. when replaying a file:// log)");
  objscan::AddPoseSolverNodeOptions(parser, &options);
  int exit_code = 0;
  if (!objscan::ParseCommandLineOrExit(parser, argc, argv, &exit_code)) return exit_code;
  std::string why;
  if (!objscan::ValidatePoseSolverNodeOptions(options, &why)) {
    std::fprintf(stderr, "error: %s\n", why.c_str());
    return 2;
  }
  std::fprintf(stderr, "%s", parser.Effective().c_str());
  objscan::SetLogName(options.name);
  try {
    auto bus = objscan::MakeBus(lcm_url, lcm_url_out);
    objscan::LogInfo("bus " + bus->Describe());
    objscan::PoseSolverNode node(*bus, options);
    return objscan::RunNode(*bus, node);
  } catch (const std::exception& e) {
    objscan::LogError(e.what());
    return 1;
  }
}

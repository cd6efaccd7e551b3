// camera: publishes the frames of an image folder, Middlebury folder, video file or V4L2 device on the bus.
#include <cstdio>
#include <exception>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "common/options.h"
#include "drivers/camera/camera_node.h"

int main(int argc, char** argv) {
  using namespace objscan;
  CameraNodeOptions options;
  std::string lcm_url = kDefaultLcmUrl;
  std::string lcm_url_out;
  OptionParser parser("camera",
                      "Camera / dataset driver: publishes CAMERA_IMAGE, CAMERA_INFO, GROUND_TRUTH_POSE (when the "
                      "source has true poses) and END_OF_STREAM on OBJSCAN_CONTROL.");
  parser.Add("lcm-url", &lcm_url, "LCM URL of the bus (input, and output unless --lcm-url-out is set)");
  parser.Add("lcm-url-out", &lcm_url_out, "separate LCM URL for the output (empty = --lcm-url)");
  AddCameraNodeOptions(parser, &options);
  int exit_code = 0;
  if (!ParseCommandLineOrExit(parser, argc, argv, &exit_code)) return exit_code;
  std::string why;
  if (!ValidateCameraNodeOptions(options, &why)) {
    std::fprintf(stderr, "error: %s\n", why.c_str());
    return 2;
  }
  std::fprintf(stderr, "%s", parser.Effective().c_str());
  SetLogName(CameraNode::kProcessName);
  try {
    auto bus = MakeBus(lcm_url, lcm_url_out);
    CameraNode node(*bus, options);
    RunOptions run;
    run.tick_ms = node.SuggestedTickMs();
    return RunNode(*bus, node, run);
  } catch (const std::exception& e) {
    LogError(e.what());
    return 1;
  }
}

// dense_modeler: dense reconstruction process. CAMERA_IMAGE, CAMERA_INFO, FEATURE_TRACKS, CAMERA_POSE(_FINAL),
// TARGET in; VOXEL_MAP, MODEL (+ files in --output-dir) out.
#include <cstdio>
#include <exception>
#include <string>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "common/options.h"
#include "processes/dense_modeler/dense_modeler_node.h"

int main(int argc, char** argv) {
  objscan::DenseModelerNodeOptions options;
  std::string lcm_url = objscan::kDefaultLcmUrl;
  std::string lcm_url_out;
  objscan::OptionParser parser("dense_modeler",
                               "dense modeler: posed images and tracks in, VOXEL_MAP and MODEL (files) out");
  parser.Add("lcm-url", &lcm_url, "LCM URL to read (and write, unless --lcm-url-out is set)");
  parser.Add("lcm-url-out", &lcm_url_out, "separate LCM URL for output (e.g. when replaying a file:// log)");
  objscan::AddDenseModelerNodeOptions(parser, &options);
  int exit_code = 0;
  if (!objscan::ParseCommandLineOrExit(parser, argc, argv, &exit_code)) return exit_code;
  std::string why;
  if (!objscan::ValidateDenseModelerNodeOptions(options, &why)) {
    std::fprintf(stderr, "error: %s\n", why.c_str());
    return 2;
  }
  std::fprintf(stderr, "%s", parser.Effective().c_str());
  objscan::SetLogName(options.name);
  try {
    auto bus = objscan::MakeBus(lcm_url, lcm_url_out);
    objscan::LogInfo("bus " + bus->Describe());
    objscan::DenseModelerNode node(*bus, options);
    return objscan::RunNode(*bus, node);
  } catch (const std::exception& e) {
    objscan::LogError(e.what());
    return 1;
  }
}

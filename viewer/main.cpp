// viewer: native LCM viewer (3-D scene + panels) for a live bus or a log file; headless screenshots and a voxel
// rendering benchmark. See viewer/README.md.
#include <cstdio>
#include <string>

#include "common/log.h"
#include "common/node.h"
#include "common/options.h"
#include "viewer/viewer_app.h"

int main(int argc, char** argv) {
  objscan::ViewerOptions options;
  objscan::OptionParser parser("viewer", "objscan viewer: live LCM bus (--lcm-url) or log file (--log)");
  objscan::AddViewerOptions(parser, &options);
  int exit_code = 0;
  if (!objscan::ParseCommandLineOrExit(parser, argc, argv, &exit_code)) return exit_code;
  std::string why;
  if (!objscan::ValidateViewerOptions(options, &why)) {
    std::fprintf(stderr, "error: %s\n", why.c_str());
    return 2;
  }
  std::fprintf(stderr, "%s", parser.Effective().c_str());
  objscan::SetLogName(options.name);
  objscan::InstallStopSignalHandlers();
  return objscan::RunViewer(options);
}

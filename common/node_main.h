// The body of a process's main(): command line (--lcm-url, --lcm-url-out and the node's own options), validation,
// the effective configuration on stderr, the bus, the node, RunNode. One place for what every process does the same.
#pragma once

#include <cstdio>
#include <exception>
#include <string>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "common/options.h"

namespace objscan {

// NodeT is constructed as NodeT(Bus&, const Options&); Options has a `name` (process name). add() registers the
// node's options on the parser; validate() explains what is wrong. Returns the process exit code: 0 after a clean
// stop, 2 for bad options, 1 when the bus or the node cannot be made (the error is logged). Blocks until the node
// stops (end of stream where the node does that, SIGINT or SIGTERM).
template <class NodeT, class Options>
int NodeMain(int argc, char** argv, const char* program, const char* description, void (*add)(OptionParser&, Options*),
             bool (*validate)(const Options&, std::string*)) {
  Options options;
  std::string lcm_url = kDefaultLcmUrl;
  std::string lcm_url_out;
  OptionParser parser(program, description);
  parser.Add("lcm-url", &lcm_url, "LCM URL to read (and write, unless --lcm-url-out is set)");
  parser.Add("lcm-url-out", &lcm_url_out, "separate LCM URL for output (e.g. when replaying a file:// log)");
  add(parser, &options);
  int exit_code = 0;
  if (!ParseCommandLineOrExit(parser, argc, argv, &exit_code)) return exit_code;
  std::string why;
  if (!validate(options, &why)) {
    std::fprintf(stderr, "error: %s\n", why.c_str());
    return 2;
  }
  std::fprintf(stderr, "%s", parser.Effective().c_str());
  SetLogName(options.name);
  try {
    auto bus = MakeBus(lcm_url, lcm_url_out);
    LogInfo("bus " + bus->Describe());
    NodeT node(*bus, options);
    return RunNode(*bus, node);
  } catch (const std::exception& e) {
    LogError(e.what());
    return 1;
  }
}

}  // namespace objscan

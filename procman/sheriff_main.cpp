// objscan-sheriff: starts, stops and watches the processes of a procman config on every host, through the deputies.
//   objscan-sheriff CONFIG [--lcm-url URL] [--observe] [--status] [--script "start all; wait-running all 20; ..."]
// Without --script or --status: a table refreshed every second and typed commands (start|stop|restart TARGET,
// follow NAME, unfollow, quit); TARGET is a process, a group or all. Quitting leaves the processes as they are.
// Exit: 0 when done (the script completed), 1 when a script step failed or timed out or the bus failed, 2 on a bad
// command line, config or script.
#include <unistd.h>

#include <cstdio>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "common/options.h"
#include "procman/sheriff_node.h"

int main(int argc, char** argv) {
  using namespace objscan;
  std::string lcm_url = kDefaultLcmUrl, script, name;
  bool observe = false, status = false;
  double deputy_timeout_s = 3.0;
  char hostname[256] = {0};
  gethostname(hostname, sizeof(hostname) - 1);
  // This sheriff's name in the orders (user@host pid; no flag, issue 27).
  name = std::string(getenv("USER") ? getenv("USER") : "user") + "@" + hostname + " pid " + std::to_string(getpid());
  OptionParser parser("objscan-sheriff", "procman sheriff: orders the deputies of a config (positional: CONFIG)");
  parser.Add("lcm-url", &lcm_url, "LCM URL of the bus the deputies listen on");
  parser.Add("observe", &observe, "watch only: send no orders");
  parser.Add("status", &status, "print the state once after deputy-timeout s of listening, then exit");
  parser.Add("script", &script,
             "steps separated by ';': start|stop|restart|follow TARGET, wait-running|wait-status|wait-exit TARGET "
             "[SECONDS], sleep SECONDS");
  parser.Add("deputy-timeout", &deputy_timeout_s, "s without a report before a deputy is shown SILENT");
  int exit_code = 0;
  if (!ParseCommandLineOrExit(parser, argc, argv, &exit_code, /*allow_positional=*/true)) return exit_code;
  if (parser.positional().size() != 1) {
    std::fprintf(stderr, "error: give exactly one CONFIG file\n%s", parser.Usage().c_str());
    return 2;
  }
  ProcmanConfig config;
  std::string error;
  if (!ReadProcmanConfig(parser.positional()[0], &config, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 2;
  }
  if (!(deputy_timeout_s > 0)) {
    std::fprintf(stderr, "error: --deputy-timeout must be > 0 s\n");
    return 2;
  }
  SheriffNodeOptions options;
  options.observe = observe;
  if (!script.empty() && !ParseSheriffScript(script, &options.script, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 2;
  }
  if (status) {
    options.status_once_after_s = deputy_timeout_s;
  } else if (options.script.empty()) {
    options.commands_from_stdin = true;
    options.view = isatty(STDOUT_FILENO) != 0;
    options.status_lines = !options.view;
  }
  SheriffOptions sheriff;
  sheriff.name = name;
  sheriff.deputy_timeout_s = deputy_timeout_s;
  SetLogName("sheriff");
  try {
    auto bus = MakeBus(lcm_url);
    LogInfo("bus " + bus->Describe() + ", config " + parser.positional()[0] + " (hash " + config.hash + ")" +
            (observe ? ", observing" : ""));
    SheriffNode node(*bus, std::move(config), sheriff, options);
    RunOptions run;
    run.tick_ms = 50;
    run.stop_at_end_of_log = false;
    const int code = RunNode(*bus, node, run);
    return code != 0 ? code : node.script_failed() ? 1 : 0;
  } catch (const std::exception& e) {
    LogError(e.what());
    return 1;
  }
}

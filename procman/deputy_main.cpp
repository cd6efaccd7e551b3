// objscan-deputy: runs the processes of a procman config that belong to this host, as the sheriff orders.
//   objscan-deputy --config procman/robot_workstation.cfg --host robot [--lcm-url URL] [--log-dir DIR] KEY=VALUE...
// KEY=VALUE: the ${KEY} variables of the config's commands on this host (BIN, OUT, LCM_URL, ...).
// Exit: 0 after SIGINT/SIGTERM (every process stopped first), 2 on a bad command line or config, 1 on a bus error.
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "common/options.h"
#include "procman/deputy_node.h"

int main(int argc, char** argv) {
  using namespace objscan;
  std::string config_path, host, log_dir = ".", lcm_url = kDefaultLcmUrl;
  char hostname[256] = {0};
  if (gethostname(hostname, sizeof(hostname) - 1) == 0) host = hostname;
  OptionParser parser("objscan-deputy",
                      "procman deputy: runs this host's processes of a config as the sheriff orders "
                      "(positional KEY=VALUE: the config's ${KEY} variables)");
  parser.Add("config", &config_path, "procman config file (the same file as the sheriff's)");
  parser.Add("host", &host, "this host's name in the config (default: the system's host name)");
  parser.Add("log-dir", &log_dir, "folder for each process's output, NAME.log (created)");
  parser.Add("lcm-url", &lcm_url, "LCM URL of the bus the sheriff orders on");
  int exit_code = 0;
  if (!ParseCommandLineOrExit(parser, argc, argv, &exit_code, /*allow_positional=*/true)) return exit_code;
  if (config_path.empty()) {
    std::fprintf(stderr, "error: --config is required\n%s", parser.Usage().c_str());
    return 2;
  }
  ProcmanConfig config;
  std::string error;
  if (!ReadProcmanConfig(config_path, &config, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 2;
  }
  DeputyOptions options;
  options.host = host;
  options.log_dir = log_dir;
  for (const std::string& kv : parser.positional()) {
    const size_t eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) {
      std::fprintf(stderr, "error: '%s' is not KEY=VALUE (the config's variables)\n", kv.c_str());
      return 2;
    }
    options.vars[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  // Every command of this host must resolve now, not when the sheriff first orders it.
  bool any = false;
  for (const auto& e : config.entries) {
    if (e.host != host) continue;
    any = true;
    ResolvedCommand resolved;
    if (!ResolveCommand(e, options.vars, &resolved, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 2;
    }
  }
  if (!any) {
    std::string hosts;
    for (const auto& h : config.Hosts()) hosts += (hosts.empty() ? "" : ", ") + h;
    std::fprintf(stderr, "error: %s has no process for host '%s' (its hosts: %s); use --host\n", config_path.c_str(),
                 host.c_str(), hosts.c_str());
    return 2;
  }
  std::error_code ec;
  std::filesystem::create_directories(log_dir, ec);
  if (ec) {
    std::fprintf(stderr, "error: cannot create the log folder %s: %s\n", log_dir.c_str(), ec.message().c_str());
    return 2;
  }
  SetLogName("deputy " + host);
  try {
    auto bus = MakeBus(lcm_url);
    LogInfo("bus " + bus->Describe() + ", config " + config_path + " (hash " + config.hash + ")");
    DeputyNode node(*bus, std::move(config), options);
    RunOptions run;
    run.tick_ms = 50;
    run.stop_at_end_of_log = false;
    return RunNode(*bus, node, run);
  } catch (const std::exception& e) {
    LogError(e.what());
    return 1;
  }
}

// objscan_session: runs one session from a process list (see session.h). Used by the `objscan run` launcher.
#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "common/bus.h"
#include "common/log.h"
#include "common/options.h"
#include "common/output_folder.h"
#include "procman/session.h"

int main(int argc, char** argv) {
  objscan::SetLogName("objscan_session");
  objscan::SessionOptions options;
  options.lcm_url = objscan::kDefaultLcmUrl;
  std::string process_list;
  objscan::OptionParser parser("objscan_session", "Starts, watches, logs and stops one objscan session.");
  // Only what the launcher, the tests or a user set (issue 27); the logger executable, the start and finalize
  // timeouts and the logger's flush wait keep the SessionOptions defaults.
  parser.Add("out", &options.out_dir, "output folder (session.lcmlog, summary.json, logs/)");
  parser.Add("processes", &process_list, "process list file: 'NAME driver|processor COMMAND ARGS...' per line");
  parser.Add("lcm-url", &options.lcm_url, "live LCM URL of the session");
  parser.Add("finish-on", &options.finish_on, "process whose COMMAND_FINISHED ends the session ('' = all exited)");
  parser.Add("expected-frames", &options.expected_frames, "frames the driver publishes (for progress)");
  parser.Add("timeout", &options.timeout_s, "s, session time limit");
  parser.Add("label", &options.label, "text copied into summary.json");
  parser.Add("progress-detail", &options.progress_detail,
             "process whose status detail (e.g. the planner's phase) ends each progress line");
  bool stop_with_parent = false;
  parser.Add("stop-with-parent", &stop_with_parent,
             "end the session in order (as on SIGTERM) when the process that started it dies, even by SIGKILL");
  std::string results;
  parser.Add("results", &results,
             "name=path,... result files (JSON, relative to --out) copied into summary.json under \"results\"");
  int exit_code = 0;
  if (!objscan::ParseCommandLineOrExit(parser, argc, argv, &exit_code)) return exit_code;
  std::string results_error;
  if (!results.empty() && !objscan::ParseResultsList(results, &options.results, &results_error)) {
    objscan::LogError(results_error);
    return 2;
  }
  if (options.out_dir.empty() || process_list.empty()) {
    objscan::LogError("--out and --processes are required");
    return 2;
  }
  std::ifstream in(process_list);
  if (!in) {
    objscan::LogError("cannot read process list " + process_list);
    return 2;
  }
  std::stringstream text;
  text << in.rdbuf();
  std::vector<objscan::SessionProcess> processes;
  std::string error;
  if (!objscan::ParseProcessList(text.str(), &processes, &error)) {
    objscan::LogError(process_list + ": " + error);
    return 2;
  }
  if (processes.empty()) {
    objscan::LogError(process_list + ": no processes");
    return 2;
  }
  // A new session never destroys an earlier one: its folder is moved aside (DIR.N); the process list is kept in it.
  std::string moved_to;
  if (!objscan::PrepareOutputFolder(options.out_dir, &moved_to, &error)) {
    objscan::LogError(error);
    return 2;
  }
  if (!moved_to.empty())
    std::fprintf(stderr, "[objscan] %s held an earlier run: moved it to %s\n", options.out_dir.c_str(),
                 moved_to.c_str());
  const std::string kept_list = options.out_dir + "/processes.txt";
  if (!(std::ofstream(kept_list) << text.str())) objscan::LogWarning("cannot write " + kept_list);
  if (stop_with_parent) {
    const pid_t parent = getppid();
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) {
      objscan::LogError("the process that started the session is gone; not starting");
      return 1;
    }
  }
  return objscan::RunSession(options, processes);
}

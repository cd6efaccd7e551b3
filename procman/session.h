// A local session supervisor (the single-host part of a procman): starts lcm-logger, then the processing
// processes, waits until each has published PROCESS_STATUS, then starts the drivers; watches the bus to print
// progress (frame n of N, rates, drops) and detects processes that die; ends when the named process announces
// COMMAND_FINISHED on OBJSCAN_CONTROL (or every process has exited), stops everything in order, stops the logger only
// after the publishers are gone and a flush interval has passed, checks that the log holds every message the
// supervisor saw, and writes DIR/summary.json. Blocks until done.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace objscan {

struct SessionProcess {
  std::string name;               // process name (as in its PROCESS_STATUS)
  bool is_driver = false;         // drivers start last (after every processor is up)
  std::vector<std::string> argv;  // command line
};

struct SessionOptions {
  std::string out_dir;                  // DIR: session.lcmlog, summary.json, logs/<process>.log go here
  std::string lcm_url;                  // live bus URL shared by all processes
  std::string logger = "lcm-logger";    // lcm-logger executable
  std::string finish_on;                // process whose COMMAND_FINISHED ends the session ("" = all exited)
  int64_t expected_frames = 0;          // frames the driver will publish (progress display; 0 = unknown)
  double timeout_s = 1800;              // s, whole-session limit (wall clock)
  double start_timeout_s = 20;          // s, a processor must publish PROCESS_STATUS within this after start
  double finalize_timeout_s = 300;       // s, after a failure or a stop signal: time each surviving processor
                                        // has to write its results (a second signal stops at once)
  int flush_wait_ms = 1500;             // ms, wait after publishers stop before stopping lcm-logger
  int progress_period_ms = 1000;        // ms between progress lines
  std::string label;                    // free text copied into summary.json (e.g. "sim sphere")
  std::string progress_detail;          // process whose status detail (e.g. the planner's phase) ends each
                                        // progress line ("" = none)
  // Result files the processes write (JSON objects, paths relative to out_dir), copied into summary.json under
  // "results" by name when they exist after the session: {name, path}.
  std::vector<std::pair<std::string, std::string>> results;
};

// Parses "name=path,name=path" (the --results option). False with *error on an empty name or path.
bool ParseResultsList(const std::string& text, std::vector<std::pair<std::string, std::string>>* results,
                      std::string* error);

// Parses a process list: one process per line "NAME driver|processor COMMAND ARGS...", '#' comments,
// arguments split on whitespace with '...' or "..." quoting. Returns false with *error on a malformed line.
bool ParseProcessList(const std::string& text, std::vector<SessionProcess>* processes, std::string* error);

// Runs the session. Returns the process exit code: 0 success, 1 a process failed / timeout, 130 interrupted.
int RunSession(const SessionOptions& options, const std::vector<SessionProcess>& processes);

}  // namespace objscan

// The sheriff's logic (LCM-free): holds the desired state of every process of a procman config, turns user commands
// (start / stop / restart a process, a group or all) into per-host orders that are sent in full every second, and
// keeps what the deputies report. It judges a deputy by its own clock only: a deputy not heard for deputy_timeout_s
// is "silent". Deputies of another config (another hash) on the same bus are listed as foreign and never ordered.
// An entry with `after` is ordered to run only once each named process has published PROCESS_STATUS since that
// process's own start (OnProcessStatus).
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "procman/config.h"
#include "procman/deputy.h"

namespace objscan {

struct SheriffOptions {
  std::string name = "sheriff";   // sent in the orders (user@host pid)
  double deputy_timeout_s = 3.0;  // s without a report before a deputy counts as silent
};

struct SheriffEntryView {
  std::string name, group, host;
  bool wanted = false;                // the user asked for it to run
  int32_t run_id = 0;                 // the run ordered
  std::vector<std::string> waiting_for;  // 'after' processes not reported yet (wanted, not ordered yet)
  bool reported = false;              // its deputy has reported it
  ProcessReport report;               // its deputy's last report of it
  bool status_seen = false;           // it published PROCESS_STATUS since its start
};

struct SheriffDeputyView {
  std::string host;
  bool foreign = false;        // another config's deputy (never ordered)
  std::string config_hash;
  double silent_for_s = 0;     // s since its last report (sheriff's clock)
  bool silent = false;         // silent_for_s > deputy_timeout_s, or never heard
  bool heard = false;
  int64_t orders_refused = 0;
  std::string last_refusal;
};

class Sheriff {
 public:
  Sheriff(ProcmanConfig config, SheriffOptions options);

  // target: a process name, a group name or "all". False with *error when it names nothing in the config.
  // Start: wanted; a process that is not running gets a new run id. Restart: a new run id for each. Stop: not wanted.
  bool Start(const std::string& target, double now_s, std::string* error);
  bool Restart(const std::string& target, double now_s, std::string* error);
  bool Stop(const std::string& target, double now_s, std::string* error);
  // Forward a process's output (PROCMAN_OUTPUT); one at a time ("" = none).
  bool Follow(const std::string& name, std::string* error);

  void OnDeputyReport(const DeputyReport& report, double now_s);
  void OnProcessStatus(const std::string& process_name, double now_s);

  // The orders to send now: one per host of the config.
  std::vector<DeputyOrders> Orders(double now_s) const;
  std::vector<SheriffEntryView> Entries(double now_s) const;
  std::vector<SheriffDeputyView> Deputies(double now_s) const;
  // True when every entry of target is running in the run ordered (per its deputy's report).
  bool Running(const std::string& target) const;
  // True when every entry of target has published PROCESS_STATUS since its start.
  bool StatusSeen(const std::string& target) const;
  // True when no entry of target runs (reported exited, crashed, failed or stopped).
  bool Ended(const std::string& target) const;
  // Whether target names something (a process, a group or all).
  bool Names(const std::string& target) const;
  const ProcmanConfig& config() const { return config_; }

 private:
  struct Desired {
    bool wanted = false;
    int32_t run_id = 0;
    double started_s = -1;       // when the current run was ordered
    double status_at_s = -1;     // last PROCESS_STATUS heard
    bool has_report = false;
    ProcessReport report;
  };
  struct DeputySeen {
    std::string config_hash;
    double heard_s = -1;
    int64_t orders_refused = 0;
    std::string last_refusal;
  };
  bool Select(const std::string& target, std::vector<const ProcmanEntry*>* entries, std::string* error) const;
  bool Ready(const ProcmanEntry& entry) const;  // its 'after' processes have reported
  void NewRun(Desired* d, double now_s);        // wanted, with a run id above every one seen
  ProcmanConfig config_;
  SheriffOptions options_;
  std::map<std::string, Desired> desired_;
  std::map<std::string, DeputySeen> deputies_;  // by host (own config) ...
  std::map<std::string, DeputySeen> foreign_;   // ... and by host for other configs
  std::string follow_;
  int32_t next_run_id_ = 1;
};

// The state as a table for a terminal: deputies (ok / SILENT for how long / foreign config / refused orders), then
// one line per process: group, host, state (or what it waits for), run, pid, CPU %, memory, restarts, last event.
std::string FormatSheriffView(const Sheriff& sheriff, double now_s);

// A script step of `objscan-sheriff --script`: "start T", "stop T", "restart T", "follow NAME", "sleep S",
// "wait-running T [S]" (every process of T running in the run ordered), "wait-status T [S]" (each has published
// PROCESS_STATUS since its start), "wait-exit T [S]" (none running: exited, crashed, failed or stopped). Waits
// time out after S seconds (default 60), which fails the script.
struct SheriffStep {
  std::string verb;
  std::string target;
  double seconds = 60;
  std::string text;  // the step as written, for messages
};
// Steps separated by ';' or newlines. False with *error naming the bad step.
bool ParseSheriffScript(const std::string& script, std::vector<SheriffStep>* steps, std::string* error);

}  // namespace objscan

// The deputy's logic (LCM-free): one per host, it runs the processes of the procman config that are assigned to its
// host, and nothing else. The sheriff's orders give, per process, the desired state (run or not) and a run id; a new
// run id (re)starts the process. Orders are stateless: each names the full desired state, so a lost order does no
// harm and a restarted deputy catches up on the next one. The deputy never compares clocks with another host: every
// time here is its own monotonic clock (now_s), passed in by the caller (tests drive it).
//
// Security: orders only name config entries. No command string ever comes from an order; orders for another config
// (hash mismatch) or naming an entry that is not this host's are refused, counted and reported, and change nothing.
//
// Blocking: HandleOrders, Step and Report never wait for a process (stops are signalled, then SIGKILL after the
// entry's grace time at a later Step); only StopAll waits.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "procman/child_process.h"
#include "procman/config.h"

namespace objscan {

struct ProcessOrder {
  std::string name;            // config entry
  bool run = false;            // desired: running
  int32_t run_id = 0;          // desired run; a different value than the current run restarts a running process
  bool follow_output = false;  // forward the process's output (TakeOutput)
};

struct DeputyOrders {
  std::string host;         // the deputy the orders are for
  std::string config_hash;  // ConfigHash of the sheriff's config file
  std::string sheriff;      // the sender, for messages
  std::vector<ProcessOrder> processes;
};

enum class ProcessState {
  kStopped,      // never started, or stopped by order
  kRunning,
  kStopping,     // stop signal sent, waiting (SIGKILL after the grace time)
  kExited,       // ended by itself with code 0
  kCrashed,      // ended by a signal or a non-zero code (kRespawnWait follows when the entry respawns)
  kRespawnWait,  // crashed, restarting after a back-off
  kFailed,       // could not be started (missing executable, undefined ${VAR}, bad cwd)
};
const char* ProcessStateName(ProcessState state);

struct ProcessReport {
  std::string name;
  std::string group;
  ProcessState state = ProcessState::kStopped;
  bool desired_run = false;
  int32_t desired_run_id = 0;
  int32_t run_id = 0;        // the run the process is in (or was in when it ended)
  int pid = 0;               // 0 when not running
  int exit_code = 0;         // last exit: code (0..255), or 128 + signal
  int exit_signal = 0;       // last exit: the signal that ended it, 0 if none
  int restarts = 0;          // automatic restarts after crashes (respawn), over the deputy's life
  double cpu_percent = 0;    // % of one core since the previous report
  int64_t rss_kb = 0;        // resident memory, kB
  double uptime_s = 0;       // s since its last start
  std::string message;       // the last event: "started", "exited with code 3", "cannot start: ..."
};

struct DeputyReport {
  std::string host;
  std::string config_hash;
  int64_t orders_accepted = 0;
  int64_t orders_refused = 0;
  std::string last_refusal;  // why the last refused order was refused
  std::vector<ProcessReport> processes;  // this host's entries, in config order
};

struct DeputyOptions {
  std::string host;                          // this deputy's host name (entries with this host are its own)
  std::map<std::string, std::string> vars;   // ${VAR} values for the commands
  std::string log_dir;                       // each process's output is appended to log_dir/NAME.log
  double first_respawn_delay_s = 1.0;        // s, doubling per crash up to max_respawn_delay_s
  double max_respawn_delay_s = 30.0;         // s
  double healthy_after_s = 30.0;             // s of running that resets the back-off
};

class Deputy {
 public:
  Deputy(ProcmanConfig config, DeputyOptions options);
  ~Deputy();  // kills what is still running (StopAll first for an ordered stop)
  Deputy(const Deputy&) = delete;
  Deputy& operator=(const Deputy&) = delete;

  // Takes the sheriff's desired state. Orders for another host are ignored (true, no error). Refused with false and
  // *error (counted in the report, nothing changed): another config hash, or an entry unknown or on another host.
  // Entries of this host that the orders do not name keep their previous desired state.
  bool HandleOrders(const DeputyOrders& orders, double now_s, std::string* error);
  // Reaps exits, starts, stops and respawns to match the desired state. Call often (e.g. every 50 ms).
  void Step(double now_s);
  // The full state (call about once a second: CPU % is measured between calls).
  DeputyReport Report(double now_s);
  // Output the followed processes wrote since the last call: (name, text), at most max_bytes per process.
  std::vector<std::pair<std::string, std::string>> TakeOutput(size_t max_bytes);
  // Stops every process in reverse config order (stop signal, grace, SIGKILL) and waits for them.
  void StopAll();
  const std::string& host() const { return options_.host; }
  // The entries this deputy runs.
  std::vector<std::string> Entries() const;

 private:
  struct Managed;
  void Start(Managed* m, double now_s);
  ProcmanConfig config_;
  DeputyOptions options_;
  std::vector<std::unique_ptr<Managed>> managed_;
  int64_t orders_accepted_ = 0, orders_refused_ = 0;
  std::string last_refusal_;
};

}  // namespace objscan

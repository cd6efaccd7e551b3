// The sheriff on the bus: PROCMAN_DEPUTY, PROCESS_STATUS and PROCMAN_OUTPUT in; PROCMAN_ORDERS out (every second
// and after every command, unless observing). The logic is Sheriff (procman/sheriff.h); this file moves messages,
// runs a script (ParseSheriffScript) step by step and takes typed commands. Malformed reports are counted and
// logged (once per reason per 10 s).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "procman/sheriff.h"

namespace objscan {

struct SheriffNodeOptions {
  bool observe = false;              // send no orders
  std::vector<SheriffStep> script;   // run these, then finish (exit code: ScriptFailed)
  bool view = false;                 // redraw the table on the terminal every second
  bool status_lines = false;         // print the table every second to stdout (logs, pipes)
  double status_once_after_s = -1;   // >= 0: print the table once after this many seconds, then finish
  bool commands_from_stdin = false;  // read typed commands from stdin (a line each; "quit" finishes)
};

class SheriffNode : public Node {
 public:
  SheriffNode(Bus& bus, ProcmanConfig config, SheriffOptions sheriff_options, SheriffNodeOptions options);
  void Tick(int64_t wall_utime) override;
  bool Finished() const override { return finished_; }
  // A typed command ("start T", "stop T", "restart T", "follow NAME", "unfollow"); false with *error otherwise.
  bool Command(const std::string& line, std::string* error);
  bool script_failed() const { return script_failed_; }
  int64_t malformed() const { return malformed_; }
  Sheriff& sheriff() { return sheriff_; }

 private:
  void SendOrders(int64_t wall_utime);
  void RunScript(double now_s);
  void Warn(const std::string& why);
  void ReadCommands();
  Bus& bus_;
  Sheriff sheriff_;
  SheriffNodeOptions options_;
  int64_t orders_seq_ = 0, malformed_ = 0;
  double start_s_ = 0, next_orders_s_ = 0, next_view_s_ = 0;
  size_t step_ = 0;
  double step_started_s_ = -1;
  bool finished_ = false, script_failed_ = false;
  WarningLimiter warnings_;
  std::string typed_;  // stdin bytes not yet ending a line
};

}  // namespace objscan

// The run loop shared by every process: dispatches bus messages to the node's handlers, calls Tick() about every
// tick_ms of wall time (status publication, timers), and stops on SIGINT/SIGTERM/SIGHUP, when the node says it has
// finished, or when a file:// input log reaches its end.
#pragma once

#include <cstdint>

namespace objscan {

class Bus;

class Node {
 public:
  virtual ~Node() = default;
  // Called from the run loop with the wall clock (µs) at least every tick period.
  virtual void Tick(int64_t wall_utime) = 0;
  // True once the node has done all its work (e.g. after end of stream) and the process may exit.
  virtual bool Finished() const { return false; }
  // Called once when the input ends (end of a replayed log) or on a stop signal, before the loop returns.
  virtual void OnShutdown() {}
};

struct RunOptions {
  int tick_ms = 100;              // ms, longest wait for a message before Tick() runs
  bool stop_at_end_of_log = true; // return when the bus reports the end of a file:// input
};

// Installs SIGINT/SIGTERM handlers (once per process) and runs until a stop condition. Blocks. Returns 0 on a
// normal stop, 1 on a bus error.
int RunNode(Bus& bus, Node& node, const RunOptions& options = {});

// True once SIGINT, SIGTERM or SIGHUP was received (after InstallStopSignalHandlers or RunNode).
bool StopRequested();
// How many of those signals were received (a second Ctrl-C can mean "stop now"), and the last one's number.
int StopRequestCount();
int StopSignal();
void InstallStopSignalHandlers();

}  // namespace objscan

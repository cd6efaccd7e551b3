#include "common/node.h"

#include <csignal>

#include "common/bus.h"
#include "common/log.h"
#include "common/time.h"

namespace objscan {
namespace {
volatile std::sig_atomic_t g_stop_count = 0;
volatile std::sig_atomic_t g_stop_signal = 0;
void OnSignal(int signal) {
  g_stop_signal = signal;
  if (g_stop_count < 100) g_stop_count = g_stop_count + 1;
}
}  // namespace

void InstallStopSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = OnSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  sigaction(SIGHUP, &action, nullptr);
}

bool StopRequested() { return g_stop_count != 0; }
int StopRequestCount() { return g_stop_count; }
int StopSignal() { return g_stop_signal; }

int RunNode(Bus& bus, Node& node, const RunOptions& options) {
  InstallStopSignalHandlers();
  int exit_code = 0;
  int64_t last_tick = 0;
  while (!StopRequested() && !node.Finished()) {
    const int status = bus.Handle(options.tick_ms);
    const int64_t now = WallTimeMicros();
    if (status < 0) {
      if (StopRequested()) break;  // the signal interrupted the wait: a normal stop, not a bus error
      if (options.stop_at_end_of_log) {
        LogInfo("input ended");
        break;
      }
      LogError("bus error on " + bus.Describe());
      exit_code = 1;
      break;
    }
    if (now - last_tick >= options.tick_ms * 1000LL) {
      node.Tick(now);
      last_tick = now;
    }
  }
  node.OnShutdown();
  node.Tick(WallTimeMicros());
  return exit_code;
}

}  // namespace objscan

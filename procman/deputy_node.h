// The deputy on the bus: PROCMAN_ORDERS in; PROCMAN_DEPUTY (its full state, every second) and PROCMAN_OUTPUT
// (followed processes' output) out. The logic is Deputy (procman/deputy.h); this file only moves messages.
// Malformed orders are counted and logged (once per reason per 10 s); refused orders too, and they appear in the
// report's orders_refused / last_refusal. On stop (SIGINT/SIGTERM) every process is stopped in order.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "procman/deputy.h"

namespace objscan {

class DeputyNode : public Node {
 public:
  // Subscribes at construction. The deputy's clock is the monotonic clock (never another host's).
  DeputyNode(Bus& bus, ProcmanConfig config, DeputyOptions options);
  void Tick(int64_t wall_utime) override;
  void OnShutdown() override;
  int64_t malformed_orders() const { return malformed_; }
  Deputy& deputy() { return *deputy_; }

 private:
  void Warn(const std::string& why);
  Bus& bus_;
  std::unique_ptr<Deputy> deputy_;
  int64_t report_seq_ = 0, output_seq_ = 0, malformed_ = 0;
  double next_report_s_ = 0;
  WarningLimiter warnings_;
};

// Monotonic seconds (the deputy's and sheriff's own clock).
double MonotonicSeconds();

}  // namespace objscan

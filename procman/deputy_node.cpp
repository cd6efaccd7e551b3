#include "procman/deputy_node.h"

#include <chrono>

#include "common/log.h"
#include "common/time.h"
#include "objscan/procman_output_t.hpp"
#include "procman/procman_messages.h"

namespace objscan {

double MonotonicSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

DeputyNode::DeputyNode(Bus& bus, ProcmanConfig config, DeputyOptions options)
    : bus_(bus), deputy_(std::make_unique<Deputy>(std::move(config), std::move(options))) {
  bus_.SubscribeMessage<procman_orders_t>(
      kProcmanOrdersChannel,
      [this](const procman_orders_t& msg, const RawMessage&) {
        DeputyOrders orders;
        std::string why;
        if (!OrdersFromMessage(msg, &orders, &why)) {
          ++malformed_;
          Warn("malformed orders ignored: " + why);
          return;
        }
        if (!deputy_->HandleOrders(orders, MonotonicSeconds(), &why)) Warn("orders refused: " + why);
        deputy_->Step(MonotonicSeconds());
      },
      [this](const RawMessage& raw) {
        ++malformed_;
        Warn("malformed orders ignored (" + std::to_string(raw.size) + " bytes): " + raw.why);
      });
  std::string names;
  for (const auto& n : deputy_->Entries()) names += (names.empty() ? "" : ", ") + n;
  LogInfo("deputy of host " + deputy_->host() + ": " + (names.empty() ? "no process of this host in the config" : names));
}

void DeputyNode::Warn(const std::string& why) { warnings_.Warn(why, MonotonicSeconds()); }

void DeputyNode::Tick(int64_t wall_utime) {
  const double now = MonotonicSeconds();
  deputy_->Step(now);
  for (auto& [name, text] : deputy_->TakeOutput(4096)) {
    procman_output_t out;
    out.utime = wall_utime;
    out.seq = output_seq_++;
    out.host = deputy_->host();
    out.name = name;
    out.text = text;
    bus_.PublishMessage(kProcmanOutputChannel, out);
  }
  if (now < next_report_s_) return;
  next_report_s_ = now + 1.0;
  bus_.PublishMessage(kProcmanDeputyChannel, DeputyReportToMessage(deputy_->Report(now), wall_utime, report_seq_++));
}

void DeputyNode::OnShutdown() {
  LogInfo("stopping every process of host " + deputy_->host());
  deputy_->StopAll();
  bus_.PublishMessage(kProcmanDeputyChannel,
                      DeputyReportToMessage(deputy_->Report(MonotonicSeconds()), WallTimeMicros(), report_seq_++));
}

}  // namespace objscan

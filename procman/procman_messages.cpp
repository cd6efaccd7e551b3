#include "procman/procman_messages.h"

namespace objscan {
namespace {
constexpr int kMaxProcesses = 1000;
}  // namespace

procman_orders_t OrdersToMessage(const DeputyOrders& orders, int64_t utime, int64_t seq) {
  procman_orders_t m;
  m.utime = utime;
  m.seq = seq;
  m.sheriff = orders.sheriff;
  m.host = orders.host;
  m.config_hash = orders.config_hash;
  m.num_processes = static_cast<int32_t>(orders.processes.size());
  for (const auto& p : orders.processes) {
    m.name.push_back(p.name);
    m.run.push_back(p.run);
    m.run_id.push_back(p.run_id);
    m.follow_output.push_back(p.follow_output);
  }
  return m;
}

bool OrdersFromMessage(const procman_orders_t& m, DeputyOrders* orders, std::string* why) {
  const size_t n = static_cast<size_t>(m.num_processes < 0 ? 0 : m.num_processes);
  if (m.num_processes < 0 || m.num_processes > kMaxProcesses || m.name.size() != n || m.run.size() != n ||
      m.run_id.size() != n || m.follow_output.size() != n) {
    *why = "orders: " + std::to_string(m.num_processes) + " processes (at most " + std::to_string(kMaxProcesses) +
           ", arrays of that length)";
    return false;
  }
  if (m.host.empty()) {
    *why = "orders without a host";
    return false;
  }
  *orders = DeputyOrders();
  orders->host = m.host;
  orders->config_hash = m.config_hash;
  orders->sheriff = m.sheriff;
  for (size_t i = 0; i < n; ++i) {
    if (m.name[i].empty()) {
      *why = "orders with an empty process name";
      return false;
    }
    orders->processes.push_back({m.name[i], m.run[i] != 0, m.run_id[i], m.follow_output[i] != 0});
  }
  return true;
}

procman_deputy_t DeputyReportToMessage(const DeputyReport& r, int64_t utime, int64_t seq) {
  procman_deputy_t m;
  m.utime = utime;
  m.seq = seq;
  m.host = r.host;
  m.config_hash = r.config_hash;
  m.orders_accepted = r.orders_accepted;
  m.orders_refused = r.orders_refused;
  m.last_refusal = r.last_refusal;
  m.num_processes = static_cast<int32_t>(r.processes.size());
  for (const auto& p : r.processes) {
    m.name.push_back(p.name);
    m.group.push_back(p.group);
    m.message.push_back(p.message);
    m.state.push_back(static_cast<int8_t>(p.state));
    m.desired_run.push_back(p.desired_run);
    m.desired_run_id.push_back(p.desired_run_id);
    m.run_id.push_back(p.run_id);
    m.pid.push_back(p.pid);
    m.exit_code.push_back(p.exit_code);
    m.exit_signal.push_back(p.exit_signal);
    m.restarts.push_back(p.restarts);
    m.cpu_percent.push_back(static_cast<float>(p.cpu_percent));
    m.rss_kb.push_back(p.rss_kb);
    m.uptime_s.push_back(static_cast<float>(p.uptime_s));
  }
  return m;
}

bool DeputyReportFromMessage(const procman_deputy_t& m, DeputyReport* r, std::string* why) {
  const size_t n = static_cast<size_t>(m.num_processes < 0 ? 0 : m.num_processes);
  const bool sizes = m.name.size() == n && m.group.size() == n && m.message.size() == n && m.state.size() == n &&
                     m.desired_run.size() == n && m.desired_run_id.size() == n && m.run_id.size() == n &&
                     m.pid.size() == n && m.exit_code.size() == n && m.exit_signal.size() == n &&
                     m.restarts.size() == n && m.cpu_percent.size() == n && m.rss_kb.size() == n &&
                     m.uptime_s.size() == n;
  if (m.num_processes < 0 || m.num_processes > kMaxProcesses || !sizes) {
    *why = "deputy report: " + std::to_string(m.num_processes) + " processes (at most " +
           std::to_string(kMaxProcesses) + ", arrays of that length)";
    return false;
  }
  if (m.host.empty()) {
    *why = "deputy report without a host";
    return false;
  }
  *r = DeputyReport();
  r->host = m.host;
  r->config_hash = m.config_hash;
  r->orders_accepted = m.orders_accepted;
  r->orders_refused = m.orders_refused;
  r->last_refusal = m.last_refusal;
  for (size_t i = 0; i < n; ++i) {
    if (m.state[i] < 0 || m.state[i] > static_cast<int8_t>(ProcessState::kFailed)) {
      *why = "deputy report: process " + m.name[i] + " has unknown state " + std::to_string(m.state[i]);
      return false;
    }
    ProcessReport p;
    p.name = m.name[i];
    p.group = m.group[i];
    p.message = m.message[i];
    p.state = static_cast<ProcessState>(m.state[i]);
    p.desired_run = m.desired_run[i] != 0;
    p.desired_run_id = m.desired_run_id[i];
    p.run_id = m.run_id[i];
    p.pid = m.pid[i];
    p.exit_code = m.exit_code[i];
    p.exit_signal = m.exit_signal[i];
    p.restarts = m.restarts[i];
    p.cpu_percent = m.cpu_percent[i];
    p.rss_kb = m.rss_kb[i];
    p.uptime_s = m.uptime_s[i];
    r->processes.push_back(std::move(p));
  }
  return true;
}

}  // namespace objscan

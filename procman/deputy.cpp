#include "procman/deputy.h"

#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace objscan {
namespace {

// CPU time (s) and resident memory (kB) of one process from /proc; false when it is gone.
bool ReadProcessUsage(int pid, double* cpu_s, int64_t* rss_kb) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  if (!std::getline(stat, text)) return false;
  const size_t close = text.rfind(')');  // the command name may hold spaces and parentheses
  if (close == std::string::npos) return false;
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  long long rss_pages = 0;
  // After the name: state(3) ... utime(14) stime(15) ... rss(24), numbered as in proc(5).
  for (int i = 3; i <= 24 && fields >> field; ++i) {
    if (i == 14) utime = std::strtoull(field.c_str(), nullptr, 10);
    if (i == 15) stime = std::strtoull(field.c_str(), nullptr, 10);
    if (i == 24) rss_pages = std::strtoll(field.c_str(), nullptr, 10);
  }
  const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
  *cpu_s = static_cast<double>(utime + stime) / (ticks > 0 ? ticks : 100.0);
  *rss_kb = rss_pages * (sysconf(_SC_PAGESIZE) / 1024);
  return true;
}

}  // namespace

const char* ProcessStateName(ProcessState state) {
  switch (state) {
    case ProcessState::kStopped: return "stopped";
    case ProcessState::kRunning: return "running";
    case ProcessState::kStopping: return "stopping";
    case ProcessState::kExited: return "exited";
    case ProcessState::kCrashed: return "crashed";
    case ProcessState::kRespawnWait: return "respawn_wait";
    case ProcessState::kFailed: return "failed";
  }
  return "unknown";
}

struct Deputy::Managed {
  const ProcmanEntry* entry = nullptr;
  std::unique_ptr<ChildProcess> child;
  ProcessReport report;
  bool follow = false;  // ordered: forward its output
  double started_s = 0, stop_deadline_s = 0, respawn_at_s = 0;
  double respawn_delay_s = 0;
  bool killed = false;              // SIGKILL sent after the grace time
  double last_cpu_s = -1, last_cpu_at_s = 0;
  std::streamoff output_offset = 0;  // bytes of the log already forwarded
  std::string log_path;
};

Deputy::Deputy(ProcmanConfig config, DeputyOptions options) : config_(std::move(config)), options_(std::move(options)) {
  for (const auto& e : config_.entries) {
    if (e.host != options_.host) continue;
    auto m = std::make_unique<Managed>();
    m->entry = &e;
    m->report.name = e.name;
    m->report.group = e.group;
    m->respawn_delay_s = options_.first_respawn_delay_s;
    m->log_path = (options_.log_dir.empty() ? std::string(".") : options_.log_dir) + "/" + e.name + ".log";
    managed_.push_back(std::move(m));
  }
}

Deputy::~Deputy() {
  for (auto& m : managed_)
    if (m->child && m->child->Running()) m->child->Signal(SIGKILL);
}

std::vector<std::string> Deputy::Entries() const {
  std::vector<std::string> names;
  for (const auto& m : managed_) names.push_back(m->entry->name);
  return names;
}

bool Deputy::HandleOrders(const DeputyOrders& orders, double /*now_s*/, std::string* error) {
  error->clear();
  if (orders.host != options_.host) return true;
  auto refuse = [&](const std::string& why) {
    ++orders_refused_;
    last_refusal_ = why;
    *error = why;
    return false;
  };
  if (orders.config_hash != config_.hash)
    return refuse("orders from " + orders.sheriff + " are for config " + orders.config_hash + ", this deputy runs " +
                  config_.hash + " (start the sheriff and every deputy with the same config file)");
  std::vector<Managed*> targets;
  for (const auto& o : orders.processes) {
    auto it = std::find_if(managed_.begin(), managed_.end(), [&](const auto& m) { return m->entry->name == o.name; });
    if (it == managed_.end()) {
      const ProcmanEntry* e = config_.Find(o.name);
      return refuse("orders from " + orders.sheriff + " name '" + o.name + "', " +
                    (e ? "an entry of host " + e->host + ", not " + options_.host : "which is not in the config"));
    }
    targets.push_back(it->get());
  }
  for (size_t i = 0; i < targets.size(); ++i) {
    Managed* m = targets[i];
    m->report.desired_run = orders.processes[i].run;
    m->report.desired_run_id = orders.processes[i].run_id;
    if (orders.processes[i].follow_output && !m->follow) {  // following starts with what comes next
      struct stat st {};
      m->output_offset = stat(m->log_path.c_str(), &st) == 0 ? st.st_size : 0;
    }
    m->follow = orders.processes[i].follow_output;
  }
  ++orders_accepted_;
  return true;
}

void Deputy::Start(Managed* m, double now_s) {
  ProcessReport& r = m->report;
  ResolvedCommand command;
  std::string error;
  r.run_id = r.desired_run_id;
  r.pid = 0;
  if (!ResolveCommand(*m->entry, options_.vars, &command, &error)) {
    r.state = ProcessState::kFailed;
    r.message = "cannot start: " + error;
    return;
  }
  m->child = std::make_unique<ChildProcess>(m->entry->name, command.argv, m->log_path);
  m->child->SetWorkingDirectory(command.cwd);
  m->child->SetEnvironment(command.env);
  if (!m->child->Start(&error)) {
    r.state = ProcessState::kFailed;
    r.message = "cannot start: " + error;
    m->child.reset();
    return;
  }
  r.state = ProcessState::kRunning;
  r.pid = m->child->pid();
  r.message = "started run " + std::to_string(r.run_id);
  m->started_s = now_s;
  m->killed = false;
  m->last_cpu_s = -1;
}

void Deputy::Step(double now_s) {
  for (auto& owned : managed_) {
    Managed* m = owned.get();
    ProcessReport& r = m->report;
    const ProcmanEntry& e = *m->entry;
    // Reap an exit.
    if (m->child && (r.state == ProcessState::kRunning || r.state == ProcessState::kStopping) &&
        !m->child->Running()) {
      const bool ordered_stop = r.state == ProcessState::kStopping;
      const int code = m->child->exit_code();
      r.exit_code = code;
      r.exit_signal = code > 128 ? code - 128 : 0;
      r.pid = 0;
      r.message = m->child->DescribeExit();
      m->child.reset();
      if (ordered_stop) {
        r.state = ProcessState::kStopped;
        r.message = "stopped (" + r.message + ")";
      } else if (code == 0) {
        r.state = ProcessState::kExited;
      } else if (e.respawn && r.desired_run) {
        if (now_s - m->started_s >= options_.healthy_after_s) m->respawn_delay_s = options_.first_respawn_delay_s;
        r.state = ProcessState::kRespawnWait;
        m->respawn_at_s = now_s + m->respawn_delay_s;
        r.message += ", restarting in " + std::to_string(m->respawn_delay_s).substr(0, 4) + " s";
        m->respawn_delay_s = std::min(2 * m->respawn_delay_s, options_.max_respawn_delay_s);
      } else {
        r.state = ProcessState::kCrashed;
      }
    }
    // A stop past its grace time: SIGKILL.
    if (r.state == ProcessState::kStopping && m->child && !m->killed && now_s >= m->stop_deadline_s) {
      m->child->Signal(SIGKILL);
      m->killed = true;
      r.message = "did not stop within " + std::to_string(e.grace_s).substr(0, 4) + " s of " +
                  SignalName(e.stop_signal) + ": killed";
    }
    const bool running = r.state == ProcessState::kRunning;
    if (running && (!r.desired_run || r.run_id != r.desired_run_id)) {
      m->child->Signal(e.stop_signal);
      r.state = ProcessState::kStopping;
      m->stop_deadline_s = now_s + e.grace_s;
      r.message = r.desired_run ? "restarting as run " + std::to_string(r.desired_run_id) : "stopping";
      continue;
    }
    if (r.state == ProcessState::kStopping) continue;
    if (!r.desired_run) {
      if (r.state == ProcessState::kRespawnWait) {
        r.state = ProcessState::kStopped;
        r.message = "respawn cancelled: stopped by order";
      }
      continue;
    }
    // Desired running and not running: start for a new run id; respawn after the back-off.
    if (running) continue;
    if (r.state == ProcessState::kRespawnWait && r.run_id == r.desired_run_id) {
      if (now_s < m->respawn_at_s) continue;
      ++r.restarts;
      Start(m, now_s);
      continue;
    }
    // A new run, or stopped (at the deputy's start or by an earlier order). An exit, crash or failed start of the
    // current run waits for a new run id.
    if (r.run_id != r.desired_run_id || r.state == ProcessState::kStopped) {
      m->respawn_delay_s = options_.first_respawn_delay_s;
      Start(m, now_s);
    }
  }
}

DeputyReport Deputy::Report(double now_s) {
  DeputyReport report;
  report.host = options_.host;
  report.config_hash = config_.hash;
  report.orders_accepted = orders_accepted_;
  report.orders_refused = orders_refused_;
  report.last_refusal = last_refusal_;
  for (auto& m : managed_) {
    ProcessReport& r = m->report;
    r.cpu_percent = 0;
    r.rss_kb = 0;
    r.uptime_s = 0;
    if (r.pid > 0) {
      double cpu_s = 0;
      int64_t rss_kb = 0;
      if (ReadProcessUsage(r.pid, &cpu_s, &rss_kb)) {
        if (m->last_cpu_s >= 0 && now_s > m->last_cpu_at_s)
          r.cpu_percent = 100.0 * (cpu_s - m->last_cpu_s) / (now_s - m->last_cpu_at_s);
        m->last_cpu_s = cpu_s;
        m->last_cpu_at_s = now_s;
        r.rss_kb = rss_kb;
      }
      r.uptime_s = now_s - m->started_s;
    }
    report.processes.push_back(r);
  }
  return report;
}

std::vector<std::pair<std::string, std::string>> Deputy::TakeOutput(size_t max_bytes) {
  std::vector<std::pair<std::string, std::string>> out;
  for (auto& m : managed_) {
    if (!m->follow) continue;  // only followed logs are read (this runs every tick)
    std::ifstream in(m->log_path, std::ios::binary);
    if (!in) continue;
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    if (size < m->output_offset) m->output_offset = 0;  // the log was replaced
    if (size == m->output_offset) continue;
    const std::streamoff n = std::min<std::streamoff>(size - m->output_offset, static_cast<std::streamoff>(max_bytes));
    std::string text(static_cast<size_t>(n), '\0');
    in.seekg(m->output_offset);
    in.read(&text[0], n);
    m->output_offset += in.gcount();
    text.resize(static_cast<size_t>(in.gcount()));
    out.emplace_back(m->entry->name, std::move(text));
  }
  return out;
}

void Deputy::StopAll() {
  for (auto it = managed_.rbegin(); it != managed_.rend(); ++it) {
    Managed* m = it->get();
    m->report.desired_run = false;
    if (!m->child) continue;
    const int grace_ms = static_cast<int>(m->entry->grace_s * 1000);
    if (!m->child->StopWith(m->entry->stop_signal, grace_ms)) m->child->StopWith(SIGKILL, grace_ms);
    m->report.state = ProcessState::kStopped;
    m->report.pid = 0;
    m->report.message = "stopped with the deputy";
    m->child.reset();
  }
}

}  // namespace objscan

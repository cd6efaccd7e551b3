#include "procman/sheriff.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace objscan {
namespace {
// A process, a group or "all".
bool Matches(const ProcmanEntry& e, const std::string& target) {
  return target == "all" || e.name == target || e.group == target;
}
}  // namespace

Sheriff::Sheriff(ProcmanConfig config, SheriffOptions options)
    : config_(std::move(config)), options_(std::move(options)) {
  for (const auto& e : config_.entries) desired_[e.name] = Desired();
}

bool Sheriff::Select(const std::string& target, std::vector<const ProcmanEntry*>* entries, std::string* error) const {
  entries->clear();
  for (const auto& e : config_.entries)
    if (Matches(e, target)) entries->push_back(&e);
  if (entries->empty()) {
    std::string names;
    for (const auto& g : config_.Groups())
      if (!g.empty()) names += " " + g;
    *error = "'" + target + "' is neither a process nor a group of the config (groups:" + names + "; or all)";
    return false;
  }
  return true;
}

void Sheriff::NewRun(Desired* d, double now_s) {
  d->wanted = true;
  d->run_id = std::max(next_run_id_, d->report.run_id + 1);  // above every run id seen (a previous sheriff's too)
  next_run_id_ = d->run_id + 1;
  d->started_s = now_s;
}

bool Sheriff::Start(const std::string& target, double now_s, std::string* error) {
  std::vector<const ProcmanEntry*> entries;
  if (!Select(target, &entries, error)) return false;
  for (const ProcmanEntry* e : entries) {
    Desired& d = desired_[e->name];
    const bool running = d.has_report && d.report.state == ProcessState::kRunning && d.report.run_id == d.run_id &&
                         d.wanted;
    if (!running) NewRun(&d, now_s);
    d.wanted = true;
  }
  return true;
}

bool Sheriff::Restart(const std::string& target, double now_s, std::string* error) {
  std::vector<const ProcmanEntry*> entries;
  if (!Select(target, &entries, error)) return false;
  for (const ProcmanEntry* e : entries) NewRun(&desired_[e->name], now_s);
  return true;
}

bool Sheriff::Stop(const std::string& target, double now_s, std::string* error) {
  std::vector<const ProcmanEntry*> entries;
  if (!Select(target, &entries, error)) return false;
  for (const ProcmanEntry* e : entries) {
    Desired& d = desired_[e->name];
    d.wanted = false;
    if (d.started_s < 0) d.started_s = now_s;  // touched: ordered from now on
  }
  return true;
}

bool Sheriff::Follow(const std::string& name, std::string* error) {
  if (!name.empty() && !config_.Find(name)) {
    *error = "'" + name + "' is not a process of the config";
    return false;
  }
  follow_ = name;
  return true;
}

void Sheriff::OnDeputyReport(const DeputyReport& report, double now_s) {
  if (report.config_hash != config_.hash) {
    DeputySeen& f = foreign_[report.host];
    f.config_hash = report.config_hash;
    f.heard_s = now_s;
    return;
  }
  DeputySeen& seen = deputies_[report.host];
  seen.config_hash = report.config_hash;
  seen.heard_s = now_s;
  seen.orders_refused = report.orders_refused;
  seen.last_refusal = report.last_refusal;
  for (const auto& p : report.processes) {
    const ProcmanEntry* e = config_.Find(p.name);
    if (!e || e->host != report.host) continue;  // a deputy of the same config cannot run it; ignore
    Desired& d = desired_[p.name];
    d.has_report = true;
    d.report = p;
    // A sheriff that starts next to running deputies takes over their state instead of restarting everything.
    if (d.started_s < 0) {
      d.wanted = p.desired_run;
      d.run_id = p.desired_run_id;
      d.started_s = now_s;
      if (p.state == ProcessState::kRunning) d.status_at_s = now_s;  // already up: do not hold back its dependants
    }
    next_run_id_ = std::max(next_run_id_, std::max(p.run_id, p.desired_run_id) + 1);
  }
}

void Sheriff::OnProcessStatus(const std::string& process_name, double now_s) {
  auto it = desired_.find(process_name);
  if (it != desired_.end()) it->second.status_at_s = now_s;
}

bool Sheriff::Ready(const ProcmanEntry& entry) const {
  for (const auto& a : entry.after) {
    const Desired& d = desired_.at(a);
    if (d.status_at_s < 0 || d.status_at_s < d.started_s) return false;
  }
  return true;
}

std::vector<DeputyOrders> Sheriff::Orders(double /*now_s*/) const {
  std::vector<DeputyOrders> all;
  for (const auto& host : config_.Hosts()) {
    DeputyOrders o;
    o.host = host;
    o.config_hash = config_.hash;
    o.sheriff = options_.name;
    for (const auto& e : config_.entries) {
      if (e.host != host) continue;
      const Desired& d = desired_.at(e.name);
      if (d.started_s < 0) continue;  // never touched nor reported: leave the deputy's state alone
      o.processes.push_back({e.name, d.wanted && Ready(e), d.run_id, follow_ == e.name});
    }
    if (!o.processes.empty()) all.push_back(std::move(o));
  }
  return all;
}

std::vector<SheriffEntryView> Sheriff::Entries(double /*now_s*/) const {
  std::vector<SheriffEntryView> views;
  for (const auto& e : config_.entries) {
    const Desired& d = desired_.at(e.name);
    SheriffEntryView v;
    v.name = e.name;
    v.group = e.group;
    v.host = e.host;
    v.wanted = d.wanted;
    v.run_id = d.run_id;
    v.reported = d.has_report;
    v.report = d.report;
    v.status_seen = d.status_at_s >= 0 && d.status_at_s >= d.started_s;
    if (d.wanted)
      for (const auto& a : e.after) {
        const Desired& da = desired_.at(a);
        if (da.status_at_s < 0 || da.status_at_s < da.started_s) v.waiting_for.push_back(a);
      }
    views.push_back(std::move(v));
  }
  return views;
}

std::vector<SheriffDeputyView> Sheriff::Deputies(double now_s) const {
  std::vector<SheriffDeputyView> views;
  for (const auto& host : config_.Hosts()) {
    SheriffDeputyView v;
    v.host = host;
    auto it = deputies_.find(host);
    v.heard = it != deputies_.end();
    if (v.heard) {
      v.config_hash = it->second.config_hash;
      v.silent_for_s = now_s - it->second.heard_s;
      v.orders_refused = it->second.orders_refused;
      v.last_refusal = it->second.last_refusal;
    }
    v.silent = !v.heard || v.silent_for_s > options_.deputy_timeout_s;
    views.push_back(std::move(v));
  }
  for (const auto& [host, seen] : foreign_) {
    SheriffDeputyView v;
    v.host = host;
    v.foreign = true;
    v.heard = true;
    v.config_hash = seen.config_hash;
    v.silent_for_s = now_s - seen.heard_s;
    v.silent = v.silent_for_s > options_.deputy_timeout_s;
    views.push_back(std::move(v));
  }
  return views;
}

bool Sheriff::Running(const std::string& target) const {
  for (const auto& e : config_.entries) {
    if (!Matches(e, target)) continue;
    const Desired& d = desired_.at(e.name);
    if (!d.has_report || d.report.state != ProcessState::kRunning || d.report.run_id != d.run_id) return false;
  }
  return true;
}

bool Sheriff::StatusSeen(const std::string& target) const {
  for (const auto& e : config_.entries) {
    if (!Matches(e, target)) continue;
    const Desired& d = desired_.at(e.name);
    if (d.status_at_s < 0 || d.status_at_s < d.started_s) return false;
  }
  return true;
}

bool Sheriff::Ended(const std::string& target) const {
  for (const auto& e : config_.entries) {
    if (!Matches(e, target)) continue;
    const Desired& d = desired_.at(e.name);
    if (!d.has_report) return false;
    const ProcessState s = d.report.state;
    if (s == ProcessState::kRunning || s == ProcessState::kStopping || s == ProcessState::kRespawnWait) return false;
    if (d.wanted && d.report.run_id != d.run_id) return false;  // the ordered run has not happened yet
  }
  return true;
}

bool Sheriff::Names(const std::string& target) const {
  std::vector<const ProcmanEntry*> entries;
  std::string error;
  return Select(target, &entries, &error);
}

std::string FormatSheriffView(const Sheriff& sheriff, double now_s) {
  std::string out;
  char line[512];
  out += "deputies:";
  for (const auto& d : sheriff.Deputies(now_s)) {
    if (d.foreign) {
      std::snprintf(line, sizeof(line), "  %s FOREIGN (config %s, not ours: another session on this bus?)",
                    d.host.c_str(), d.config_hash.c_str());
    } else if (!d.heard) {
      std::snprintf(line, sizeof(line), "  %s SILENT (never heard: is its deputy started, on this bus?)",
                    d.host.c_str());
    } else if (d.silent) {
      std::snprintf(line, sizeof(line), "  %s SILENT for %.1f s", d.host.c_str(), d.silent_for_s);
    } else {
      std::snprintf(line, sizeof(line), "  %s ok", d.host.c_str());
    }
    out += line;
    if (!d.foreign && d.orders_refused > 0) out += " (refused " + std::to_string(d.orders_refused) + ": " + d.last_refusal + ")";
  }
  out += "\n";
  std::snprintf(line, sizeof(line), "%-16s %-12s %-12s %-14s %5s %7s %6s %8s %4s  %s\n", "PROCESS", "GROUP", "HOST",
                "STATE", "RUN", "PID", "CPU%", "RSS_MB", "RSP", "LAST EVENT");
  out += line;
  for (const auto& e : sheriff.Entries(now_s)) {
    std::string state = e.reported ? ProcessStateName(e.report.state) : "unknown";
    if (e.wanted && !e.waiting_for.empty()) {
      state = "waiting";
      std::string names;
      for (const auto& w : e.waiting_for) names += (names.empty() ? "" : ",") + w;
      std::snprintf(line, sizeof(line), "%-16s %-12s %-12s %-14s %5d %7s %6s %8s %4s  for %s\n", e.name.c_str(),
                    e.group.c_str(), e.host.c_str(), state.c_str(), e.run_id, "-", "-", "-", "-", names.c_str());
      out += line;
      continue;
    }
    if (e.reported && e.report.state == ProcessState::kRunning && e.report.run_id != e.run_id && e.wanted)
      state = "restarting";
    if (!e.wanted && e.reported && e.report.state == ProcessState::kRunning) state = "stopping";
    std::snprintf(line, sizeof(line), "%-16s %-12s %-12s %-14s %5d %7d %6.1f %8.1f %4d  %s\n", e.name.c_str(),
                  e.group.c_str(), e.host.c_str(), state.c_str(), e.reported ? e.report.run_id : 0,
                  e.report.pid, e.report.cpu_percent, e.report.rss_kb / 1024.0, e.report.restarts,
                  e.report.message.c_str());
    out += line;
  }
  return out;
}

bool ParseSheriffScript(const std::string& script, std::vector<SheriffStep>* steps, std::string* error) {
  steps->clear();
  std::string text = script;
  std::replace(text.begin(), text.end(), '\n', ';');
  std::stringstream in(text);
  std::string step;
  while (std::getline(in, step, ';')) {
    std::vector<std::string> words;
    std::string split_error;
    if (!SplitWords(step, &words, &split_error)) {
      *error = "script step '" + step + "': " + split_error;
      return false;
    }
    if (words.empty()) continue;
    SheriffStep s;
    s.verb = words[0];
    s.text = step;
    const bool wait = s.verb == "wait-running" || s.verb == "wait-status" || s.verb == "wait-exit";
    const bool command = s.verb == "start" || s.verb == "stop" || s.verb == "restart" || s.verb == "follow";
    auto number = [&](const std::string& w, double* v) {
      char* end = nullptr;
      *v = std::strtod(w.c_str(), &end);
      return end != w.c_str() && *end == '\0' && std::isfinite(*v) && *v >= 0;
    };
    bool ok = false;
    if (command) {
      ok = words.size() == 2;
      if (ok) s.target = words[1];
    } else if (wait) {
      ok = words.size() == 2 || (words.size() == 3 && number(words[2], &s.seconds));
      if (ok) s.target = words[1];
    } else if (s.verb == "sleep") {
      ok = words.size() == 2 && number(words[1], &s.seconds);
    }
    if (!ok) {
      *error = "script step '" + step +
               "': expected start|stop|restart|follow TARGET, wait-running|wait-status|wait-exit TARGET [SECONDS] "
               "or sleep SECONDS";
      return false;
    }
    steps->push_back(s);
  }
  if (steps->empty()) {
    *error = "the script has no step";
    return false;
  }
  return true;
}

}  // namespace objscan

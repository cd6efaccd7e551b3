#include "common/status.h"

#include "objscan/control_t.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <limits>

#include "common/bus.h"
#include "common/log.h"
#include "common/statistics.h"
#include "objscan/process_status_t.hpp"

namespace objscan {
namespace {
constexpr size_t kLatencyWindow = 1000;
constexpr size_t kMaxRejectedAhead = 64;  // rejected seqs ahead of a stream remembered at most

}  // namespace

StatusReporter::StatusReporter(Bus* bus, std::string name, std::string channel, double period_s)
    : bus_(bus),
      name_(std::move(name)),
      channel_(std::move(channel)),
      period_us_(static_cast<int64_t>(period_s * 1e6)),
      latency_window_ms_(kLatencyWindow) {
  char host[256] = {0};
  if (gethostname(host, sizeof(host) - 1) == 0) host_ = host;
}

void StatusReporter::Reject(const std::string& reason, const std::string& detail) {
  ++messages_in_;
  if (rejections_[reason]++ == 0) {
    LogWarning("rejected input (" + reason + ")" + (detail.empty() ? "" : ": " + detail) +
               " [further rejections of this kind are only counted]");
  }
}

SeqResult StatusReporter::ObserveSeq(const std::string& stream, int64_t seq) {
  auto it = streams_.find(stream);
  if (it == streams_.end()) {
    streams_[stream].last = seq;
    return SeqResult::kFirst;
  }
  SeqStream& st = it->second;
  // Differences as unsigned 64-bit values (no signed overflow for extreme seqs).
  const uint64_t ahead = seq > st.last ? static_cast<uint64_t>(seq) - static_cast<uint64_t>(st.last) : 0;
  const uint64_t behind = seq <= st.last ? static_cast<uint64_t>(st.last) - static_cast<uint64_t>(seq) : 0;
  if (ahead > static_cast<uint64_t>(kMaxSeqJump) || behind > static_cast<uint64_t>(kSeqReorderWindow)) {
    st.jump_run = st.jump_run > 0 && st.jump_last != std::numeric_limits<int64_t>::max() && seq == st.jump_last + 1
                      ? st.jump_run + 1
                      : 1;
    st.jump_last = seq;
    if (st.jump_run < kNewRunInputs) return SeqResult::kImplausibleJump;
    LogWarning(stream + ": sequence numbers jumped from " + std::to_string(st.last) + " to " +
               std::to_string(seq - kNewRunInputs + 1) + " and went on for " + std::to_string(kNewRunInputs) +
               " inputs: a new run (the source restarted?)");
    st.last = seq;
    st.jump_run = 0;
    st.rejected_ahead.clear();
    return SeqResult::kNewRun;
  }
  st.jump_run = 0;
  if (seq <= st.last) return SeqResult::kRepeatedOrOld;
  // Rejected inputs in between were received, not dropped.
  uint64_t missing = ahead - 1;
  auto& noted = st.rejected_ahead;  // sorted, distinct, all > last: those < seq lie in the gap
  const auto in_gap = std::lower_bound(noted.begin(), noted.end(), seq);
  missing -= static_cast<uint64_t>(in_gap - noted.begin());
  noted.erase(noted.begin(), std::upper_bound(in_gap, noted.end(), seq));
  st.last = seq;
  if (missing > 0) {
    const uint64_t room = static_cast<uint64_t>(std::numeric_limits<int64_t>::max() - dropped_inputs_);
    dropped_inputs_ += static_cast<int64_t>(std::min(missing, room));  // saturates
    return SeqResult::kGap;
  }
  return SeqResult::kNext;
}

bool StatusReporter::AcceptSeq(const std::string& stream, int64_t seq, const std::string& what) {
  const SeqResult r = ObserveSeq(stream, seq);
  if (r == SeqResult::kRepeatedOrOld) {
    Reject(what + ": out of order or repeated", "seq " + std::to_string(seq));
    return false;
  }
  if (r == SeqResult::kImplausibleJump) {
    Reject(what + ": implausible seq jump", "seq " + std::to_string(seq));
    return false;
  }
  return true;
}

bool SessionIdFromText(const std::string& text, int64_t* id, std::string* error) {
  if (text.empty()) {
    std::random_device device;
    uint64_t v = 0;
    while (v == 0)
      v = (static_cast<uint64_t>(device()) << 32) ^ static_cast<uint64_t>(device()) ^
          static_cast<uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
    *id = static_cast<int64_t>(v);
    return true;
  }
  std::string digits = text;
  if (digits.size() > 2 && digits[0] == '0' && (digits[1] == 'x' || digits[1] == 'X')) digits = digits.substr(2);
  const bool hex = !digits.empty() && digits.size() <= 16 &&
                   std::all_of(digits.begin(), digits.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
  const uint64_t v = hex ? std::strtoull(digits.c_str(), nullptr, 16) : 0;
  if (!hex || v == 0) {
    if (error) *error = "session id '" + text + "': 1-16 hex digits, not zero";
    return false;
  }
  *id = static_cast<int64_t>(v);
  return true;
}

std::string SessionIdText(int64_t id) {
  char text[24];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(id));
  return text;
}

bool StatusReporter::AcceptSession(int64_t session_id, const std::string& what) {
  if (session_id == 0 || session_id == session_id_) return true;
  if (session_id_ == 0) {
    session_id_ = session_id;
    return true;
  }
  ++foreign_session_inputs_;
  SetValue("foreign_session_inputs", static_cast<double>(foreign_session_inputs_));
  constexpr size_t kMaxLoggedSessions = 16;  // a flood of forged ids is counted, not logged one by one
  if (foreign_sessions_.size() < kMaxLoggedSessions && foreign_sessions_.insert(session_id).second) {
    LogError("another session is on this bus: " + what + " of session " + SessionIdText(session_id) +
             " refused (this process keeps to session " + SessionIdText(session_id_) +
             ", the first it heard). Give each session a bus of its own: objscan run picks a free one unless "
             "--lcm-url is given; across hosts, another multicast port or group");
  }
  Reject(what + ": foreign session", "session " + std::to_string(session_id));
  return false;
}

void StatusReporter::Reject(const std::string& reason, const std::string& detail, const std::string& stream,
                            int64_t seq) {
  Reject(reason, detail);
  NoteRejectedSeq(stream, seq);
}

void StatusReporter::NoteRejectedSeq(const std::string& stream, int64_t seq) {
  auto it = streams_.find(stream);
  if (it == streams_.end() || seq <= it->second.last) return;
  std::vector<int64_t>& ahead = it->second.rejected_ahead;
  auto pos = std::lower_bound(ahead.begin(), ahead.end(), seq);
  if (pos != ahead.end() && *pos == seq) return;
  ahead.insert(pos, seq);
  if (ahead.size() > kMaxRejectedAhead) ahead.pop_back();  // the farthest ahead go first
}

void StatusReporter::RecordLatencyMs(double ms) { latency_window_ms_.Add(ms); }

void StatusReporter::SetValue(const std::string& name, double value) {
  for (auto& kv : values_) {
    if (kv.first == name) {
      kv.second = value;
      return;
    }
  }
  values_.emplace_back(name, value);
}

double StatusReporter::value(const std::string& name) const {
  for (const auto& kv : values_)
    if (kv.first == name) return kv.second;
  return 0.0;
}

void StatusReporter::SetState(int8_t state, const std::string& detail) {
  state_ = state;
  state_detail_ = detail;
}

int64_t StatusReporter::rejected(const std::string& reason) const {
  auto it = rejections_.find(reason);
  return it == rejections_.end() ? 0 : it->second;
}

int64_t StatusReporter::rejected_total() const {
  int64_t total = 0;
  for (const auto& kv : rejections_) total += kv.second;
  return total;
}

void StatusReporter::PublishIfDue(int64_t wall_utime, bool force) {
  if (bus_ == nullptr) return;
  if (!force && wall_utime - last_publish_us_ < period_us_) return;
  last_publish_us_ = wall_utime;
  process_status_t msg;
  msg.utime = wall_utime;
  msg.seq = status_seq_++;
  msg.name = name_;
  msg.host = host_;
  msg.pid = static_cast<int32_t>(getpid());
  msg.state = state_;
  msg.state_detail = state_detail_;
  msg.last_data_utime = last_data_utime_;
  msg.messages_in = messages_in_;
  msg.messages_out = messages_out_;
  msg.messages_rejected = rejected_total();
  for (const auto& kv : rejections_) {
    msg.rejection_reason.push_back(kv.first);
    msg.rejection_count.push_back(kv.second);
  }
  msg.num_rejection_reasons = static_cast<int32_t>(msg.rejection_reason.size());
  msg.dropped_inputs = dropped_inputs_;
  msg.latency_p50_ms = Percentile(latency_window_ms_.values(), 0.5);
  msg.latency_p99_ms = Percentile(latency_window_ms_.values(), 0.99);
  for (const auto& kv : values_) {
    msg.value_name.push_back(kv.first);
    msg.value.push_back(kv.second);
  }
  msg.num_values = static_cast<int32_t>(msg.value.size());
  bus_->PublishMessage(channel_, msg);
}

std::function<void(const RawMessage&)> StatusReporter::MalformedHandler(const std::string& what) {
  return [this, what](const RawMessage& raw) {
    Reject(what + ": malformed",
           (raw.why.empty() ? "" : raw.why + ", ") + std::to_string(raw.size) + " bytes on " + raw.channel);
  };
}

void PublishFinished(Bus& bus, StatusReporter& status, const std::string& channel, const std::string& sender,
                     int64_t utime, int64_t last_seq, const std::string& argument) {
  control_t reply;
  reply.session_id = status.session_id();  // the session it keeps to (0: none heard)
  reply.utime = utime;
  reply.sender = sender;
  reply.target = "*";
  reply.command = control_t::COMMAND_FINISHED;
  reply.last_seq = last_seq;
  reply.argument = argument;
  if (bus.PublishMessage(channel, reply))
    status.CountOut();
  else
    LogWarning("publishing on " + channel + " failed");
}

bool IsFinalizeRequest(const control_t& msg, const std::string& name) {
  return msg.command == control_t::COMMAND_FINALIZE && msg.target == name;
}

}  // namespace objscan

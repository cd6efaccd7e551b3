#include "viewer/log_player.h"

#include <lcm/eventlog.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace objscan {

struct LogPlayer::Pending {
  bool valid = false;
  std::string channel;
  std::vector<uint8_t> data;
  int64_t utime = 0;
};

LogPlayer::~LogPlayer() {
  if (log_ != nullptr) lcm_eventlog_destroy(log_);
  delete pending_;
}

bool LogPlayer::Open(const std::string& path, std::string* error) {
  if (log_ != nullptr) lcm_eventlog_destroy(log_);
  log_ = lcm_eventlog_create(path.c_str(), "r");
  if (log_ == nullptr) {
    if (error) *error = "cannot open log '" + path + "'";
    return false;
  }
  path_ = path;
  num_events_ = 0;
  bool first = true;
  while (lcm_eventlog_event_t* event = lcm_eventlog_read_next_event(log_)) {
    if (first) first_utime_ = event->timestamp;
    first = false;
    last_utime_ = std::max(last_utime_, event->timestamp);
    ++num_events_;
    lcm_eventlog_free_event(event);
  }
  if (num_events_ == 0) {
    if (error) *error = "log '" + path + "' has no events";
    lcm_eventlog_destroy(log_);
    log_ = nullptr;
    return false;
  }
  if (pending_ == nullptr) pending_ = new Pending;
  return Rewind();
}

bool LogPlayer::Rewind() {
  // Reopening is the simplest exact rewind (seek_to_timestamp is approximate).
  lcm_eventlog_destroy(log_);
  log_ = lcm_eventlog_create(path_.c_str(), "r");
  if (log_ == nullptr) return false;
  pending_->valid = false;
  clock_utime_ = first_utime_;
  delivered_ = 0;
  at_end_ = false;
  return ReadAhead();
}

bool LogPlayer::ReadAhead() {
  pending_->valid = false;
  if (log_ == nullptr) return false;
  lcm_eventlog_event_t* event = lcm_eventlog_read_next_event(log_);
  if (event == nullptr) {
    at_end_ = true;
    return false;
  }
  pending_->valid = true;
  pending_->channel.assign(event->channel, static_cast<size_t>(std::max(event->channellen, 0)));
  const auto* bytes = static_cast<const uint8_t*>(event->data);
  pending_->data.assign(bytes, bytes + std::max(event->datalen, 0));
  pending_->utime = event->timestamp;
  lcm_eventlog_free_event(event);
  return true;
}

bool LogPlayer::DeliverPending(const EventHandler& handler) {
  if (pending_ == nullptr || !pending_->valid) return false;
  clock_utime_ = std::max(clock_utime_, pending_->utime);
  ++delivered_;
  handler(pending_->channel, pending_->data.data(), static_cast<int>(pending_->data.size()), pending_->utime);
  ReadAhead();
  return true;
}

int LogPlayer::Advance(double wall_dt_s, const EventHandler& handler, int max_events) {
  if (!is_open() || !playing_ || at_end_) return 0;
  clock_utime_ += static_cast<int64_t>(std::llround(std::max(wall_dt_s, 0.0) * speed_ * 1e6));
  int count = 0;
  while (count < max_events && pending_->valid && pending_->utime <= clock_utime_) {
    DeliverPending(handler);
    ++count;
  }
  if (at_end_) playing_ = false;
  return count;
}

bool LogPlayer::Step(const EventHandler& handler) {
  playing_ = false;
  return is_open() && DeliverPending(handler);
}

int64_t LogPlayer::DeliverUntil(int64_t utime, const EventHandler& handler) {
  int64_t count = 0;
  while (is_open() && pending_->valid && pending_->utime <= utime) {
    DeliverPending(handler);
    ++count;
  }
  clock_utime_ = std::max(clock_utime_, std::min(utime, last_utime_));
  return count;
}

void LogPlayer::Seek(int64_t utime, const std::function<void()>& reset, const EventHandler& handler) {
  if (!is_open()) return;
  if (utime < clock_utime_) {
    if (reset) reset();
    if (!Rewind()) return;
  }
  DeliverUntil(utime, handler);
  clock_utime_ = std::clamp(utime, first_utime_, last_utime_);
}

}  // namespace objscan

// LogPlayer: reads an LCM log file directly (lcm/eventlog.h) and hands its events to a callback at a chosen
// speed, with pause, single step and seek. Log time is the events' timestamps (µs; for datalog:// logs the data
// time, for lcm-logger logs the wall clock of the recording).
// Seeking backwards rewinds to the start and re-delivers every event up to the seek time (after calling the
// reset callback), so accumulated views (trajectories) are complete after any seek.
// Not thread-safe. Open() does not throw; a truncated final event ends the log there.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

struct _lcm_eventlog_t;

namespace objscan {

class LogPlayer {
 public:
  using EventHandler = std::function<void(const std::string& channel, const void* data, int size, int64_t utime)>;

  LogPlayer() = default;
  ~LogPlayer();
  LogPlayer(const LogPlayer&) = delete;
  LogPlayer& operator=(const LogPlayer&) = delete;

  // Opens the log and scans it once for its time span and event count. False with *error when unreadable/empty.
  bool Open(const std::string& path, std::string* error);
  bool is_open() const { return log_ != nullptr; }

  int64_t first_utime() const { return first_utime_; }
  int64_t last_utime() const { return last_utime_; }
  int64_t num_events() const { return num_events_; }
  // Log time reached: timestamp of the last event delivered (first_utime before any), or the playback clock.
  int64_t current_utime() const { return clock_utime_; }
  int64_t events_delivered() const { return delivered_; }
  bool at_end() const { return at_end_; }

  bool playing() const { return playing_; }
  void set_playing(bool playing) { playing_ = playing; }
  double speed() const { return speed_; }
  void set_speed(double speed) { speed_ = speed > 0 ? speed : speed_; }

  // Advances the playback clock by wall_dt_s * speed when playing and delivers the events that became due.
  // At most max_events per call (the rest follow on the next call). Returns the number delivered.
  int Advance(double wall_dt_s, const EventHandler& handler, int max_events = 100000);
  // Delivers the next event regardless of the clock (pauses playback). Returns false at the end of the log.
  bool Step(const EventHandler& handler);
  // Delivers every remaining event with timestamp <= utime (as fast as possible). Returns the number delivered.
  int64_t DeliverUntil(int64_t utime, const EventHandler& handler);
  // Moves to log time utime: backwards = reset() + rewind + deliver up to utime; forwards = DeliverUntil.
  void Seek(int64_t utime, const std::function<void()>& reset, const EventHandler& handler);

 private:
  bool ReadAhead();  // loads the next event into pending_ (false at end)
  bool DeliverPending(const EventHandler& handler);
  bool Rewind();

  std::string path_;
  _lcm_eventlog_t* log_ = nullptr;
  struct Pending;
  Pending* pending_ = nullptr;
  int64_t first_utime_ = 0;
  int64_t last_utime_ = 0;
  int64_t num_events_ = 0;
  int64_t clock_utime_ = 0;
  int64_t delivered_ = 0;
  bool at_end_ = false;
  bool playing_ = true;
  double speed_ = 1.0;
};

}  // namespace objscan

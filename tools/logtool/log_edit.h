// What LCM 1.3.1's tools lack for working with recorded sessions (`objscan log ...`): a summary of a log (duration,
// channels, counts, rates, gaps, lost sequence numbers, damage), and new logs made from old ones: the events of
// chosen channels (filter), of a time window (cut), or of several logs in time order (merge). A session log holds the
// processes' outputs next to the sensor data; `filter --keep` makes a log that lcm-logplayer can play into live
// processes without them hearing the old outputs.
//
// Times: event timestamps are the logger's receive times (µs since 1970); windows are seconds from the first event of
// the input. Damage: a damaged input (spliced garbage, a cut last event) is read past, every readable event is kept,
// and the damage is reported in the result: the caller says so and exits non-zero, the output is never silently
// shorter than the input. Outputs are written to OUT.partial and renamed when complete; an output path that is one of
// the inputs is refused. LCM-free (common/lcm_log.h does the file format).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "common/lcm_log.h"

namespace objscan {

struct LogChannelInfo {
  int64_t count = 0;
  int64_t bytes = 0;
  int64_t first_us = 0, last_us = 0;  // µs, logger times of the first and last event
  double rate_hz = 0;                 // (count - 1) / (last - first); 0 with fewer than two events
  double median_interval_s = 0;       // s, between consecutive events
  double max_gap_s = 0;               // s, the longest interval between consecutive events
  double max_gap_at_s = 0;            // s from the log's first event, where that interval starts
  int gaps = 0;                       // intervals longer than max(5 x median interval, 0.5 s)
  // Sequence numbers (bytes 16..23 of an objscan message): reported only for channels whose seq rises by exactly 1
  // from one message to the next at least 90 % of the time (images, odometry, poses), where a jump means loss.
  bool has_seq = false;
  int64_t seq_missing = 0;    // numbers skipped by forward jumps
  int64_t seq_backwards = 0;  // steps that went back or repeated (a restarted sender, a second session)
};

struct LogInfo {
  int64_t events = 0;
  int64_t bytes = 0;                  // event payloads
  int64_t first_us = 0, last_us = 0;  // µs, logger times of the first and last event
  int64_t timestamps_backwards = 0;   // events whose timestamp is earlier than the one before
  std::map<std::string, LogChannelInfo> channels;
  LcmLogDamage damage;
};

// Reads the whole log. False with *error when it cannot be opened or is no log; damage is in info->damage.
bool ReadLogInfo(const std::string& path, LogInfo* info, std::string* error);
// Human-readable table (one line per channel, then gaps, lost sequence numbers and damage).
std::string FormatLogInfo(const std::string& path, const LogInfo& info);

// Event selection: channel names or shell-style patterns (fnmatch: * ? [..]), and optionally a rule on the event
// itself (e.g. the drivers' messages, common/bus.h IsDriverMessage). An event is kept when no drop pattern matches
// its channel and either there is no keep rule at all, or a keep pattern matches, or keep_event says so.
struct ChannelSelection {
  std::vector<std::string> keep, drop;
  std::function<bool(const LcmLogEvent&)> keep_event;  // empty: none
  bool Selects(const LcmLogEvent& event) const;
};
// Splits "A,B*,C" into patterns. False with *error for an empty list or an empty item ("A,,B").
bool ParseChannelPatterns(const std::string& list, std::vector<std::string>* patterns, std::string* error);

struct LogEditResult {
  int64_t events_in = 0, events_out = 0;
  std::map<std::string, int64_t> channels_out;     // events written per channel
  std::vector<std::string> patterns_never_matched;  // keep/drop patterns that matched no channel of the input
  std::vector<std::string> damage;                  // "IN: what was damaged", one per damaged input
};

// Writes to out the events of in whose channel is selected and whose time lies in [from_s, to_s) seconds after the
// log's first event. Event order and timestamps are kept. False with *error when in cannot be read, out cannot be
// written, or out is in.
bool FilterLog(const std::string& in, const std::string& out, const ChannelSelection& selection, double from_s,
               double to_s, LogEditResult* result, std::string* error);

// Writes to out the events of all inputs in timestamp order (a stable merge: equal times keep the inputs' order,
// each input's own order is kept even where its timestamps go back). False with *error as for FilterLog.
bool MergeLogs(const std::vector<std::string>& inputs, const std::string& out, LogEditResult* result,
               std::string* error);

}  // namespace objscan

#include "tools/logtool/log_edit.h"

#include <fnmatch.h>
#include <sys/stat.h>

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "common/bus.h"  // RawMessageSeq


namespace objscan {
namespace {

bool SameFile(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  if (stat(a.c_str(), &sa) != 0 || stat(b.c_str(), &sb) != 0) return false;
  return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

// Opens OUT.partial; Finish renames it to OUT (or removes it on failure).
class PartialOutput {
 public:
  explicit PartialOutput(std::string out) : out_(std::move(out)), partial_(out_ + ".partial") {}
  ~PartialOutput() {
    if (!finished_) {
      std::string ignored;
      writer_.Close(&ignored);
      std::remove(partial_.c_str());
    }
  }
  bool Open(std::string* error) { return writer_.Open(partial_, error); }
  bool Write(const LcmLogEvent& e, std::string* error) { return writer_.Write(e, error); }
  bool Finish(std::string* error) {
    if (!writer_.Close(error)) return false;
    if (std::rename(partial_.c_str(), out_.c_str()) != 0) {
      *error = "cannot rename " + partial_ + " to " + out_;
      return false;
    }
    finished_ = true;
    return true;
  }

 private:
  std::string out_, partial_;
  LcmLogWriter writer_;
  bool finished_ = false;
};

std::string Seconds(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", s);
  return b;
}

}  // namespace

bool ReadLogInfo(const std::string& path, LogInfo* info, std::string* error) {
  *info = LogInfo{};
  LcmLogReader log;
  if (!log.Open(path, error)) return false;
  struct Track {
    std::vector<int64_t> times;
    int64_t seq_steps = 0, seq_plus_one = 0, seq_missing = 0, seq_backwards = 0;
    bool have_seq = false;
    int64_t last_seq = 0;
  };
  std::map<std::string, Track> tracks;
  LcmLogEvent e;
  int64_t previous_us = 0;
  while (log.Next(&e)) {
    if (info->events == 0) info->first_us = e.timestamp_us;
    if (info->events > 0 && e.timestamp_us < previous_us) ++info->timestamps_backwards;
    previous_us = e.timestamp_us;
    info->last_us = std::max(info->last_us, e.timestamp_us);
    ++info->events;
    info->bytes += static_cast<int64_t>(e.data.size());
    LogChannelInfo& c = info->channels[e.channel];
    Track& t = tracks[e.channel];
    if (c.count == 0) c.first_us = e.timestamp_us;
    c.last_us = e.timestamp_us;
    ++c.count;
    c.bytes += static_cast<int64_t>(e.data.size());
    t.times.push_back(e.timestamp_us);
    int64_t seq = 0;
    if (RawMessageSeq(e.data.data(), static_cast<int>(e.data.size()), &seq)) {
      if (t.have_seq) {
        ++t.seq_steps;
        if (seq == t.last_seq + 1) ++t.seq_plus_one;
        if (seq > t.last_seq + 1) t.seq_missing += seq - t.last_seq - 1;
        if (seq <= t.last_seq) ++t.seq_backwards;
      }
      t.have_seq = true;
      t.last_seq = seq;
    }
  }
  info->damage = log.damage();
  for (auto& [channel, c] : info->channels) {
    Track& t = tracks[channel];
    const double span_s = (c.last_us - c.first_us) * 1e-6;
    c.rate_hz = c.count > 1 && span_s > 0 ? (c.count - 1) / span_s : 0;
    std::vector<double> intervals;
    for (size_t i = 1; i < t.times.size(); ++i) intervals.push_back((t.times[i] - t.times[i - 1]) * 1e-6);
    if (!intervals.empty()) {
      std::vector<double> sorted = intervals;
      std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
      c.median_interval_s = sorted[sorted.size() / 2];
      const double gap_s = std::max(5 * c.median_interval_s, 0.5);
      for (size_t i = 0; i < intervals.size(); ++i) {
        if (intervals[i] > c.max_gap_s) {
          c.max_gap_s = intervals[i];
          c.max_gap_at_s = (t.times[i] - info->first_us) * 1e-6;
        }
        if (intervals[i] > gap_s) ++c.gaps;
      }
    }
    if (t.seq_steps > 0 && t.seq_plus_one >= 0.9 * t.seq_steps) {
      c.has_seq = true;
      c.seq_missing = t.seq_missing;
      c.seq_backwards = t.seq_backwards;
    }
  }
  return true;
}

std::string FormatLogInfo(const std::string& path, const LogInfo& info) {
  std::ostringstream s;
  const double duration_s = (info.last_us - info.first_us) * 1e-6;
  s << path << ": " << info.events << " events, " << info.channels.size() << " channels, " << Seconds(duration_s)
    << " s, " << info.bytes << " bytes of messages\n";
  char line[256];
  std::snprintf(line, sizeof line, "%-24s %9s %13s %9s %9s %10s %s\n", "channel", "events", "bytes", "rate Hz",
                "start s", "max gap s", "lost (seq)");
  s << line;
  for (const auto& [channel, c] : info.channels) {
    const std::string lost = c.has_seq ? std::to_string(c.seq_missing) : "-";
    std::snprintf(line, sizeof line, "%-24s %9" PRId64 " %13" PRId64 " %9.2f %9.3f %10.3f %s\n", channel.c_str(),
                  c.count, c.bytes, c.rate_hz, (c.first_us - info.first_us) * 1e-6, c.max_gap_s, lost.c_str());
    s << line;
  }
  bool notes = false;
  for (const auto& [channel, c] : info.channels) {
    if (c.gaps > 0) {
      s << "gap: " << channel << " has " << c.gaps << " interval" << (c.gaps == 1 ? "" : "s")
        << " over 5x its median " << Seconds(c.median_interval_s) << " s; the longest " << Seconds(c.max_gap_s)
        << " s from " << Seconds(c.max_gap_at_s) << " s\n";
      notes = true;
    }
    if (c.has_seq && c.seq_missing > 0) {
      s << "lost: " << channel << " skips " << c.seq_missing << " sequence number" << (c.seq_missing == 1 ? "" : "s")
        << " (messages its sender published that are not in the log)\n";
      notes = true;
    }
    if (c.has_seq && c.seq_backwards > 0) {
      s << "restart: " << channel << "'s sequence numbers go back " << c.seq_backwards << " time"
        << (c.seq_backwards == 1 ? "" : "s") << " (a restarted sender, a second session on the bus, or a sender that publishes again)\n";
      notes = true;
    }
  }
  if (info.timestamps_backwards > 0) {
    s << "order: " << info.timestamps_backwards << " event" << (info.timestamps_backwards == 1 ? " has" : "s have")
      << " an earlier timestamp than the event before (players play them in file order)\n";
    notes = true;
  }
  if (info.damage.Any()) {
    s << "DAMAGED: " << info.damage.Describe() << "\n";
    notes = true;
  }
  if (!notes) s << "no gaps, no lost sequence numbers, no damage\n";
  return s.str();
}

bool ChannelSelection::Selects(const LcmLogEvent& event) const {
  auto matches = [&](const std::vector<std::string>& patterns) {
    for (const auto& p : patterns)
      if (fnmatch(p.c_str(), event.channel.c_str(), 0) == 0) return true;
    return false;
  };
  if (matches(drop)) return false;
  if (keep.empty() && !keep_event) return true;
  return matches(keep) || (keep_event && keep_event(event));
}

bool ParseChannelPatterns(const std::string& list, std::vector<std::string>* patterns, std::string* error) {
  patterns->clear();
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) {
      *error = "empty channel name in '" + list + "' (give names or patterns separated by commas: A,B*,C)";
      return false;
    }
    patterns->push_back(item);
  }
  if (patterns->empty() || list.back() == ',') {
    *error = "empty channel name in '" + list + "' (give names or patterns separated by commas: A,B*,C)";
    return false;
  }
  return true;
}

bool FilterLog(const std::string& in, const std::string& out, const ChannelSelection& selection, double from_s,
               double to_s, LogEditResult* result, std::string* error) {
  *result = LogEditResult{};
  if (std::isnan(from_s) || std::isnan(to_s) || from_s < 0 || to_s <= from_s) {
    *error = "the window must satisfy 0 <= from < to (seconds from the log's first event)";
    return false;
  }
  if (SameFile(in, out)) {
    *error = "the output " + out + " is the input: write to another file";
    return false;
  }
  LcmLogReader log;
  if (!log.Open(in, error)) return false;
  PartialOutput writer(out);
  if (!writer.Open(error)) return false;
  std::map<std::string, bool> seen_pattern;
  for (const auto& p : selection.keep) seen_pattern[p] = false;
  for (const auto& p : selection.drop) seen_pattern[p] = false;
  LcmLogEvent e;
  int64_t first_us = 0;
  while (log.Next(&e)) {
    if (result->events_in++ == 0) first_us = e.timestamp_us;
    for (auto& [p, seen] : seen_pattern)
      if (!seen && fnmatch(p.c_str(), e.channel.c_str(), 0) == 0) seen = true;
    const double t_s = (e.timestamp_us - first_us) * 1e-6;
    if (t_s < from_s || t_s >= to_s || !selection.Selects(e)) continue;
    if (!writer.Write(e, error)) return false;
    ++result->events_out;
    ++result->channels_out[e.channel];
  }
  for (const auto& [p, seen] : seen_pattern)
    if (!seen) result->patterns_never_matched.push_back(p);
  if (log.damage().Any()) result->damage.push_back(in + ": " + log.damage().Describe());
  return writer.Finish(error);
}

bool MergeLogs(const std::vector<std::string>& inputs, const std::string& out, LogEditResult* result,
               std::string* error) {
  *result = LogEditResult{};
  if (inputs.empty()) {
    *error = "no input logs to merge";
    return false;
  }
  std::vector<std::unique_ptr<LcmLogReader>> logs;
  std::vector<LcmLogEvent> heads(inputs.size());
  std::vector<bool> have(inputs.size(), false);
  for (size_t i = 0; i < inputs.size(); ++i) {
    if (SameFile(inputs[i], out)) {
      *error = "the output " + out + " is one of the inputs: write to another file";
      return false;
    }
    logs.push_back(std::make_unique<LcmLogReader>());
    if (!logs.back()->Open(inputs[i], error)) return false;
    have[i] = logs[i]->Next(&heads[i]);
    result->events_in += have[i] ? 1 : 0;
  }
  PartialOutput writer(out);
  if (!writer.Open(error)) return false;
  while (true) {
    int best = -1;
    for (size_t i = 0; i < inputs.size(); ++i)
      if (have[i] && (best < 0 || heads[i].timestamp_us < heads[static_cast<size_t>(best)].timestamp_us))
        best = static_cast<int>(i);
    if (best < 0) break;
    const size_t b = static_cast<size_t>(best);
    if (!writer.Write(heads[b], error)) return false;
    ++result->events_out;
    ++result->channels_out[heads[b].channel];
    have[b] = logs[b]->Next(&heads[b]);
    result->events_in += have[b] ? 1 : 0;
  }
  for (size_t i = 0; i < inputs.size(); ++i)
    if (logs[i]->damage().Any()) result->damage.push_back(inputs[i] + ": " + logs[i]->damage().Describe());
  return writer.Finish(error);
}

}  // namespace objscan

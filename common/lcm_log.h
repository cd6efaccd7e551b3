// Reading LCM log files (the lcm-logger format), the one home for it: events in order, past damage. An event is
// magic 0xEDA1DA01, event number, timestamp (µs), channel length, data length (big-endian), channel, data. A region
// that does not parse as an event (spliced garbage, a bad length) is skipped up to the next event header that does,
// and counted; a last event cut short (a log whose writer died) is counted too. lcm_eventlog_read_next_event of LCM
// 1.3.1 instead stops at the first bad length, silently: every later event is lost.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace objscan {

struct LcmLogEvent {
  int64_t event_number = 0;
  int64_t timestamp_us = 0;  // µs, the logger's receive time (not the message's own utime)
  std::string channel;
  std::vector<uint8_t> data;
};

struct LcmLogDamage {
  int64_t skipped_bytes = 0;    // bytes in regions that were not events (before resynchronising)
  int skipped_regions = 0;      // such regions
  int64_t first_offset = -1;    // byte offset of the first damage, -1 when none
  bool truncated_tail = false;  // the file ends inside an event
  bool Any() const { return skipped_bytes > 0 || truncated_tail; }
  std::string Describe() const;  // "" when none, else e.g. "4096 bytes in 1 region skipped from byte 1234; ..."
};

class LcmLogReader {
 public:
  LcmLogReader() = default;
  ~LcmLogReader();
  LcmLogReader(const LcmLogReader&) = delete;
  LcmLogReader& operator=(const LcmLogReader&) = delete;

  // Opens path. False with *error when it cannot be read, is empty, or does not start with an event header (not an
  // LCM log: a file that is not one is refused rather than scanned for a chance header).
  bool Open(const std::string& path, std::string* error);
  // The next event; false at the end of the file. Damage on the way is skipped and counted in damage().
  bool Next(LcmLogEvent* event);
  const LcmLogDamage& damage() const { return damage_; }
  int64_t events() const { return events_; }

 private:
  bool ReadAt(int64_t offset, void* out, size_t bytes);
  bool CutTail();  // the file ends inside the event at offset_: counted, reading ends (returns false)
  std::FILE* file_ = nullptr;
  int64_t size_ = 0, offset_ = 0, events_ = 0;
  LcmLogDamage damage_;
};

// Writes an LCM log in the lcm-logger format (what lcm-logplayer, lcm-spy and LcmLogReader read). Events are
// numbered 0, 1, 2, ... in the order written, as lcm-logger numbers them; their timestamps are written as given.
// Errors (cannot create, disk full) come back from Write / Close with *error; nothing is retried.
class LcmLogWriter {
 public:
  LcmLogWriter() = default;
  ~LcmLogWriter();  // closes without reporting: call Close to learn whether everything reached the file
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;

  bool Open(const std::string& path, std::string* error);  // creates path, or truncates it
  bool Write(const LcmLogEvent& event, std::string* error);  // event.event_number is ignored (renumbered)
  bool Close(std::string* error);
  int64_t events() const { return events_; }

 private:
  std::FILE* file_ = nullptr;
  std::string path_;
  int64_t events_ = 0;
};

}  // namespace objscan

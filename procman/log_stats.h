// Reads an LCM log file and counts its events per channel (for checking that lcm-logger kept everything and for
// session summaries). Message data times come from the message itself: every objscan type starts with
// int64 utime right after the 8-byte fingerprint.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "common/bus.h"

namespace objscan {

struct ChannelStats {
  int64_t count = 0;
  int64_t bytes = 0;
  int64_t first_utime = 0;  // µs, data time of the first message (from the message's utime field)
  int64_t last_utime = 0;   // µs, data time of the last message
};

// RawMessageUtime / RawMessageSeq (common/bus.h) read a raw message's utime and seq.

// Counts every event of the log (common/lcm_log.h). Returns false with *error when the file cannot be opened, is no
// log, or is damaged (the stats then hold the events that could be read).
bool ReadLogStats(const std::string& path, std::map<std::string, ChannelStats>* stats, std::string* error);

}  // namespace objscan

#include "procman/log_stats.h"

#include <lcm/eventlog.h>

namespace objscan {
namespace {
int64_t ReadBigEndian64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return static_cast<int64_t>(v);
}
}  // namespace

bool RawMessageUtime(const void* data, int size, int64_t* utime) {
  if (size < 16) return false;
  *utime = ReadBigEndian64(static_cast<const uint8_t*>(data) + 8);
  return true;
}

bool RawMessageSeq(const void* data, int size, int64_t* seq) {
  if (size < 24) return false;
  *seq = ReadBigEndian64(static_cast<const uint8_t*>(data) + 16);
  return true;
}

bool ReadLogStats(const std::string& path, std::map<std::string, ChannelStats>* stats, std::string* error) {
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "r");
  if (log == nullptr) {
    *error = "cannot open LCM log " + path;
    return false;
  }
  stats->clear();
  while (lcm_eventlog_event_t* event = lcm_eventlog_read_next_event(log)) {
    ChannelStats& s = (*stats)[std::string(event->channel, event->channellen)];
    int64_t utime = 0;
    if (RawMessageUtime(event->data, event->datalen, &utime)) {
      if (s.count == 0) s.first_utime = utime;
      s.last_utime = utime;
    }
    ++s.count;
    s.bytes += event->datalen;
    lcm_eventlog_free_event(event);
  }
  lcm_eventlog_destroy(log);
  return true;
}

}  // namespace objscan

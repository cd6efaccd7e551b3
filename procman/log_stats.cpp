#include "procman/log_stats.h"

#include <lcm/eventlog.h>

namespace objscan {

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

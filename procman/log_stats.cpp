#include "procman/log_stats.h"

#include "common/lcm_log.h"

namespace objscan {

bool ReadLogStats(const std::string& path, std::map<std::string, ChannelStats>* stats, std::string* error) {
  LcmLogReader log;
  if (!log.Open(path, error)) return false;
  stats->clear();
  LcmLogEvent event;
  while (log.Next(&event)) {
    ChannelStats& s = (*stats)[event.channel];
    int64_t utime = 0;
    if (RawMessageUtime(event.data.data(), static_cast<int>(event.data.size()), &utime)) {
      if (s.count == 0) s.first_utime = utime;
      s.last_utime = utime;
    }
    ++s.count;
    s.bytes += static_cast<int64_t>(event.data.size());
  }
  if (log.damage().Any()) {
    *error = path + ": " + log.damage().Describe();
    return false;
  }
  return true;
}

}  // namespace objscan

#include "tools/logtool/log_compare.h"

#include <cmath>
#include <unordered_map>

#include "common/lcm_log.h"
#include "common/message_size_check.h"
#include "objscan/feature_tracks_t.hpp"

namespace objscan {

bool ReadLogMessages(const std::string& path, const std::set<std::string>& skip, std::vector<LogMessage>* out,
                     std::string* error) {
  LcmLogReader log;
  if (!log.Open(path, error)) return false;
  out->clear();
  LcmLogEvent e;
  while (log.Next(&e))
    if (!skip.count(e.channel)) out->push_back({e.channel, e.data});
  if (log.damage().Any()) {  // a damaged log is not compared as if it were whole
    *error = path + ": " + log.damage().Describe();
    return false;
  }
  return true;
}

BytesComparison CompareLogBytes(const std::string& a, const std::string& b, const std::set<std::string>& skip,
                                std::string* error) {
  BytesComparison result;
  std::vector<LogMessage> ma, mb;
  if (!ReadLogMessages(a, skip, &ma, error) || !ReadLogMessages(b, skip, &mb, error)) return result;
  result.messages_a = static_cast<int64_t>(ma.size());
  result.messages_b = static_cast<int64_t>(mb.size());
  std::map<std::string, std::vector<const LogMessage*>> ca, cb;
  for (const auto& m : ma) ca[m.channel].push_back(&m);
  for (const auto& m : mb) cb[m.channel].push_back(&m);
  std::set<std::string> channels;
  for (const auto& kv : ca) channels.insert(kv.first);
  for (const auto& kv : cb) channels.insert(kv.first);
  for (const auto& ch : channels) {
    const auto& xa = ca[ch];
    const auto& xb = cb[ch];
    if (xa.size() != xb.size()) {
      result.first_difference = ch + ": " + std::to_string(xa.size()) + " vs " + std::to_string(xb.size()) +
                                " messages";
      return result;
    }
    for (size_t i = 0; i < xa.size(); ++i) {
      if (xa[i]->data != xb[i]->data) {
        result.first_difference = ch + ": message " + std::to_string(i) + " differs";
        return result;
      }
    }
  }
  result.identical = true;
  return result;
}

bool CompareLogTracks(const std::string& a, const std::string& b, const std::string& channel, double tolerance_px,
                      TracksComparison* out, std::string* error) {
  std::set<std::string> skip;
  std::vector<LogMessage> ma, mb;
  if (!ReadLogMessages(a, skip, &ma, error) || !ReadLogMessages(b, skip, &mb, error)) return false;
  auto decode = [&](const std::vector<LogMessage>& in, std::map<int64_t, feature_tracks_t>* frames) {
    for (const auto& m : in) {
      if (m.channel != channel) continue;
      feature_tracks_t t;
      if (!DecodeMessage(m.data.data(), static_cast<int>(m.data.size()), &t, nullptr)) continue;
      (*frames)[t.seq] = std::move(t);
    }
  };
  std::map<int64_t, feature_tracks_t> fa, fb;
  decode(ma, &fa);
  decode(mb, &fb);
  TracksComparison r;
  r.frames_a = static_cast<int64_t>(fa.size());
  r.frames_b = static_cast<int64_t>(fb.size());
  r.contiguous_b = !fb.empty() && fb.rbegin()->first - fb.begin()->first + 1 == static_cast<int64_t>(fb.size());
  int64_t tracks_a = 0;
  for (const auto& [seq, ta] : fa) {
    tracks_a += ta.num_tracks;
    auto it = fb.find(seq);
    if (it == fb.end()) continue;
    ++r.frames_matched;
    std::unordered_map<int64_t, int> index_b;
    for (int i = 0; i < it->second.num_tracks; ++i) index_b[it->second.track_id[i]] = i;
    for (int i = 0; i < ta.num_tracks; ++i) {
      auto jt = index_b.find(ta.track_id[i]);
      if (jt == index_b.end()) continue;
      const double d = std::hypot(ta.u[i] - it->second.u[jt->second], ta.v[i] - it->second.v[jt->second]);
      ++r.tracks_compared;
      if (d <= tolerance_px) ++r.tracks_within_tolerance;
      r.max_difference_px = std::max(r.max_difference_px, d);
    }
  }
  r.id_overlap = tracks_a > 0 ? double(r.tracks_compared) / double(tracks_a) : 0.0;
  *out = r;
  return true;
}

}  // namespace objscan

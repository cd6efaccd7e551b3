// objscan_logtool: inspect and compare LCM logs.
//   objscan_logtool count LOG                      events per channel (+ data-time span and rate)
//   objscan_logtool compare-bytes A B [SKIP,...]   exit 0 when the per-channel messages are byte-identical
//                                                  (PROCESS_STATUS is always skipped: wall-clock fields)
//   objscan_logtool compare-tracks A B TOL_PX      FEATURE_TRACKS of B against reference A; prints figures
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "procman/log_stats.h"
#include "tools/logtool/log_compare.h"

int main(int argc, char** argv) {
  const std::string usage =
      "usage: objscan_logtool count LOG | compare-bytes A B [SKIP_CHANNELS] | compare-tracks A B TOLERANCE_PX\n";
  if (argc < 3) {
    std::fprintf(stderr, "%s", usage.c_str());
    return 2;
  }
  const std::string command = argv[1];
  std::string error;
  if (command == "count") {
    std::map<std::string, objscan::ChannelStats> stats;
    if (!objscan::ReadLogStats(argv[2], &stats, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 1;
    }
    int64_t total = 0;
    for (const auto& [channel, s] : stats) {
      const double span = (s.last_utime - s.first_utime) * 1e-6;
      std::printf("%-24s %8lld messages %12lld bytes  %.1f Hz\n", channel.c_str(), static_cast<long long>(s.count),
                  static_cast<long long>(s.bytes), s.count > 1 && span > 0 ? (s.count - 1) / span : 0.0);
      total += s.count;
    }
    std::printf("total %lld\n", static_cast<long long>(total));
    return 0;
  }
  if (command == "compare-bytes" && argc >= 4) {
    std::set<std::string> skip = {"PROCESS_STATUS"};
    if (argc >= 5) {
      std::stringstream ss(argv[4]);
      std::string ch;
      while (std::getline(ss, ch, ',')) skip.insert(ch);
    }
    const auto r = objscan::CompareLogBytes(argv[2], argv[3], skip, &error);
    if (!error.empty()) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 1;
    }
    std::printf("%s: %lld vs %lld messages%s%s\n", r.identical ? "identical" : "DIFFERENT",
                static_cast<long long>(r.messages_a), static_cast<long long>(r.messages_b),
                r.identical ? "" : ", first difference: ", r.first_difference.c_str());
    return r.identical ? 0 : 1;
  }
  if (command == "compare-tracks" && argc >= 5) {
    objscan::TracksComparison r;
    char* end = nullptr;
    const double tolerance_px = std::strtod(argv[4], &end);
    if (end == argv[4] || *end != '\0' || !(tolerance_px >= 0) || !std::isfinite(tolerance_px)) {
      std::fprintf(stderr, "error: compare-tracks: TOLERANCE_PX must be a number of pixels >= 0, got '%s'\n", argv[4]);
      return 2;
    }
    if (!objscan::CompareLogTracks(argv[2], argv[3], "FEATURE_TRACKS", tolerance_px, &r, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 1;
    }
    std::printf("frames_a %lld frames_b %lld matched %lld contiguous_b %d tracks_compared %lld within %lld "
                "max_px %.4f id_overlap %.4f\n",
                static_cast<long long>(r.frames_a), static_cast<long long>(r.frames_b),
                static_cast<long long>(r.frames_matched), r.contiguous_b ? 1 : 0,
                static_cast<long long>(r.tracks_compared), static_cast<long long>(r.tracks_within_tolerance),
                r.max_difference_px, r.id_overlap);
    return 0;
  }
  std::fprintf(stderr, "%s", usage.c_str());
  return 2;
}

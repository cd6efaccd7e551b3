// objscan_logtool (`objscan log`): inspect, edit and compare LCM logs; what LCM 1.3.1's tools lack.
//   info LOG                                 duration, channels, counts, rates, gaps, lost sequence numbers, damage
//   filter IN OUT [--sensors] [--keep A,B] [--drop A,B]
//                                            the events of the chosen channels (names or shell patterns: 'CAMERA_*');
//                                            --sensors: what the drivers published (common/bus.h IsDriverMessage)
//   cut IN OUT [--from S] [--to S]           the events of a time window, seconds from the log's first event
//   merge OUT IN...                          the events of several logs in time order
//   count LOG                                events per channel (+ data-time span and rate), for scripts
//   compare-bytes A B [SKIP,...]             exit 0 when the per-channel messages are byte-identical
//                                            (PROCESS_STATUS is always skipped: wall-clock fields)
//   compare-tracks A B TOL_PX                FEATURE_TRACKS of B against reference A; prints figures
// Exit status: 0 done; 1 an error, or an input was damaged (the output then holds every readable event and the
// damage is printed), or nothing was selected; 2 a usage error.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "common/bus.h"
#include "common/options.h"
#include "common/statistics.h"
#include "procman/log_stats.h"
#include "tools/logtool/log_compare.h"
#include "tools/logtool/log_edit.h"
#include "tools/report/report_log.h"

namespace {

const char* const kUsage =
    "usage: objscan log info LOG\n"
    "       objscan log filter IN OUT [--sensors] [--keep A,B] [--drop A,B]   (names or shell patterns: 'CAMERA_*';\n"
    "           --sensors: what the drivers published, to play into live processes with lcm-logplayer)\n"
    "       objscan log cut IN OUT [--from S] [--to S]             (seconds from the log's first event)\n"
    "       objscan log merge OUT IN...\n"
    "       objscan log latency LOG   (camera image -> tracks and -> pose, per frame, as the logger received them:\n"
    "           p50 / p90 / p99 / max ms; across hosts, log on the host that sees the poses)\n"
    "       objscan log count LOG | compare-bytes A B [SKIP_CHANNELS] | compare-tracks A B TOLERANCE_PX\n";

int Usage(const std::string& why) {
  std::fprintf(stderr, "error: %s\n%s", why.c_str(), kUsage);
  return 2;
}

bool ParseSeconds(const std::string& text, double* out) {
  double v = 0;
  if (!objscan::ParseFiniteNumber(text, &v) || v < 0) return false;
  *out = v;
  return true;
}

// Prints what an edit wrote; returns the exit status (1 when an input was damaged or nothing was written).
int ReportEdit(const std::string& out, const objscan::LogEditResult& r) {
  for (const auto& p : r.patterns_never_matched)
    std::fprintf(stderr, "warning: '%s' matches no channel of the input (see `objscan log info`)\n", p.c_str());
  std::printf("%s: %lld of %lld events", out.c_str(), static_cast<long long>(r.events_out),
              static_cast<long long>(r.events_in));
  const char* sep = ": ";
  for (const auto& [channel, n] : r.channels_out) {
    std::printf("%s%s %lld", sep, channel.c_str(), static_cast<long long>(n));
    sep = ", ";
  }
  std::printf("\n");
  for (const auto& d : r.damage)
    std::fprintf(stderr, "error: damaged input, %s; %s holds every event that could be read\n", d.c_str(),
                 out.c_str());
  if (r.events_out == 0) std::fprintf(stderr, "error: nothing selected: %s holds no event\n", out.c_str());
  return r.damage.empty() && r.events_out > 0 ? 0 : 1;
}

int Info(int argc, char** argv) {
  if (argc != 3) return Usage("info takes one LOG");
  objscan::LogInfo info;
  std::string error;
  if (!objscan::ReadLogInfo(argv[2], &info, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  std::printf("%s", objscan::FormatLogInfo(argv[2], info).c_str());
  return info.damage.Any() ? 1 : 0;
}

int FilterOrCut(int argc, char** argv) {
  const std::string command = argv[1];
  if (argc < 4) return Usage(command + " takes IN OUT and options");
  objscan::ChannelSelection selection;
  double from_s = 0, to_s = std::numeric_limits<double>::infinity();
  std::string error;
  for (int i = 4; i < argc; ++i) {
    const std::string option = argv[i];
    if (command == "filter" && option == "--sensors") {
      selection.keep_event = [](const objscan::LcmLogEvent& e) {
        return objscan::IsDriverMessage(e.channel, e.data.data(), static_cast<int>(e.data.size()));
      };
      continue;
    }
    if (i + 1 >= argc) return Usage(option + " needs a value");
    const std::string value = argv[++i];
    if (command == "filter" && (option == "--keep" || option == "--drop")) {
      auto* patterns = option == "--keep" ? &selection.keep : &selection.drop;
      if (!patterns->empty()) return Usage(option + " given twice (list the channels in one: A,B,C)");
      if (!objscan::ParseChannelPatterns(value, patterns, &error)) return Usage(error);
    } else if (command == "cut" && (option == "--from" || option == "--to")) {
      if (!ParseSeconds(value, option == "--from" ? &from_s : &to_s))
        return Usage(option + " must be a number of seconds >= 0, got '" + value + "'");
    } else {
      return Usage("unknown option '" + option + "' for " + command);
    }
  }
  if (command == "filter" && selection.keep.empty() && selection.drop.empty() && !selection.keep_event)
    return Usage("filter needs --sensors, --keep or --drop");
  if (command == "cut" && !(to_s > from_s)) return Usage("cut needs --to later than --from");
  objscan::LogEditResult result;
  if (!objscan::FilterLog(argv[2], argv[3], selection, from_s, to_s, &result, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  return ReportEdit(argv[3], result);
}

int Merge(int argc, char** argv) {
  if (argc < 4) return Usage("merge takes OUT and at least one IN");
  std::vector<std::string> inputs(argv + 3, argv + argc);
  for (const auto& in : inputs)
    if (in.rfind("--", 0) == 0) return Usage("merge takes no options, got '" + in + "'");
  objscan::LogEditResult result;
  std::string error;
  if (!objscan::MergeLogs(inputs, argv[2], &result, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  return ReportEdit(argv[2], result);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && (std::string(argv[1]) == "help" || std::string(argv[1]) == "--help" ||
                    std::string(argv[1]) == "-h")) {
    std::printf("%s", kUsage);
    return 0;
  }
  if (argc < 3) return Usage("give a command and its logs");
  const std::string command = argv[1];
  if (command == "info") return Info(argc, argv);
  if (command == "filter" || command == "cut") return FilterOrCut(argc, argv);
  if (command == "merge") return Merge(argc, argv);
  std::string error;
  if (command == "latency") {
    if (argc != 3) return Usage("latency takes one log");
    objscan::FrameSeries frames;
    std::string damage;
    if (!objscan::ReadFrameSeries(argv[2], &frames, nullptr, &damage, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 1;
    }
    if (!damage.empty()) std::fprintf(stderr, "warning: %s: %s (latencies of the readable part)\n", argv[2], damage.c_str());
    const size_t images = frames.t_s.size();
    int with_any = 0;
    for (const auto* series : {&frames.tracks_latency_ms, &frames.pose_latency_ms}) {
      std::vector<double> v;
      for (double ms : *series)
        if (std::isfinite(ms)) v.push_back(ms);
      const char* name = series == &frames.tracks_latency_ms ? "image_to_tracks" : "image_to_pose";
      if (v.empty()) {
        std::printf("%-16s frames 0 of %zu\n", name, images);
        continue;
      }
      ++with_any;
      std::printf("%-16s frames %zu of %zu  p50 %.1f  p90 %.1f  p99 %.1f  max %.1f ms\n", name, v.size(), images,
                  objscan::Percentile(v, 0.5), objscan::Percentile(v, 0.9), objscan::Percentile(v, 0.99),
                  *std::max_element(v.begin(), v.end()));
    }
    if (images == 0) {
      std::fprintf(stderr, "error: %s has no CAMERA_IMAGE\n", argv[2]);
      return 1;
    }
    return with_any > 0 ? 0 : 1;
  }
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
    double tolerance_px = 0;
    if (!objscan::ParseFiniteNumber(argv[4], &tolerance_px) || tolerance_px < 0) {
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
  return Usage("unknown command '" + command + "' or wrong arguments");
}

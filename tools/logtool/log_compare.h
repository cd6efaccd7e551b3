// Comparisons of LCM logs for regression tests: byte-identical output messages (determinism) and feature tracks
// within a pixel tolerance (live replay vs the deterministic run). LCM-log I/O only; no bus.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace objscan {

struct LogMessage {
  std::string channel;
  std::vector<uint8_t> data;
};

// Reads every event of a log in order. Channels in `skip` are left out. False with *error if unreadable.
bool ReadLogMessages(const std::string& path, const std::set<std::string>& skip, std::vector<LogMessage>* out,
                     std::string* error);

struct BytesComparison {
  bool identical = false;
  int64_t messages_a = 0, messages_b = 0;
  std::string first_difference;  // human-readable, empty when identical
};

// Compares the per-channel message sequences of two logs byte for byte (order within a channel matters, the
// interleaving of channels does not), skipping the given channels.
BytesComparison CompareLogBytes(const std::string& a, const std::string& b, const std::set<std::string>& skip,
                                std::string* error);

struct TracksComparison {
  int64_t frames_a = 0, frames_b = 0;    // FEATURE_TRACKS messages
  int64_t frames_matched = 0;            // frames present in both (by seq)
  int64_t tracks_compared = 0;           // track points present in both (same frame seq, same id)
  int64_t tracks_within_tolerance = 0;
  double max_difference_px = 0;
  double id_overlap = 0;                 // tracks_compared / tracks in a (0..1)
  bool contiguous_b = false;             // b's seqs have no gaps
};

// Matches FEATURE_TRACKS (by frame seq and track id) of log a (reference) and log b.
bool CompareLogTracks(const std::string& a, const std::string& b, const std::string& channel, double tolerance_px,
                      TracksComparison* out, std::string* error);

}  // namespace objscan

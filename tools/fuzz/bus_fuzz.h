// Hostile messages for the bus (issue 28's fuzz test), LCM-type aware but bus-free: each call returns one message
// for a channel of the objscan session, chosen by a seeded generator among the kinds below. Used by
// objscan_bus_fuzz (publishes them on a live session) and its unit test (every kind is refused by DecodeMessage or
// by the adapters' checks). Never produces a well-formed control_t or robot_command_t: a forged END_OF_STREAM or
// motion command is a valid message, not a malformed one.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace objscan {

enum class FuzzKind {
  kRandomBytes,         // 0..300 random bytes
  kFingerprintGarbage,  // the channel type's fingerprint, then random bytes
  kTruncated,           // a well-formed message cut short
  kAbsurdCount,         // a well-formed message with an array count of -1, 2^25 or 2^31-1
  kNonFinite,           // NaN / inf in float fields (poses, odometry, track coordinates, landmarks, ...)
  kForgedSeq,           // seq INT64_MAX, INT64_MIN, -1 or 2^40, otherwise well-formed
  kDuplicateIds,        // tracks / landmarks with repeated ids
  // (a kind that does not apply to the channel, e.g. ids on CAMERA_POSE, gives a fingerprint then garbage)
};
inline constexpr int kNumFuzzKinds = 7;
const char* FuzzKindName(FuzzKind kind);

struct FuzzMessage {
  std::string channel;
  FuzzKind kind = FuzzKind::kRandomBytes;
  std::vector<uint8_t> bytes;
};

// The input channels of the session's processes (default names).
const std::vector<std::string>& FuzzChannels();

class BusFuzzer {
 public:
  explicit BusFuzzer(uint32_t seed) : rng_(seed) {}
  // One message on a random channel of a random kind (kinds that do not apply to the channel fall back to random
  // bytes after its fingerprint).
  FuzzMessage Next();
  // One message of the given kind on the given channel.
  FuzzMessage Make(const std::string& channel, FuzzKind kind);

 private:
  std::mt19937 rng_;
};

}  // namespace objscan

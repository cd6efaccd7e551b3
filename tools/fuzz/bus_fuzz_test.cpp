#include "tools/fuzz/bus_fuzz.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "common/message_size_check.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/robot_command_t.hpp"
#include "objscan/target_t.hpp"
#include "objscan/voxel_map_t.hpp"

namespace objscan {
namespace {

template <class Msg>
bool Decodes(const FuzzMessage& m) {
  Msg msg;
  return DecodeMessage(m.bytes.data(), static_cast<int>(m.bytes.size()), &msg, nullptr);
}

bool DecodesAsChannelType(const FuzzMessage& m) {
  static const std::map<std::string, bool (*)(const FuzzMessage&)> types = {
      {"CAMERA_IMAGE", Decodes<image_t>},      {"CAMERA_INFO", Decodes<camera_info_t>},
      {"FEATURE_TRACKS", Decodes<feature_tracks_t>}, {"CAMERA_POSE", Decodes<pose_t>},
      {"ROBOT_ODOMETRY", Decodes<odometry_t>}, {"LANDMARKS", Decodes<landmarks_t>},
      {"VOXEL_MAP", Decodes<voxel_map_t>},     {"TARGET", Decodes<target_t>},
      {"ROBOT_COMMAND", Decodes<robot_command_t>}, {"OBJSCAN_CONTROL", Decodes<control_t>}};
  return types.at(m.channel)(m);
}

// Malformed kinds never decode as their channel's type; the well-formed hostile kinds (non-finite values, forged
// seqs, duplicate ids) do, so that the processes' own checks meet them; nothing is ever a decodable command.
TEST(BusFuzz, MalformedKindsNeverDecodeAndCommandsAreNeverWellFormed) {
  BusFuzzer fuzzer(3);
  std::map<FuzzKind, int> decoded, total;
  for (int i = 0; i < 5000; ++i) {
    const FuzzMessage m = fuzzer.Next();
    ++total[m.kind];
    const bool ok = DecodesAsChannelType(m);
    decoded[m.kind] += ok;
    if (m.channel == "ROBOT_COMMAND" || m.channel == "OBJSCAN_CONTROL") EXPECT_FALSE(ok) << FuzzKindName(m.kind);
  }
  for (FuzzKind k : {FuzzKind::kRandomBytes, FuzzKind::kFingerprintGarbage, FuzzKind::kTruncated,
                     FuzzKind::kAbsurdCount}) {
    EXPECT_GT(total[k], 100) << FuzzKindName(k);
    EXPECT_EQ(decoded[k], 0) << FuzzKindName(k);
  }
  for (FuzzKind k : {FuzzKind::kNonFinite, FuzzKind::kForgedSeq, FuzzKind::kDuplicateIds}) {
    EXPECT_GT(total[k], 100) << FuzzKindName(k);
    EXPECT_EQ(decoded[k], total[k]) << FuzzKindName(k);
  }
}

TEST(BusFuzz, Deterministic) {
  BusFuzzer a(11), b(11);
  for (int i = 0; i < 200; ++i) {
    const FuzzMessage x = a.Next(), y = b.Next();
    EXPECT_EQ(x.channel, y.channel);
    EXPECT_EQ(x.bytes, y.bytes);
  }
}

}  // namespace
}  // namespace objscan

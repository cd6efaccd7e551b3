#include "tools/fuzz/bus_fuzz.h"

#include <cmath>
#include <limits>

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

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int64_t kForgedSeqs[] = {std::numeric_limits<int64_t>::max(), std::numeric_limits<int64_t>::min(),
                                   -1, int64_t{1} << 40};
constexpr int32_t kAbsurdCounts[] = {-1, 1 << 25, std::numeric_limits<int32_t>::max()};

template <class Msg>
std::vector<uint8_t> Encode(const Msg& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

void Poke32(std::vector<uint8_t>* b, size_t offset, int32_t v) {
  for (int i = 0; i < 4; ++i) (*b)[offset + i] = static_cast<uint8_t>(static_cast<uint32_t>(v) >> (24 - 8 * i));
}

// A well-formed message for the channel (n array items), the bytes per array item after its count field (the count
// sits right before the arrays at the end of these types; 0 = no array), and its fingerprint.
struct Sample {
  std::vector<uint8_t> bytes;
  int item_bytes = 0;
  int items = 0;
  int64_t hash = 0;
};

Sample MakeSample(const std::string& channel, int64_t seq, bool non_finite, bool duplicate_ids) {
  const double bad = non_finite ? kNaN : 1.0;
  const float badf = non_finite ? std::numeric_limits<float>::infinity() : 10.0f;
  Sample s;
  if (channel == "CAMERA_IMAGE") {
    image_t m{};
    m.utime = 1000;
    m.seq = seq;
    m.camera_name = "fuzz";
    m.width = 16;
    m.height = 8;
    m.stride = 16;
    m.encoding = image_t::ENCODING_GRAY8;
    m.size = 128;
    m.data.assign(128, 7);
    s = {Encode(m), 1, 128, image_t::getHash()};
  } else if (channel == "CAMERA_INFO") {
    camera_info_t m{};
    m.camera_name = "fuzz";
    m.width = 640;
    m.height = 480;
    m.fx = m.fy = 500 * bad;
    m.cx = 320;
    m.cy = 240;
    m.distortion_model = "radtan";
    m.num_distortion = 4;
    m.distortion.assign(4, 0.0);
    s = {Encode(m), 8, 4, camera_info_t::getHash()};
  } else if (channel == "FEATURE_TRACKS") {
    feature_tracks_t m{};
    m.seq = seq;
    m.camera_name = "fuzz";
    m.image_width = 640;
    m.image_height = 480;
    m.num_tracks = 10;
    for (int i = 0; i < 10; ++i) {
      m.track_id.push_back(duplicate_ids ? 5 : 1000000 + i);
      m.u.push_back(i == 3 ? badf : 10.0f * i);
      m.v.push_back(20.0f);
      m.age.push_back(1);
    }
    s = {Encode(m), 20, 10, feature_tracks_t::getHash()};
  } else if (channel == "CAMERA_POSE") {
    pose_t m{};
    m.seq = seq;
    m.parent_frame = "world";
    m.child_frame = "camera";
    m.position_mm[0] = bad;
    m.orientation[0] = 1;
    m.status = 1;
    s = {Encode(m), 0, 0, pose_t::getHash()};
  } else if (channel == "ROBOT_ODOMETRY") {
    odometry_t m{};
    m.seq = seq;
    m.x_mm = bad * 3;
    m.theta_rad = non_finite ? kInf : 0.1;
    s = {Encode(m), 0, 0, odometry_t::getHash()};
  } else if (channel == "LANDMARKS") {
    landmarks_t m{};
    m.seq = seq;
    m.frame = "world";
    m.num_landmarks = 5;
    for (int i = 0; i < 5; ++i) {
      m.id.push_back(duplicate_ids ? 9 : 2000000 + i);
      m.position_mm.push_back({{static_cast<float>(bad), 2.0f, 3.0f}});
      m.num_observations.push_back(3);
      m.reprojection_error_px.push_back(0.5f);
      m.rgb.push_back({{1, 2, 3}});
    }
    s = {Encode(m), 31, 5, landmarks_t::getHash()};
  } else if (channel == "VOXEL_MAP") {
    voxel_map_t m{};
    m.seq = seq;
    m.frame = "world";
    m.voxel_size_mm = 2 * bad;
    m.num_voxels = 3;
    m.ijk.assign(3, {{1, 2, 3}});
    m.votes.assign(3, 5);
    m.rgb.assign(3, {{1, 2, 3}});
    s = {Encode(m), 19, 3, voxel_map_t::getHash()};
  } else if (channel == "TARGET") {
    target_t m{};
    m.seq = seq;
    m.state = 1;
    m.frame = "world";
    m.center_mm[0] = bad * 100;
    m.size_mm[0] = m.size_mm[1] = m.size_mm[2] = 150;
    s = {Encode(m), 0, 0, target_t::getHash()};
  } else if (channel == "ROBOT_COMMAND") {
    s = {Encode(robot_command_t{}), 0, 0, robot_command_t::getHash()};
  } else {  // OBJSCAN_CONTROL and anything else
    s = {Encode(control_t{}), 0, 0, control_t::getHash()};
  }
  return s;
}

}  // namespace

const char* FuzzKindName(FuzzKind kind) {
  switch (kind) {
    case FuzzKind::kRandomBytes: return "random bytes";
    case FuzzKind::kFingerprintGarbage: return "fingerprint + garbage";
    case FuzzKind::kTruncated: return "truncated";
    case FuzzKind::kAbsurdCount: return "absurd count";
    case FuzzKind::kNonFinite: return "non-finite";
    case FuzzKind::kForgedSeq: return "forged seq";
    case FuzzKind::kDuplicateIds: return "duplicate ids";
  }
  return "?";
}

const std::vector<std::string>& FuzzChannels() {
  static const std::vector<std::string> channels = {
      "CAMERA_IMAGE", "CAMERA_INFO", "FEATURE_TRACKS", "CAMERA_POSE", "ROBOT_ODOMETRY",
      "LANDMARKS",    "VOXEL_MAP",   "TARGET",         "ROBOT_COMMAND", "OBJSCAN_CONTROL"};
  return channels;
}

FuzzMessage BusFuzzer::Next() {
  const auto& channels = FuzzChannels();
  const std::string& channel = channels[std::uniform_int_distribution<size_t>(0, channels.size() - 1)(rng_)];
  return Make(channel, static_cast<FuzzKind>(std::uniform_int_distribution<int>(0, kNumFuzzKinds - 1)(rng_)));
}

FuzzMessage BusFuzzer::Make(const std::string& channel, FuzzKind kind) {
  FuzzMessage out;
  out.channel = channel;
  out.kind = kind;
  std::uniform_int_distribution<int> byte(0, 255);
  const bool command_channel = channel == "ROBOT_COMMAND" || channel == "OBJSCAN_CONTROL";
  const int64_t seq = kForgedSeqs[std::uniform_int_distribution<int>(0, 3)(rng_)];
  Sample sample = MakeSample(channel, kind == FuzzKind::kForgedSeq ? seq : 1, kind == FuzzKind::kNonFinite,
                             kind == FuzzKind::kDuplicateIds);
  // Every message must be one a correct process rejects: ids only where messages carry ids, non-finite values only
  // where they carry floats (otherwise the "hostile" message would be a plausible, valid one).
  const bool has_ids = channel == "FEATURE_TRACKS" || channel == "LANDMARKS";
  const bool has_floats = channel != "CAMERA_IMAGE";
  const bool applies = !command_channel && (kind != FuzzKind::kAbsurdCount || sample.item_bytes > 0) &&
                       (kind != FuzzKind::kDuplicateIds || has_ids) && (kind != FuzzKind::kNonFinite || has_floats);
  if (kind == FuzzKind::kRandomBytes) {
    out.bytes.resize(std::uniform_int_distribution<size_t>(0, 300)(rng_));
    for (auto& b : out.bytes) b = static_cast<uint8_t>(byte(rng_));
    return out;
  }
  if (kind == FuzzKind::kTruncated) {
    out.bytes = sample.bytes;
    out.bytes.resize(std::uniform_int_distribution<size_t>(0, out.bytes.size() - 1)(rng_));
    return out;
  }
  if (kind == FuzzKind::kFingerprintGarbage || !applies) {
    out.kind = FuzzKind::kFingerprintGarbage;
    out.bytes.assign(sample.bytes.begin(), sample.bytes.begin() + 8);
    size_t length = 8 + std::uniform_int_distribution<size_t>(0, 200)(rng_);
    if (length == sample.bytes.size()) ++length;  // a fixed-size type would decode any bytes of its exact size
    out.bytes.resize(length);
    for (size_t i = 8; i < out.bytes.size(); ++i) out.bytes[i] = static_cast<uint8_t>(byte(rng_));
    return out;
  }
  out.bytes = sample.bytes;
  if (kind == FuzzKind::kAbsurdCount) {
    const size_t count_at = out.bytes.size() - static_cast<size_t>(sample.items * sample.item_bytes) - 4;
    Poke32(&out.bytes, count_at, kAbsurdCounts[std::uniform_int_distribution<int>(0, 2)(rng_)]);
  }
  return out;
}

}  // namespace objscan

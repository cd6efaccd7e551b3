#include "processes/dense_modeler/voxel_votes.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace objscan {
namespace {

// Snapshot format (little endian): 8-byte magic "OSVOTES2", double voxel_size_mm, int32 neighbourhood,
// int32 center/face/edge/corner weights, int64 count, then count records of
// int32 i, j, k, votes, uint32 color_sum b, g, r, int32 color_count, float32 toward_camera_sum x, y, z.
// ("OSVOTES1" files, without the direction sums, are refused as foreign.)
constexpr char kMagic[8] = {'O', 'S', 'V', 'O', 'T', 'E', 'S', '2'};
constexpr int32_t kMaxIndex = 1 << 22;

struct SnapshotRecord {
  int32_t i, j, k, votes;
  uint32_t sum[3];
  int32_t count;
  float toward_camera_sum[3];
};

}  // namespace

bool ValidateVoxelVoteOptions(const VoxelVoteOptions& o, std::string* why) {
  std::ostringstream e;
  if (!(o.voxel_size_mm > 0) || !std::isfinite(o.voxel_size_mm)) e << "voxel size must be > 0; ";
  if (o.neighbourhood != 0 && o.neighbourhood != 6 && o.neighbourhood != 26) e << "neighbourhood must be 0, 6 or 26; ";
  if (o.center_weight < 1) e << "center weight must be >= 1; ";
  if (o.face_weight < 0 || o.edge_weight < 0 || o.corner_weight < 0) e << "neighbour weights must be >= 0; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

VoxelVoteGrid::VoxelVoteGrid(const VoxelVoteOptions& options) : options_(options) {
  std::string why;
  if (!ValidateVoxelVoteOptions(options_, &why)) throw std::invalid_argument("voxel votes: " + why);
  weight_by_order_ = {options_.center_weight, options_.neighbourhood >= 6 ? options_.face_weight : 0,
                      options_.neighbourhood == 26 ? options_.edge_weight : 0,
                      options_.neighbourhood == 26 ? options_.corner_weight : 0};
}

Eigen::Vector3i VoxelVoteGrid::VoxelOf(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d s = p / options_.voxel_size_mm;
  return Eigen::Vector3i(static_cast<int>(std::floor(s.x())), static_cast<int>(std::floor(s.y())),
                         static_cast<int>(std::floor(s.z())));
}

Eigen::Vector3d VoxelVoteGrid::CenterOf(const Eigen::Vector3i& ijk) const {
  return (ijk.cast<double>() + Eigen::Vector3d::Constant(0.5)) * options_.voxel_size_mm;
}

uint64_t VoxelVoteGrid::BlockKey(int bx, int by, int bz) {
  const uint64_t off = 1u << 20;
  return ((static_cast<uint64_t>(bx) + off) & 0x1FFFFF) | (((static_cast<uint64_t>(by) + off) & 0x1FFFFF) << 21) |
         (((static_cast<uint64_t>(bz) + off) & 0x1FFFFF) << 42);
}

VoxelVoteGrid::Block* VoxelVoteGrid::GetBlock(int bx, int by, int bz, bool create) {
  const uint64_t key = BlockKey(bx, by, bz);
  if (key == cached_key_ && cached_block_) return cached_block_;
  auto it = block_index_.find(key);
  if (it != block_index_.end()) {
    cached_key_ = key;
    cached_block_ = blocks_[it->second].get();
    return cached_block_;
  }
  if (!create) return nullptr;
  block_index_.emplace(key, static_cast<uint32_t>(blocks_.size()));
  blocks_.push_back(std::make_unique<Block>());
  block_coords_.emplace_back(bx, by, bz);
  cached_key_ = key;
  cached_block_ = blocks_.back().get();
  return cached_block_;
}

const VoxelVoteGrid::Block* VoxelVoteGrid::FindBlock(int bx, int by, int bz) const {
  auto it = block_index_.find(BlockKey(bx, by, bz));
  return it == block_index_.end() ? nullptr : blocks_[it->second].get();
}

void VoxelVoteGrid::AddVotes(Block* block, int local, int32_t weight) {
  if (weight <= 0) return;
  if (block->votes[local] == 0) ++num_voxels_;
  block->votes[local] += weight;
  total_votes_ += weight;
}

bool VoxelVoteGrid::AddPoint(const Eigen::Vector3d& p, const std::array<uint8_t, 3>& bgr,
                             const Eigen::Vector3f& toward_camera) {
  if (!p.allFinite()) return false;
  const Eigen::Vector3d s = p / options_.voxel_size_mm;
  if ((s.array().abs() >= kMaxIndex - 2).any()) return false;
  const Eigen::Vector3i c = VoxelOf(p);
  const int m = kBlockSide - 1;
  const int lx = c.x() & m, ly = c.y() & m, lz = c.z() & m;
  Block* center_block = GetBlock(c.x() >> kBlockBits, c.y() >> kBlockBits, c.z() >> kBlockBits, true);
  const int center_local = (lz * kBlockSide + ly) * kBlockSide + lx;
  center_block->color_sum[center_local][0] += bgr[0];
  center_block->color_sum[center_local][1] += bgr[1];
  center_block->color_sum[center_local][2] += bgr[2];
  ++center_block->color_count[center_local];
  if (toward_camera.allFinite())
    for (int k = 0; k < 3; ++k) center_block->toward_camera_sum[center_local][k] += toward_camera[k];
  ++points_added_;
  if (options_.neighbourhood == 0) {
    AddVotes(center_block, center_local, weight_by_order_[0]);
    return true;
  }
  const bool interior = lx > 0 && lx < m && ly > 0 && ly < m && lz > 0 && lz < m;
  for (int dz = -1; dz <= 1; ++dz) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int order = (dx != 0) + (dy != 0) + (dz != 0);
        const int32_t w = weight_by_order_[order];
        if (w <= 0) continue;
        if (interior) {
          AddVotes(center_block, center_local + (dz * kBlockSide + dy) * kBlockSide + dx, w);
        } else {
          const int x = c.x() + dx, y = c.y() + dy, z = c.z() + dz;
          Block* blk = GetBlock(x >> kBlockBits, y >> kBlockBits, z >> kBlockBits, true);
          AddVotes(blk, ((z & m) * kBlockSide + (y & m)) * kBlockSide + (x & m), w);
        }
      }
    }
  }
  return true;
}

int VoxelVoteGrid::AddPoints(const std::vector<DensePoint>& points) {
  int n = 0;
  for (const DensePoint& p : points) n += AddPoint(p.point_in_world, p.bgr, p.toward_camera) ? 1 : 0;
  return n;
}

int32_t VoxelVoteGrid::Votes(const Eigen::Vector3i& ijk) const {
  const int m = kBlockSide - 1;
  const Block* b = FindBlock(ijk.x() >> kBlockBits, ijk.y() >> kBlockBits, ijk.z() >> kBlockBits);
  if (!b) return 0;
  return b->votes[((ijk.z() & m) * kBlockSide + (ijk.y() & m)) * kBlockSide + (ijk.x() & m)];
}

std::vector<VoxelRecord> VoxelVoteGrid::Extract(int32_t min_votes) const {
  min_votes = std::max<int32_t>(min_votes, 1);
  std::vector<VoxelRecord> out;
  for (size_t bi = 0; bi < blocks_.size(); ++bi) {
    const Block& b = *blocks_[bi];
    const Eigen::Vector3i base = block_coords_[bi] * kBlockSide;
    for (int l = 0; l < kBlockVoxels; ++l) {
      if (b.votes[l] < min_votes) continue;
      VoxelRecord r;
      r.ijk = base + Eigen::Vector3i(l & (kBlockSide - 1), (l >> kBlockBits) & (kBlockSide - 1), l >> (2 * kBlockBits));
      r.votes = b.votes[l];
      r.color_count = b.color_count[l];
      if (r.color_count > 0)
        for (int k = 0; k < 3; ++k)
          r.bgr[k] =
              static_cast<uint8_t>((b.color_sum[l][k] + r.color_count / 2) / static_cast<uint32_t>(r.color_count));
      const Eigen::Vector3f dir(b.toward_camera_sum[l][0], b.toward_camera_sum[l][1], b.toward_camera_sum[l][2]);
      if (r.color_count > 0) r.toward_camera = dir / static_cast<float>(r.color_count);
      out.push_back(r);
    }
  }
  std::sort(out.begin(), out.end(), [](const VoxelRecord& x, const VoxelRecord& y) {
    if (x.ijk.z() != y.ijk.z()) return x.ijk.z() < y.ijk.z();
    if (x.ijk.y() != y.ijk.y()) return x.ijk.y() < y.ijk.y();
    return x.ijk.x() < y.ijk.x();
  });
  return out;
}

size_t VoxelVoteGrid::memory_bytes() const {
  return blocks_.size() * (sizeof(Block) + sizeof(Eigen::Vector3i) + 32) + sizeof(*this);
}

void VoxelVoteGrid::Clear() {
  block_index_.clear();
  blocks_.clear();
  block_coords_.clear();
  cached_key_ = ~uint64_t{0};
  cached_block_ = nullptr;
  num_voxels_ = total_votes_ = points_added_ = 0;
}

bool VoxelVoteGrid::SaveSnapshot(const std::string& path, std::string* error) const {
  const std::string tmp = path + ".tmp";
  std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
  if (!f) {
    if (error) *error = "cannot open " + tmp;
    return false;
  }
  std::vector<SnapshotRecord> recs;
  for (size_t bi = 0; bi < blocks_.size(); ++bi) {
    const Block& b = *blocks_[bi];
    const Eigen::Vector3i base = block_coords_[bi] * kBlockSide;
    for (int l = 0; l < kBlockVoxels; ++l) {
      if (b.votes[l] == 0 && b.color_count[l] == 0) continue;
      const Eigen::Vector3i ijk =
          base + Eigen::Vector3i(l & (kBlockSide - 1), (l >> kBlockBits) & (kBlockSide - 1), l >> (2 * kBlockBits));
      recs.push_back({ijk.x(),
                      ijk.y(),
                      ijk.z(),
                      b.votes[l],
                      {b.color_sum[l][0], b.color_sum[l][1], b.color_sum[l][2]},
                      b.color_count[l],
                      {b.toward_camera_sum[l][0], b.toward_camera_sum[l][1], b.toward_camera_sum[l][2]}});
    }
  }
  std::sort(recs.begin(), recs.end(), [](const SnapshotRecord& x, const SnapshotRecord& y) {
    return std::tie(x.k, x.j, x.i) < std::tie(y.k, y.j, y.i);
  });
  const int32_t header_ints[5] = {options_.neighbourhood, options_.center_weight, options_.face_weight,
                                  options_.edge_weight, options_.corner_weight};
  const int64_t count = static_cast<int64_t>(recs.size());
  f.write(kMagic, 8);
  f.write(reinterpret_cast<const char*>(&options_.voxel_size_mm), sizeof(double));
  f.write(reinterpret_cast<const char*>(header_ints), sizeof(header_ints));
  f.write(reinterpret_cast<const char*>(&count), sizeof(count));
  if (!recs.empty()) f.write(reinterpret_cast<const char*>(recs.data()), recs.size() * sizeof(SnapshotRecord));
  f.close();
  if (!f) {
    if (error) *error = "write failed: " + tmp;
    std::remove(tmp.c_str());
    return false;
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    if (error) *error = "cannot rename " + tmp + " to " + path;
    std::remove(tmp.c_str());
    return false;
  }
  return true;
}

bool VoxelVoteGrid::LoadSnapshot(const std::string& path, std::string* error) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    if (error) *error = "cannot open " + path;
    return false;
  }
  char magic[8];
  double size = 0;
  int32_t header_ints[5];
  int64_t count = 0;
  f.read(magic, 8);
  f.read(reinterpret_cast<char*>(&size), sizeof(size));
  f.read(reinterpret_cast<char*>(header_ints), sizeof(header_ints));
  f.read(reinterpret_cast<char*>(&count), sizeof(count));
  if (!f || std::memcmp(magic, kMagic, 8) != 0) {
    if (error) *error = "not a vote snapshot: " + path;
    return false;
  }
  VoxelVoteOptions o;
  o.voxel_size_mm = size;
  o.neighbourhood = header_ints[0];
  o.center_weight = header_ints[1];
  o.face_weight = header_ints[2];
  o.edge_weight = header_ints[3];
  o.corner_weight = header_ints[4];
  std::string why;
  if (!ValidateVoxelVoteOptions(o, &why) || count < 0 || count > (int64_t{1} << 32)) {
    if (error) *error = "bad snapshot header: " + path;
    return false;
  }
  std::vector<SnapshotRecord> recs(static_cast<size_t>(count));
  if (count > 0) f.read(reinterpret_cast<char*>(recs.data()), recs.size() * sizeof(SnapshotRecord));
  if (!f) {
    if (error) *error = "truncated snapshot: " + path;
    return false;
  }
  VoxelVoteGrid loaded(o);
  const int m = kBlockSide - 1;
  for (const SnapshotRecord& r : recs) {
    if (std::abs(r.i) >= kMaxIndex || std::abs(r.j) >= kMaxIndex || std::abs(r.k) >= kMaxIndex || r.votes < 0 ||
        r.count < 0) {
      if (error) *error = "bad snapshot record: " + path;
      return false;
    }
    Block* b = loaded.GetBlock(r.i >> kBlockBits, r.j >> kBlockBits, r.k >> kBlockBits, true);
    const int l = ((r.k & m) * kBlockSide + (r.j & m)) * kBlockSide + (r.i & m);
    if (b->votes[l] == 0 && r.votes > 0) ++loaded.num_voxels_;
    b->votes[l] += r.votes;
    loaded.total_votes_ += r.votes;
    for (int k = 0; k < 3; ++k) b->color_sum[l][k] += r.sum[k];
    for (int k = 0; k < 3; ++k)
      if (std::isfinite(r.toward_camera_sum[k])) b->toward_camera_sum[l][k] += r.toward_camera_sum[k];
    b->color_count[l] += r.count;
    loaded.points_added_ += r.count;
  }
  *this = std::move(loaded);
  cached_key_ = ~uint64_t{0};
  cached_block_ = nullptr;
  return true;
}

}  // namespace objscan

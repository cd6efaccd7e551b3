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
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int32_t w = weight_by_order_[(dx != 0) + (dy != 0) + (dz != 0)];
        if (w <= 0) continue;
        neighbour_weight_total_ += w;
        // For each place of a voxel in its block (per axis: first, inner or last layer).
        for (int place = 0; place < 27; ++place) {
          const int layer[3] = {place % 3, place / 3 % 3, place / 9};  // x, y, z
          const int d[3] = {dx, dy, dz};
          int step[3], delta = 0, stride = 1;
          for (int axis = 0; axis < 3; ++axis, stride *= kBlockSide) {
            step[axis] = (layer[axis] == 0 && d[axis] < 0) ? -1 : (layer[axis] == 2 && d[axis] > 0) ? 1 : 0;
            delta += (d[axis] - step[axis] * kBlockSide) * stride;
          }
          placed_neighbours_[place].push_back({((step[2] + 1) * 3 + (step[1] + 1)) * 3 + (step[0] + 1), delta, w});
        }
      }
  slot_key_.assign(64, kNoKey);
  slot_block_.assign(64, 0);
}

Eigen::Vector3i VoxelVoteGrid::VoxelOf(const Eigen::Vector3d& p) const {
  return VoxelIndexOf(p, options_.voxel_size_mm);
}

Eigen::Vector3d VoxelVoteGrid::CenterOf(const Eigen::Vector3i& ijk) const {
  return VoxelCenterOf(ijk, options_.voxel_size_mm);
}

uint64_t VoxelVoteGrid::BlockKey(int bx, int by, int bz) {
  const uint64_t off = 1u << 20;
  return ((static_cast<uint64_t>(bx) + off) & 0x1FFFFF) | (((static_cast<uint64_t>(by) + off) & 0x1FFFFF) << 21) |
         (((static_cast<uint64_t>(bz) + off) & 0x1FFFFF) << 42);
}

size_t VoxelVoteGrid::SlotOf(uint64_t key) const {
  const size_t mask = slot_key_.size() - 1;
  // Fibonacci hashing: the product's high bits depend on every key bit (its low bits only on the key's low bits,
  // which would leave z, in the key's top bits, out of the slot).
  const int bits = __builtin_ctzll(static_cast<unsigned long long>(slot_key_.size()));  // size: a power of two
  size_t i = static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> (64 - bits)) & mask;
  while (slot_key_[i] != key && slot_key_[i] != kNoKey) i = (i + 1) & mask;
  return i;
}

void VoxelVoteGrid::GrowTable() {
  const std::vector<uint64_t> keys = std::move(slot_key_);
  const std::vector<uint32_t> index = std::move(slot_block_);
  slot_key_.assign(2 * keys.size(), kNoKey);
  slot_block_.assign(2 * keys.size(), 0);
  for (size_t i = 0; i < keys.size(); ++i) {
    if (keys[i] == kNoKey) continue;
    const size_t slot = SlotOf(keys[i]);
    slot_key_[slot] = keys[i];
    slot_block_[slot] = index[i];
  }
}

VoxelVoteGrid::Block* VoxelVoteGrid::GetBlock(int bx, int by, int bz) { return blocks_[BlockIndex(bx, by, bz)].get(); }

uint32_t VoxelVoteGrid::BlockIndex(int bx, int by, int bz) {
  const uint64_t key = BlockKey(bx, by, bz);
  if (key == cached_key_) return cached_index_;
  size_t slot = SlotOf(key);
  if (slot_key_[slot] == key) {
    cached_key_ = key;
    cached_index_ = slot_block_[slot];
    return cached_index_;
  }
  if (2 * (blocks_.size() + 1) > slot_key_.size()) {  // load factor <= 1/2
    GrowTable();
    slot = SlotOf(key);
  }
  slot_key_[slot] = key;
  slot_block_[slot] = static_cast<uint32_t>(blocks_.size());
  blocks_.push_back(std::make_unique<Block>());
  block_coords_.emplace_back(bx, by, bz);
  cached_key_ = key;
  cached_index_ = slot_block_[slot];
  return cached_index_;
}

const VoxelVoteGrid::Block* VoxelVoteGrid::FindBlock(int bx, int by, int bz) const {
  const uint64_t key = BlockKey(bx, by, bz);
  const size_t slot = SlotOf(key);
  return slot_key_[slot] == key ? blocks_[slot_block_[slot]].get() : nullptr;
}

bool VoxelVoteGrid::VotableVoxel(const Eigen::Vector3d& p, Eigen::Vector3i* voxel) const {
  if (!p.allFinite()) return false;
  const Eigen::Vector3d s = p / options_.voxel_size_mm;
  if ((s.array().abs() >= kMaxIndex - 2).any()) return false;
  *voxel = VoxelOf(p);
  return true;
}

bool VoxelVoteGrid::AddPoint(const Eigen::Vector3d& p, const std::array<uint8_t, 3>& bgr,
                             const Eigen::Vector3f& toward_camera) {
  Eigen::Vector3i c;
  if (!VotableVoxel(p, &c)) return false;
  Block* near[27] = {};
  near[13] = GetBlock(c.x() >> kBlockBits, c.y() >> kBlockBits, c.z() >> kBlockBits);
  AddPointAt(c, near, bgr, toward_camera);
  return true;
}

void VoxelVoteGrid::AddPointAt(const Eigen::Vector3i& c, Block* near[27], const std::array<uint8_t, 3>& bgr,
                               const Eigen::Vector3f& toward_camera) {
  const int m = kBlockSide - 1;
  const int lx = c.x() & m, ly = c.y() & m, lz = c.z() & m;
  const int center_local = (lz * kBlockSide + ly) * kBlockSide + lx;
  Block* center_block = near[13];
  VoxelSums& sums = center_block->sums[center_local];
  sums.color_sum[0] += bgr[0];
  sums.color_sum[1] += bgr[1];
  sums.color_sum[2] += bgr[2];
  ++sums.color_count;
  if (toward_camera.allFinite())
    for (int k = 0; k < 3; ++k) sums.toward_camera_sum[k] += toward_camera[k];
  ++points_added_;
  // The neighbour pattern of the voxel's place in its block (interior, or on which faces): per neighbour the
  // block (by step, near[] index) and the local index offset, wrapping into the neighbouring block.
  auto layer = [m](int l) { return l == 0 ? 0 : l == m ? 2 : 1; };
  const int place = (layer(lz) * 3 + layer(ly)) * 3 + layer(lx);
  int64_t new_voxels = 0;      // voxels whose first vote this is
  if (place == kInnerPlace) {  // all in the voxel's own block; as the general loop it cost 25 % more time
    int32_t* votes = center_block->votes + center_local;
    for (const PlacedNeighbour& nb : placed_neighbours_[kInnerPlace]) {
      int32_t& v = votes[nb.delta];
      new_voxels += v == 0;
      v += nb.weight;
    }
    num_voxels_ += new_voxels;
    total_votes_ += neighbour_weight_total_;
    return;
  }
  for (const PlacedNeighbour& nb : placed_neighbours_[place]) {
    Block*& blk = near[nb.block];
    if (!blk)
      blk = GetBlock((c.x() >> kBlockBits) + nb.block % 3 - 1, (c.y() >> kBlockBits) + nb.block / 3 % 3 - 1,
                     (c.z() >> kBlockBits) + nb.block / 9 - 1);
    int32_t& v = blk->votes[center_local + nb.delta];
    new_voxels += v == 0;
    v += nb.weight;
  }
  num_voxels_ += new_voxels;
  total_votes_ += neighbour_weight_total_;
}

int VoxelVoteGrid::AddPoints(const std::vector<DensePoint>& points) {
  // The points grouped by the block of their voxel (a stable counting sort), so that each block and its
  // neighbours are looked up once per group and worked on in one run instead of being revisited from all over
  // memory. Votes and colour sums are integers; the direction sums are floats, but a voxel's points keep their
  // order, so every sum comes out the same as point by point. (Blocks may be created in another order, which
  // nothing observes: Extract and snapshots sort.)
  const size_t n = points.size();
  std::vector<Eigen::Vector3i> voxel(n);
  std::vector<int32_t> group(n, -1);  // per point: its block's group, -1 = not votable
  std::vector<uint32_t> group_block;  // per group: block index
  std::vector<uint32_t> group_start(1, 0);
  for (size_t i = 0; i < n; ++i) {
    if (!VotableVoxel(points[i].point_in_world, &voxel[i])) continue;
    const Eigen::Vector3i& c = voxel[i];
    const uint32_t block = BlockIndex(c.x() >> kBlockBits, c.y() >> kBlockBits, c.z() >> kBlockBits);
    if (block >= group_of_block_.size()) group_of_block_.resize(blocks_.size(), -1);
    int32_t& g = group_of_block_[block];
    if (g < 0) {
      g = static_cast<int32_t>(group_block.size());
      group_block.push_back(block);
      group_start.push_back(0);
    }
    group[i] = g;
    ++group_start[g + 1];
  }
  for (size_t g = 0; g < group_block.size(); ++g) {
    group_start[g + 1] += group_start[g];
    group_of_block_[group_block[g]] = -1;  // ready for the next call
  }
  const int accepted = static_cast<int>(group_start.back());
  std::vector<uint32_t> order(accepted);
  for (size_t i = 0; i < n; ++i)
    if (group[i] >= 0) order[group_start[group[i]]++] = static_cast<uint32_t>(i);
  Block* near[27] = {};  // the blocks around the current group's block
  int32_t current = -1;
  for (const uint32_t i : order) {
    if (group[i] != current) {
      current = group[i];
      std::fill(near, near + 27, nullptr);
      near[13] = blocks_[group_block[current]].get();
    }
    const DensePoint& p = points[i];
    AddPointAt(voxel[i], near, p.bgr, p.toward_camera);
  }
  return accepted;
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
      r.color_count = b.sums[l].color_count;
      if (r.color_count > 0)
        for (int k = 0; k < 3; ++k)
          r.bgr[k] =
              static_cast<uint8_t>((b.sums[l].color_sum[k] + r.color_count / 2) / static_cast<uint32_t>(r.color_count));
      const Eigen::Vector3f dir(b.sums[l].toward_camera_sum[0], b.sums[l].toward_camera_sum[1],
                                b.sums[l].toward_camera_sum[2]);
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
  return blocks_.size() * (sizeof(Block) + sizeof(Eigen::Vector3i) + sizeof(void*)) +
         slot_key_.size() * (sizeof(uint64_t) + sizeof(uint32_t)) + sizeof(*this);
}

void VoxelVoteGrid::Clear() {
  slot_key_.assign(64, kNoKey);
  slot_block_.assign(64, 0);
  blocks_.clear();
  block_coords_.clear();
  group_of_block_.clear();
  cached_key_ = kNoKey;
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
      if (b.votes[l] == 0 && b.sums[l].color_count == 0) continue;
      const Eigen::Vector3i ijk =
          base + Eigen::Vector3i(l & (kBlockSide - 1), (l >> kBlockBits) & (kBlockSide - 1), l >> (2 * kBlockBits));
      recs.push_back(
          {ijk.x(),
           ijk.y(),
           ijk.z(),
           b.votes[l],
           {b.sums[l].color_sum[0], b.sums[l].color_sum[1], b.sums[l].color_sum[2]},
           b.sums[l].color_count,
           {b.sums[l].toward_camera_sum[0], b.sums[l].toward_camera_sum[1], b.sums[l].toward_camera_sum[2]}});
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
    Block* b = loaded.GetBlock(r.i >> kBlockBits, r.j >> kBlockBits, r.k >> kBlockBits);
    const int l = ((r.k & m) * kBlockSide + (r.j & m)) * kBlockSide + (r.i & m);
    if (b->votes[l] == 0 && r.votes > 0) ++loaded.num_voxels_;
    b->votes[l] += r.votes;
    loaded.total_votes_ += r.votes;
    for (int k = 0; k < 3; ++k) b->sums[l].color_sum[k] += r.sum[k];
    for (int k = 0; k < 3; ++k)
      if (std::isfinite(r.toward_camera_sum[k])) b->sums[l].toward_camera_sum[k] += r.toward_camera_sum[k];
    b->sums[l].color_count += r.count;
    loaded.points_added_ += r.count;
  }
  *this = std::move(loaded);
  cached_key_ = kNoKey;
  return true;
}

}  // namespace objscan

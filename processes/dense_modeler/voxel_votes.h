// Exact vote counting in a sparse voxel space (LCM-free).
// Voxel (i, j, k) covers [i, i+1) x [j, j+1) x [k, k+1) times voxel_size_mm in world (origin at the world origin),
// its centre is (i + 0.5, j + 0.5, k + 0.5) * voxel_size_mm. Every point adds integer votes to its voxel and,
// with the chosen neighbourhood, to its 6 face or 26 face/edge/corner neighbours with configurable weights.
// Colours (BGR) are accumulated in the point's own voxel. Storage: blocks of 8x8x8 voxels in a hash map, so memory
// grows with the occupied region only; blocks are found through an open-addressing hash table (linear probing) and
// a point's 27 votes need at most 8 block look-ups. Snapshots are a small binary file (format in voxel_votes.cpp).
// Not thread-safe. Constructor throws std::invalid_argument on invalid options; nothing else throws.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "processes/dense_modeler/affine_dense.h"

namespace objscan {

struct VoxelVoteOptions {
  double voxel_size_mm = 2.0;  // mm, voxel edge (> 0)
  int neighbourhood = 26;      // 0 (own voxel only), 6 (faces) or 26 (faces, edges, corners)
  int center_weight = 10;      // votes for the point's own voxel (>= 1)
  int face_weight = 2;         // votes for each of the 6 face neighbours (>= 0)
  int edge_weight = 1;         // votes for each of the 12 edge neighbours (>= 0, 26-neighbourhood only)
  int corner_weight = 1;       // votes for each of the 8 corner neighbours (>= 0, 26-neighbourhood only)
};

bool ValidateVoxelVoteOptions(const VoxelVoteOptions& options, std::string* why);

// Hash key of a voxel index, unique for indices in [-2^20, 2^20) on each axis (2 km at 2 mm voxels).
inline uint64_t VoxelKey(const Eigen::Vector3i& ijk) {
  constexpr uint64_t kOffset = uint64_t{1} << 20, kMask = 0x1FFFFF;
  return ((static_cast<uint64_t>(ijk.x()) + kOffset) & kMask) |
         (((static_cast<uint64_t>(ijk.y()) + kOffset) & kMask) << 21) |
         (((static_cast<uint64_t>(ijk.z()) + kOffset) & kMask) << 42);
}

// Index of the voxel of size voxel_size_mm that contains point (mm, world): floor(point / voxel_size_mm).
inline Eigen::Vector3i VoxelIndexOf(const Eigen::Vector3d& point, double voxel_size_mm) {
  const Eigen::Vector3d s = point / voxel_size_mm;
  return Eigen::Vector3i(static_cast<int>(std::floor(s.x())), static_cast<int>(std::floor(s.y())),
                         static_cast<int>(std::floor(s.z())));
}

// Centre of voxel ijk (mm, world): (ijk + 0.5) x voxel_size_mm.
inline Eigen::Vector3d VoxelCenterOf(const Eigen::Vector3i& ijk, double voxel_size_mm) {
  return (ijk.cast<double>() + Eigen::Vector3d::Constant(0.5)) * voxel_size_mm;
}

// One voxel with its votes and mean colour.
struct VoxelRecord {
  Eigen::Vector3i ijk = Eigen::Vector3i::Zero();            // voxel index
  int32_t votes = 0;                                        // exact vote count
  std::array<uint8_t, 3> bgr{{128, 128, 128}};              // mean colour of the points that fell in it (grey if none)
  int32_t color_count = 0;                                  // points that fell in it
  Eigen::Vector3f toward_camera = Eigen::Vector3f::Zero();  // mean unit direction from its points towards the
                                                            // cameras that triangulated them (zero if unknown)
};

class VoxelVoteGrid {
 public:
  explicit VoxelVoteGrid(const VoxelVoteOptions& options = {});

  const VoxelVoteOptions& options() const { return options_; }
  double voxel_size() const { return options_.voxel_size_mm; }
  Eigen::Vector3i VoxelOf(const Eigen::Vector3d& point_in_world) const;
  Eigen::Vector3d CenterOf(const Eigen::Vector3i& ijk) const;

  // Adds the votes of one point. False (nothing added) for non-finite points or points beyond ±2^22 voxels.
  // toward_camera (unit, world; zero = unknown) is summed in the point's own voxel: the side the point was seen
  // from, which orients the surface normal.
  bool AddPoint(const Eigen::Vector3d& point_in_world, const std::array<uint8_t, 3>& bgr,
                const Eigen::Vector3f& toward_camera = Eigen::Vector3f::Zero());
  // Adds every point (worked on grouped by block for memory locality; the result is exactly that of AddPoint one
  // by one in order); returns how many were accepted.
  int AddPoints(const std::vector<DensePoint>& points);

  int32_t Votes(const Eigen::Vector3i& ijk) const;
  // Voxels with votes >= min_votes (>= 1), sorted by (k, j, i).
  std::vector<VoxelRecord> Extract(int32_t min_votes) const;
  // Voxels with at least one vote.
  int64_t num_voxels() const { return num_voxels_; }
  int64_t total_votes() const { return total_votes_; }
  int64_t points_added() const { return points_added_; }
  size_t memory_bytes() const;
  void Clear();

  // Binary snapshot of every voted voxel. False with *error on I/O failure (written to path + ".tmp", renamed).
  bool SaveSnapshot(const std::string& path, std::string* error) const;
  // Replaces the content (and voxel size, neighbourhood and weights) with a snapshot. False with *error (content
  // unchanged) on a missing, truncated or foreign file.
  bool LoadSnapshot(const std::string& path, std::string* error);

 private:
  static constexpr int kBlockBits = 3;
  static constexpr int kBlockSide = 1 << kBlockBits;
  static constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;
  struct VoxelSums {  // one voxel's accumulators side by side (28 bytes): a point updates one or two cache lines
    uint32_t color_sum[3] = {0, 0, 0};
    int32_t color_count = 0;
    float toward_camera_sum[3] = {0, 0, 0};
  };

  struct Block {
    int32_t votes[kBlockVoxels] = {};
    VoxelSums sums[kBlockVoxels];
  };
  static constexpr uint64_t kNoKey = ~uint64_t{0};  // empty slot (BlockKey uses 63 bits)
  static uint64_t BlockKey(int bx, int by, int bz);
  Block* GetBlock(int bx, int by, int bz);      // the block, created (zeroed) when absent
  uint32_t BlockIndex(int bx, int by, int bz);  // its index into blocks_, the block created when absent
  bool VotableVoxel(const Eigen::Vector3d& point_in_world, Eigen::Vector3i* voxel) const;
  // near: the blocks around the voxel's block by block step ((sz + 1) * 3 + (sy + 1)) * 3 + (sx + 1); near[13] =
  // the voxel's block; null entries are looked up (created) when needed.
  void AddPointAt(const Eigen::Vector3i& voxel, Block* near[27], const std::array<uint8_t, 3>& bgr,
                  const Eigen::Vector3f& toward_camera);
  const Block* FindBlock(int bx, int by, int bz) const;
  size_t SlotOf(uint64_t key) const;  // the key's slot, or the empty slot where it would go
  void GrowTable();

  VoxelVoteOptions options_;
  std::array<int32_t, 4> weight_by_order_{};  // votes by number of non-zero offsets (0 = own voxel)
  // The voxels a point votes for (weight > 0, the own voxel included), in (dz, dy, dx) raster order, for each
  // place of the point's voxel in its block ((lz, ly, lx) each 0 = first layer, 1 = inner, 2 = last layer):
  struct PlacedNeighbour {
    int block;  // near[] index of the block holding it: ((sz + 1) * 3 + (sy + 1)) * 3 + (sx + 1)
    int delta;  // its local index in that block minus the point's local index
    int32_t weight;
  };
  static constexpr int kInnerPlace = 13;  // inner layer on every axis: no neighbour crosses a block border
  std::vector<PlacedNeighbour> placed_neighbours_[27];
  int64_t neighbour_weight_total_ = 0;  // votes one point adds
  std::vector<uint64_t> slot_key_;      // hash table of blocks: key per slot (kNoKey = empty), power-of-two size
  std::vector<uint32_t> slot_block_;    // index into blocks_ per slot
  uint64_t cached_key_ = kNoKey;        // last block looked up (kNoKey = none; BlockKey never returns it)
  uint32_t cached_index_ = 0;
  std::vector<int32_t> group_of_block_;  // AddPoints' scratch: group per block index (-1 between calls)
  std::vector<std::unique_ptr<Block>> blocks_;
  std::vector<Eigen::Vector3i> block_coords_;
  int64_t num_voxels_ = 0;
  int64_t total_votes_ = 0;
  int64_t points_added_ = 0;
};

}  // namespace objscan

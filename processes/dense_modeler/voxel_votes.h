// Exact vote counting in a sparse voxel space (LCM-free).
// Voxel (i, j, k) covers [i, i+1) x [j, j+1) x [k, k+1) times voxel_size_mm in world (origin at the world origin),
// its centre is (i + 0.5, j + 0.5, k + 0.5) * voxel_size_mm. Every point adds integer votes to its voxel and,
// with the chosen neighbourhood, to its 6 face or 26 face/edge/corner neighbours with configurable weights.
// Colours (BGR) are accumulated in the point's own voxel. Storage: blocks of 8x8x8 voxels in a hash map, so memory
// grows with the occupied region only. Snapshots are a small binary file (format in voxel_votes.cpp).
// Not thread-safe. Constructor throws std::invalid_argument on invalid options; nothing else throws.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
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
  // Adds every point; returns how many were accepted.
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
  struct Block {
    int32_t votes[kBlockVoxels] = {};
    uint32_t color_sum[kBlockVoxels][3] = {};
    int32_t color_count[kBlockVoxels] = {};
    float toward_camera_sum[kBlockVoxels][3] = {};
  };
  static uint64_t BlockKey(int bx, int by, int bz);
  Block* GetBlock(int bx, int by, int bz, bool create);
  const Block* FindBlock(int bx, int by, int bz) const;
  void AddVotes(Block* block, int local, int32_t weight);

  VoxelVoteOptions options_;
  std::array<int32_t, 4> weight_by_order_{};  // votes by number of non-zero offsets (0 = own voxel)
  std::unordered_map<uint64_t, uint32_t> block_index_;
  uint64_t cached_key_ = ~uint64_t{0};  // last block looked up (blocks never move: heap-allocated)
  Block* cached_block_ = nullptr;
  std::vector<std::unique_ptr<Block>> blocks_;
  std::vector<Eigen::Vector3i> block_coords_;
  int64_t num_voxels_ = 0;
  int64_t total_votes_ = 0;
  int64_t points_added_ = 0;
};

}  // namespace objscan

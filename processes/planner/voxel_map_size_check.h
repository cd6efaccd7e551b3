// Declared-size check of a received voxel_map_t against its byte count, before decoding (LCM's generated decoders
// resize arrays from the count field first; see processes/object_finder/message_size_check.h for landmarks_t and
// camera_info_t, which the planner node reuses). Walks the raw bytes without allocating; false with *why
// ("wrong type", "truncated", "declared 1000000 voxels in 120 bytes"); never throws.
#pragma once

#include <string>

namespace objscan {

// voxel_map_t: hash, utime, seq, frame, voxel_size_mm, origin_mm[3], vote_threshold, is_final, truncated,
// num_voxels n >= 0, then exactly 19 * n bytes (ijk 12, votes 4, rgb 3 per voxel).
bool CheckVoxelMapMessageSize(const void* data, int size, std::string* why);

}  // namespace objscan

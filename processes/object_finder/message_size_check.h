// Checks of a received message's declared array sizes against its byte count, before decoding: LCM's generated C++
// decoders resize each array from its count field before checking it against the buffer, so a corrupted count
// allocates and zero-fills up to gigabytes before the decode fails. These walk the raw bytes (LCM encoding: 8-byte
// type hash, big-endian fields, strings as int32 length incl. the NUL, then the bytes) without allocating.
// They return false with *why ("wrong type", "truncated", "declared 1000000 landmarks in 120 bytes") and never throw.
#pragma once

#include <string>

namespace objscan {

// landmarks_t: hash, utime, seq, frame, num_landmarks n >= 0, then exactly 31 * n bytes (id 8, position 12,
// num_observations 4, reprojection_error_px 4, rgb 3 per landmark).
bool CheckLandmarksMessageSize(const void* data, int size, std::string* why);

// camera_info_t: hash, utime, camera_name, width, height, fx fy cx cy skew, distortion_model, num_distortion n >= 0,
// then exactly 8 * n bytes.
bool CheckCameraInfoMessageSize(const void* data, int size, std::string* why);

}  // namespace objscan

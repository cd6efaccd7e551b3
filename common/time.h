#pragma once
#include <chrono>
#include <cstdint>

namespace objscan {
// µs since the Unix epoch, wall clock (for status messages and latency, never for data).
inline int64_t WallTimeMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch()).count();
}
// µs from a monotonic clock, for measuring durations.
inline int64_t MonotonicMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace objscan

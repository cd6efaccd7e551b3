// Small statistics over plain values (LCM-free).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace objscan {

// The q-quantile (q in [0, 1]) of values by nearest rank: the element at round(q·(n−1)) of the sorted values; 0 for
// no values or a NaN q. Takes a copy (values are reordered). Never throws: q out of range is clamped to [0, 1].
inline double Percentile(std::vector<double> values, double q) {
  if (values.empty() || std::isnan(q)) return 0.0;
  q = std::clamp(q, 0.0, 1.0);
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * static_cast<double>(values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(k), values.end());
  return values[k];
}

// The last `capacity` values added (a ring; older ones are overwritten), for percentiles over a bounded window, and
// the count and maximum of every value ever added. capacity 0 is taken as 1. Not thread-safe.
class RecentValues {
 public:
  explicit RecentValues(size_t capacity) : capacity_(std::max<size_t>(capacity, 1)) { values_.reserve(capacity_); }

  void Add(double value) {
    if (values_.size() < capacity_) {
      values_.push_back(value);
    } else {
      values_[next_] = value;
      next_ = (next_ + 1) % capacity_;
    }
    if (total_ == 0 || value > max_) max_ = value;
    ++total_;
  }

  const std::vector<double>& values() const { return values_; }  // the kept ones, not in order once wrapped
  size_t capacity() const { return capacity_; }
  size_t total() const { return total_; }  // values ever added
  double max() const { return max_; }      // of every value ever added; 0 before the first
  bool empty() const { return total_ == 0; }

 private:
  size_t capacity_;
  std::vector<double> values_;
  size_t next_ = 0;
  size_t total_ = 0;
  double max_ = 0;
};

}  // namespace objscan

// Small statistics over plain values (LCM-free).
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace objscan {

// The q-quantile (q in [0, 1]) of values by nearest rank: the element at round(q·(n−1)) of the sorted values; 0 for
// no values. Takes a copy (values are reordered). Never throws for q out of range: it is clamped to [0, 1].
inline double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  q = std::clamp(q, 0.0, 1.0);
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * static_cast<double>(values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(k), values.end());
  return values[k];
}

}  // namespace objscan

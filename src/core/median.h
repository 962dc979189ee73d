#pragma once

#include <algorithm>
#include <vector>

namespace pano4d {

// The upper median of `v` (its element at size / 2 once sorted; for an
// even count the larger of the two middle values), 0 for an empty `v`.
// Takes `v` by value: nth_element reorders it.
template <typename T>
T UpperMedian(std::vector<T> v) {
  if (v.empty()) return T(0);
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace pano4d

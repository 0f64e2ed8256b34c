// Order statistics of samples, shared by the evaluations and the solvers.
#pragma once

#include <algorithm>
#include <vector>

namespace oslam {

// The middle value, the upper of the two for an even count; 0 for none.
inline double UpperMedian(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

// The median, the mean of the two middle values for an even count; 0 for none.
inline double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t mid = values.size() / 2;
  return values.size() % 2 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
}

}  // namespace oslam

#include "core/bounding_slice.h"

#include <algorithm>
#include <cmath>

#include "core/angles.h"

namespace oslam {

BoundingSlice SliceFromExtents(double r_min_px, double r_max_px, double angle_begin_rad,
                               double angle_end_rad) {
  double width = angle_end_rad - angle_begin_rad;
  width = std::fmod(width, 2.0 * kPi);
  if (width < 0) width += 2.0 * kPi;
  BoundingSlice slice;
  slice.u_r_px = r_min_px;
  slice.s_r_px = r_max_px - r_min_px;
  slice.s_phi_rad = width;
  slice.u_phi_rad = WrapAngle(angle_begin_rad + 0.5 * width);
  return slice;
}

BoundingSlice SliceOfPolarPoints(const std::vector<double>& radii_px,
                                 const std::vector<double>& angles_rad) {
  if (radii_px.empty() || angles_rad.empty()) return {};
  const auto [r_min, r_max] = std::minmax_element(radii_px.begin(), radii_px.end());
  std::vector<double> sorted;
  sorted.reserve(angles_rad.size());
  for (double angle : angles_rad) sorted.push_back(WrapAngle(angle));
  std::sort(sorted.begin(), sorted.end());
  // Largest gap between neighbours, including the wrap from last to first.
  double largest_gap = sorted.front() + 2.0 * kPi - sorted.back();
  size_t arc_begin = 0;  // the arc starts just after the largest gap
  for (size_t i = 1; i < sorted.size(); ++i) {
    const double gap = sorted[i] - sorted[i - 1];
    if (gap > largest_gap) {
      largest_gap = gap;
      arc_begin = i;
    }
  }
  const size_t arc_end = arc_begin == 0 ? sorted.size() - 1 : arc_begin - 1;
  return SliceFromExtents(*r_min, *r_max, sorted[arc_begin], sorted[arc_end]);
}

}  // namespace oslam

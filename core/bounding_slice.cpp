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

BoundingSlice SliceOfPixelCentres(const std::vector<double>& radii_px,
                                  const std::vector<double>& angles_rad) {
  BoundingSlice slice = SliceOfPolarPoints(radii_px, angles_rad);
  if (radii_px.empty()) return slice;
  const double pad_angle_rad = 0.5 / std::max(1.0, slice.u_r_px);
  slice.u_r_px -= 0.5;
  slice.s_r_px += 1.0;
  // A blob all around the centre spans at most the full circle.
  slice.s_phi_rad = std::min(2.0 * kPi, slice.s_phi_rad + 2.0 * pad_angle_rad);
  return slice;
}

double SliceArcWidth(const BoundingSlice& slice) {
  return slice.s_phi_rad * (slice.u_r_px + 0.5 * slice.s_r_px);
}

double SliceElongation(const BoundingSlice& slice) {
  const double arc_width_px = SliceArcWidth(slice);
  return arc_width_px > 0 ? slice.s_r_px / arc_width_px : 0.0;
}

double SliceCoverage(const BoundingSlice& slice, const BoundingSlice& other) {
  if (!(slice.s_r_px > 0) || !(slice.s_phi_rad > 0)) return 0.0;
  const double radial = std::min(slice.u_r_px + slice.s_r_px, other.u_r_px + other.s_r_px) -
                        std::max(slice.u_r_px, other.u_r_px);
  // Two arcs can meet on both sides of the circle when together they span more than half of it.
  const double half_sum = 0.5 * (slice.s_phi_rad + other.s_phi_rad);
  const double apart = std::abs(WrapAngle(slice.u_phi_rad - other.u_phi_rad));
  const double angular =
      std::min(std::min(slice.s_phi_rad, other.s_phi_rad),
               std::max(0.0, half_sum - apart) + std::max(0.0, half_sum - (2.0 * kPi - apart)));
  return std::clamp(radial / slice.s_r_px, 0.0, 1.0) *
         std::clamp(angular / slice.s_phi_rad, 0.0, 1.0);
}

}  // namespace oslam

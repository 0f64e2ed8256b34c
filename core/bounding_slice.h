// A bounding slice: the annular sector an object covers in the omnidirectional
// image, in polar image coordinates (docs/method.md §3.1, §10.1). It is the measurement
// every detector produces and the observation model predicts.
#pragma once

#include <vector>

namespace oslam {

struct BoundingSlice {
  double u_r_px = 0.0;     // radius of the object's base point (inner radius of the slice)
  double u_phi_rad = 0.0;  // angle of the base point (middle angle of the slice)
  double s_r_px = 0.0;     // radial length r_max - r_min (projected height)
  double s_phi_rad = 0.0;  // angular width (projected diameter), in [0, 2 pi)
};

// The slice spanning radii [r_min, r_max] and the counter-clockwise arc from
// angle_begin to angle_end (wrap at +-pi handled).
BoundingSlice SliceFromExtents(double r_min_px, double r_max_px, double angle_begin_rad,
                               double angle_end_rad);

// Smallest slice containing every (radius, angle) point: the angular arc is
// the complement of the largest gap between sorted angles, so a blob across
// the +-pi seam gets its true width. Empty input gives a zero slice.
BoundingSlice SliceOfPolarPoints(const std::vector<double>& radii_px,
                                 const std::vector<double>& angles_rad);

// The slice of a set of pixels given by their centres' polar coordinates:
// SliceOfPolarPoints widened by half a pixel on every side, since pixels are
// unit squares and only their centres are sampled (sizes not biased low).
BoundingSlice SliceOfPixelCentres(const std::vector<double>& radii_px,
                                  const std::vector<double>& angles_rad);

// Arc width in pixels at the slice's middle radius.
double SliceArcWidth(const BoundingSlice& slice);

// Radial length over arc width at the slice's middle radius: a shape measure
// independent of the object's distance to first order (a sphere gives about 1).
// 0 for a slice of zero width.
double SliceElongation(const BoundingSlice& slice);

// The share of `slice`'s area (in polar coordinates) that `other` covers: the
// product of the shared fractions of its radial and angular extents, in [0, 1].
double SliceCoverage(const BoundingSlice& slice, const BoundingSlice& other);

}  // namespace oslam

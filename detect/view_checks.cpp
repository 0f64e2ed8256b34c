#include "detect/view_checks.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace oslam {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kMinRangeM = 0.02, kMaxRangeM = 200.0;

// The image radius of the robot-frame point at horizontal range `range` along
// the unit `direction` and height `z`; +inf when it has no image (above the
// mirror's field of view).
double RadiusAt(const CameraModel& camera, const Eigen::Vector2d& direction, double range,
                double z) {
  double radius;
  const Eigen::Vector3d point(range * direction.x(), range * direction.y(), z);
  return camera.ProjectRadius(point, &radius) ? radius : kInfinity;
}

// Bisection for the root of a function that changes sign once in [lo, hi].
template <typename F>
double Bisect(const F& f, double lo, double hi) {
  const bool rising = f(hi) > f(lo);
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    if ((f(mid) > 0) == rising)
      hi = mid;
    else
      lo = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

bool ViewCheckOptions::Validate(std::string* why) const {
  if (!(pixel_std_px > 0) || std::isinf(pixel_std_px)) {
    if (why) *why = "the pixel error of the view checks must be positive";
    return false;
  }
  if (!(arc_std_px > 0) || std::isinf(arc_std_px)) {
    if (why) *why = "the arc-width error of the view checks must be positive";
    return false;
  }
  if (!(edge_margin_px >= 0) || std::isinf(edge_margin_px)) {
    if (why) *why = "the edge margin of the view checks must be >= 0 px";
    return false;
  }
  return true;
}

bool SizeFromSupport(const CameraModel& camera, const BoundingSlice& slice, double base_height_m,
                     SupportedViewSize* size) {
  // The bearing of the slice's base (any central camera: through its ray).
  Ray ray;
  if (!camera.BackProjectPixel(camera.PolarToPixel({slice.u_r_px, slice.u_phi_rad}), &ray))
    return false;
  Eigen::Vector2d direction = ray.direction_robot.head<2>();
  if (!(direction.norm() > 1e-9)) return false;
  direction.normalize();
  // The range at which a point at the base height images at u_r. The radius
  // is monotonic in the range along a ray of the floor (outwards for a camera
  // below its mirror); a base at or above the camera has no such range.
  const auto base_error = [&](double range) {
    const double r = RadiusAt(camera, direction, range, base_height_m);
    return std::isinf(r) ? 1e9 : r - slice.u_r_px;
  };
  const double near = base_error(kMinRangeM), far = base_error(kMaxRangeM);
  if (!((near < 0) != (far < 0))) return false;
  const double range = Bisect(base_error, kMinRangeM, kMaxRangeM);
  // The height whose top images at the slice's outer radius; radii grow with
  // the elevation until the point leaves the field of view.
  const double outer = slice.u_r_px + slice.s_r_px;
  const auto top_error = [&](double height) {
    const double r = RadiusAt(camera, direction, range, base_height_m + height);
    return std::isinf(r) ? 1e9 : r - outer;
  };
  constexpr double kMaxHeightM = 50.0;
  size->range_m = range;
  size->diameter_m = 2.0 * range * std::tan(0.5 * slice.s_phi_rad);
  size->top_cut = !(top_error(kMaxHeightM) > 0);
  size->height_m = size->top_cut ? kMaxHeightM : Bisect(top_error, 0.0, kMaxHeightM);
  if (top_error(0.0) > 0) size->height_m = 0.0;  // a slice of no length
  return true;
}

double ArcStdPx(const ObjectClass& object_class, const ViewCheckOptions& options) {
  const auto& shape = object_class.image_shape;
  return shape && shape->arc_error_px > 0 ? shape->arc_error_px : options.arc_std_px;
}

SliceCuts CutsOf(const MirrorAnnulus& annulus, const BoundingSlice& slice,
                 const ViewCheckOptions& options) {
  SliceCuts cuts;
  cuts.base = slice.u_r_px <= annulus.blind_radius_px + options.edge_margin_px;
  cuts.top = annulus.rim_radius_px > 0 &&
             slice.u_r_px + slice.s_r_px >= annulus.rim_radius_px - options.edge_margin_px;
  return cuts;
}

double SupportedSizeSquaredDistance(const CameraModel& camera, const ObjectClass& object_class,
                                    const BoundingSlice& slice, double base_height_m,
                                    const ViewCheckOptions& options) {
  if (!(object_class.diameter_std_m > 0) || !(object_class.height_std_m > 0)) return 0.0;
  const SliceCuts cuts = CutsOf(camera.annulus(), slice, options);
  if (cuts.base) return 0.0;
  SupportedViewSize size;
  if (!SizeFromSupport(camera, slice, base_height_m, &size)) return kInfinity;
  const bool top_cut = size.top_cut || cuts.top;
  // What the pixel error on u_r, s_r and the arc width does to the size:
  // finite differences of the same inversion.
  const double e = options.pixel_std_px;
  const double middle_radius = slice.u_r_px + 0.5 * slice.s_r_px;
  double d_variance = 0, h_variance = 0;
  auto add_variance = [&](const BoundingSlice& moved) {
    SupportedViewSize other;
    if (!SizeFromSupport(camera, moved, base_height_m, &other)) return;
    d_variance += std::pow(other.diameter_m - size.diameter_m, 2);
    if (!other.top_cut && !size.top_cut) h_variance += std::pow(other.height_m - size.height_m, 2);
  };
  BoundingSlice moved = slice;
  moved.u_r_px += e;
  moved.s_r_px = std::max(0.0, moved.s_r_px - e);  // the top stays where it was
  add_variance(moved);
  moved = slice;
  moved.s_r_px += e;
  add_variance(moved);
  moved = slice;
  moved.s_phi_rad += ArcStdPx(object_class, options) / std::max(1.0, middle_radius);
  add_variance(moved);
  const double d_error = size.diameter_m - object_class.diameter_mean_m;
  double distance2 =
      d_error * d_error / (object_class.diameter_std_m * object_class.diameter_std_m + d_variance);
  const double h_error = size.height_m - object_class.height_mean_m;
  if (!top_cut || h_error > 0) {
    const double variance = object_class.height_std_m * object_class.height_std_m + h_variance;
    distance2 += h_error * h_error / variance;
  }
  return distance2;
}

}  // namespace oslam

#include "calib/hyperbolic_camera.h"

#include <cmath>

#include "core/angles.h"
#include "core/bounds.h"
#include "core/error.h"

namespace oslam {
namespace {

constexpr double kMaxMirrorAxisM = 1.0;
constexpr double kMinMirrorShape = 1e-3, kMaxMirrorShape = 10.0;  // b / a
constexpr double kMaxHeightM = 100.0;
constexpr double kMaxFocalPx = 1e7;

}  // namespace

HyperbolicCamera::HyperbolicCamera(const HyperbolicMirrorParameters& parameters, int image_width,
                                   int image_height, const MirrorAnnulus& annulus)
    : parameters_(parameters) {
  set_image_size(image_width, image_height);
  set_annulus(annulus);
}

HyperbolicCamera HyperbolicCamera::Preset(const std::string& name) {
  // Mirror and focal values: thesis Appendix A (docs/method.md §4.3 table). Image size
  // and annulus are not in the thesis: chosen so the horizon (201 px LPA,
  // 262 px Cogniron) and some sky fit, and the robot's own reflection is
  // masked.
  HyperbolicMirrorParameters p;
  if (name == "lpa") {
    p.mirror_a_m = 0.03929;
    p.mirror_b_m = 0.01965;
    p.focus_height_m = 0.76;
    p.focal_px = 1800.0;
    p.center_x_px = 320.0;
    p.center_y_px = 240.0;
    return HyperbolicCamera(p, 640, 480, MirrorAnnulus{40.0, 236.0});
  }
  if (name == "cogniron") {
    p.mirror_a_m = 0.04209;
    p.mirror_b_m = 0.02509;
    p.focus_height_m = 1.0615;
    p.focal_px = 1715.0;
    p.center_x_px = 400.0;
    p.center_y_px = 300.0;
    return HyperbolicCamera(p, 800, 600, MirrorAnnulus{45.0, 296.0});
  }
  throw Error("unknown camera preset '" + name + "' (known: lpa, cogniron)");
}

std::vector<std::string> HyperbolicCamera::PresetNames() {
  return {"lpa", "cogniron"};
}

std::unique_ptr<CameraModel> HyperbolicCamera::Clone() const {
  return std::make_unique<HyperbolicCamera>(*this);
}

std::vector<std::string> HyperbolicCamera::IntrinsicNames() const {
  return {"mirror_a_m",  "mirror_b_m",  "focus_height_m",  "focal_px",
          "center_x_px", "center_y_px", "angle_offset_rad"};
}

Eigen::VectorXd HyperbolicCamera::Intrinsics() const {
  Eigen::VectorXd v(7);
  v << parameters_.mirror_a_m, parameters_.mirror_b_m, parameters_.focus_height_m,
      parameters_.focal_px, parameters_.center_x_px, parameters_.center_y_px,
      parameters_.angle_offset_rad;
  return v;
}

void HyperbolicCamera::SetIntrinsics(const Eigen::VectorXd& v) {
  if (v.size() != 7) {
    throw Error("hyperbolic camera: expected 7 intrinsics, got " + std::to_string(v.size()));
  }
  parameters_.mirror_a_m = v[0];
  parameters_.mirror_b_m = v[1];
  parameters_.focus_height_m = v[2];
  parameters_.focal_px = v[3];
  parameters_.center_x_px = v[4];
  parameters_.center_y_px = v[5];
  parameters_.angle_offset_rad = v[6];
}

bool HyperbolicCamera::Validate(std::string* why) const {
  if (!CameraModel::Validate(why)) return false;
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (parameters_.mirror_a_m <= 0) return fail("mirror_a_m must be positive");
  if (parameters_.mirror_b_m <= 0) return fail("mirror_b_m must be positive");
  if (parameters_.focal_px <= 0) return fail("focal_px must be positive");
  if (parameters_.focus_height_m <= 0) return fail("focus_height_m must be above the floor (> 0)");
  const HyperbolicMirrorParameters& p = parameters_;
  // A mirror is centimetres to decimetres across; its shape b/a between
  // 1:1000 (nearly a cone) and 10:1 (the horizon images 5 focal lengths out,
  // beyond any image).
  return CheckIntrinsic("mirror_a_m", p.mirror_a_m, 0, kMaxMirrorAxisM, "m", why) &&
         CheckIntrinsic("mirror_b_m", p.mirror_b_m, 0, kMaxMirrorAxisM, "m", why) &&
         CheckIntrinsic("mirror_b_m / mirror_a_m", p.mirror_b_m / p.mirror_a_m, kMinMirrorShape,
                        kMaxMirrorShape, "", why) &&
         CheckIntrinsic("focus_height_m", p.focus_height_m, 0, kMaxHeightM, "m", why) &&
         CheckIntrinsic("focal_px", p.focal_px, 0, kMaxFocalPx, "px", why) &&
         CheckIntrinsic("angle_offset_rad", p.angle_offset_rad, -bounds::kAngleRad,
                        bounds::kAngleRad, "rad", why) &&
         CheckPrincipalPoint(p.center_x_px, p.center_y_px, why);
}

double HyperbolicCamera::Eccentricity() const {
  // Called per projection: sqrt, not hypot (several times slower; a and b
  // are centimetres, far from overflow).
  const double a = parameters_.mirror_a_m, b = parameters_.mirror_b_m;
  return std::sqrt(a * a + b * b);
}

double HyperbolicCamera::HorizonRadius() const {
  const double a = parameters_.mirror_a_m, b = parameters_.mirror_b_m;
  return parameters_.focal_px * b * b / (2.0 * a * Eccentricity());
}

bool HyperbolicCamera::ImageRadius(double range_m, double height_m, double* radius_px,
                                   double* d_radius_d_range, double* d_radius_d_height) const {
  const double a = parameters_.mirror_a_m, b = parameters_.mirror_b_m;
  const double e = Eccentricity();
  const double w = height_m - parameters_.focus_height_m;
  const double s = std::sqrt(range_m * range_m + w * w);  // hypot: slow, and no overflow here
  // The ray from the focus hits the mirror only below elevation asin(a/e).
  if (!(a * s > e * w)) return false;
  const double k = parameters_.focal_px * b * b;
  const double sum_sq = a * a + e * e;
  const double denominator = 2.0 * a * e * s - sum_sq * w;
  *radius_px = k * range_m / denominator;
  if (d_radius_d_range || d_radius_d_height) {
    const double inv_s = s > 0 ? 1.0 / s : 0.0;
    const double d_den_d_range = 2.0 * a * e * range_m * inv_s;
    const double d_den_d_w = 2.0 * a * e * w * inv_s - sum_sq;
    const double den_sq = denominator * denominator;
    if (d_radius_d_range) *d_radius_d_range = k * (denominator - range_m * d_den_d_range) / den_sq;
    if (d_radius_d_height) *d_radius_d_height = -k * range_m * d_den_d_w / den_sq;
  }
  return true;
}

double HyperbolicCamera::ElevationOfRadius(double radius_px, double* d_elevation_d_radius) const {
  // T(alpha) = K cos(alpha) / (B - A sin(alpha)); solve K cos + t A sin = t B
  // as R cos(alpha - delta) = t B and keep the root below the mirror limit.
  const double a = parameters_.mirror_a_m, b = parameters_.mirror_b_m;
  const double e = Eccentricity();
  const double k = parameters_.focal_px * b * b;
  const double big_a = a * a + e * e, big_b = 2.0 * a * e;
  const double t = radius_px;
  const double r = std::hypot(k, t * big_a);
  const double delta = std::atan2(t * big_a, k);
  const double elevation = delta - std::acos(std::min(1.0, t * big_b / r));
  if (d_elevation_d_radius) {
    // dT/dalpha = K (A - B sin) / (B - A sin)^2 > 0 below the mirror limit.
    const double sin_el = std::sin(elevation);
    const double den = big_b - big_a * sin_el;
    *d_elevation_d_radius = den * den / (k * (big_a - big_b * sin_el));
  }
  return elevation;
}

double HyperbolicCamera::ImageAngleOfBearing(double bearing_rad) const {
  return WrapAngle(parameters_.angle_offset_rad + AngleSign() * bearing_rad);
}

double HyperbolicCamera::BearingOfImageAngle(double image_angle_rad) const {
  return WrapAngle(AngleSign() * (image_angle_rad - parameters_.angle_offset_rad));
}

bool HyperbolicCamera::ProjectToPixel(const Eigen::Vector3d& point_robot, Eigen::Vector2d* pixel,
                                      Eigen::Matrix<double, 2, 3>* jacobian) const {
  const double range = std::hypot(point_robot.x(), point_robot.y());
  if (!(range > 0.0)) return false;  // on the mirror axis: no bearing
  double radius = 0, d_radius_d_range = 0, d_radius_d_height = 0;
  if (!ImageRadius(range, point_robot.z(), &radius, jacobian ? &d_radius_d_range : nullptr,
                   jacobian ? &d_radius_d_height : nullptr)) {
    return false;
  }
  const double bearing = std::atan2(point_robot.y(), point_robot.x());
  const double angle = ImageAngleOfBearing(bearing);
  const Eigen::Vector2d radial(std::cos(angle), std::sin(angle));
  *pixel = ImageCenter() + radius * radial;
  if (jacobian) {
    const Eigen::Vector2d tangential(-radial.y(), radial.x());
    const double range_sq = range * range;
    const Eigen::RowVector3d d_radius(d_radius_d_range * point_robot.x() / range,
                                      d_radius_d_range * point_robot.y() / range,
                                      d_radius_d_height);
    const Eigen::RowVector3d d_angle =
        AngleSign() *
        Eigen::RowVector3d(-point_robot.y() / range_sq, point_robot.x() / range_sq, 0);
    *jacobian = radial * d_radius + radius * tangential * d_angle;
  }
  return true;
}

bool HyperbolicCamera::ProjectToPolar(const Eigen::Vector3d& point_robot, PolarPoint* polar,
                                      Eigen::Matrix<double, 2, 3>* jacobian) const {
  const double range_sq = point_robot.x() * point_robot.x() + point_robot.y() * point_robot.y();
  const double range = std::sqrt(range_sq);
  if (!(range > 0.0)) return false;  // on the mirror axis: no bearing
  double radius = 0, d_radius_d_range = 0, d_radius_d_height = 0;
  if (!ImageRadius(range, point_robot.z(), &radius, jacobian ? &d_radius_d_range : nullptr,
                   jacobian ? &d_radius_d_height : nullptr)) {
    return false;
  }
  polar->radius_px = radius;
  polar->angle_rad = ImageAngleOfBearing(std::atan2(point_robot.y(), point_robot.x()));
  if (jacobian) {
    *jacobian << d_radius_d_range * point_robot.x() / range,
        d_radius_d_range * point_robot.y() / range, d_radius_d_height,
        -AngleSign() * point_robot.y() / range_sq, AngleSign() * point_robot.x() / range_sq, 0.0;
  }
  return true;
}

bool HyperbolicCamera::ProjectRadius(const Eigen::Vector3d& point_robot, double* radius_px,
                                     Eigen::RowVector3d* jacobian) const {
  const double range =
      std::sqrt(point_robot.x() * point_robot.x() + point_robot.y() * point_robot.y());
  if (!(range > 0.0)) return false;  // as ProjectToPolar
  double d_radius_d_range = 0, d_radius_d_height = 0;
  if (!ImageRadius(range, point_robot.z(), radius_px, jacobian ? &d_radius_d_range : nullptr,
                   jacobian ? &d_radius_d_height : nullptr))
    return false;
  if (jacobian)
    *jacobian << d_radius_d_range * point_robot.x() / range,
        d_radius_d_range * point_robot.y() / range, d_radius_d_height;
  return true;
}

bool HyperbolicCamera::BackProjectPixel(const Eigen::Vector2d& pixel, Ray* ray) const {
  if (!pixel.allFinite()) return false;
  const PolarPoint polar = PixelToPolar(pixel);
  const double elevation = ElevationOfRadius(polar.radius_px);
  const double bearing = BearingOfImageAngle(polar.angle_rad);
  ray->origin_robot = Eigen::Vector3d(0.0, 0.0, parameters_.focus_height_m);
  ray->direction_robot =
      Eigen::Vector3d(std::cos(elevation) * std::cos(bearing),
                      std::cos(elevation) * std::sin(bearing), std::sin(elevation));
  return true;
}

}  // namespace oslam

#include "calib/mei_camera.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "core/bounds.h"
#include "core/error.h"

namespace oslam {

namespace {

constexpr double kMaxXi = 3.0;
constexpr double kMaxFocalPx = 1e7;
constexpr double kMaxDistortion = 1e3;  // |k1|, |k2|, |p1|, |p2|
constexpr double kMaxHeightM = 100.0;

// Distortion of a normalised-plane point and its 2x2 Jacobian.
Eigen::Vector2d Distort(const MeiParameters& p, const Eigen::Vector2d& m,
                        Eigen::Matrix2d* jacobian) {
  const double x = m.x(), y = m.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + p.k1 * r2 + p.k2 * r2 * r2;
  const Eigen::Vector2d d(x * radial + 2.0 * p.p1 * x * y + p.p2 * (r2 + 2.0 * x * x),
                          y * radial + p.p1 * (r2 + 2.0 * y * y) + 2.0 * p.p2 * x * y);
  if (jacobian) {
    const double c = 2.0 * p.k1 + 4.0 * p.k2 * r2;  // d(radial)/dx = c x
    (*jacobian)(0, 0) = radial + c * x * x + 2.0 * p.p1 * y + 6.0 * p.p2 * x;
    (*jacobian)(0, 1) = c * x * y + 2.0 * p.p1 * x + 2.0 * p.p2 * y;
    (*jacobian)(1, 0) = c * x * y + 2.0 * p.p1 * x + 2.0 * p.p2 * y;
    (*jacobian)(1, 1) = radial + c * y * y + 6.0 * p.p1 * y + 2.0 * p.p2 * x;
  }
  return d;
}

}  // namespace

MeiCamera::MeiCamera(const MeiParameters& parameters, int image_width, int image_height,
                     const MirrorAnnulus& annulus)
    : parameters_(parameters) {
  set_image_size(image_width, image_height);
  set_annulus(annulus);
}

std::unique_ptr<CameraModel> MeiCamera::Clone() const {
  return std::make_unique<MeiCamera>(*this);
}

std::vector<std::string> MeiCamera::IntrinsicNames() const {
  return {"xi",
          "fx_px",
          "fy_px",
          "skew_px",
          "cx_px",
          "cy_px",
          "k1",
          "k2",
          "p1",
          "p2",
          "focus_height_m",
          "mount_roll_rad",
          "mount_pitch_rad",
          "mount_yaw_rad"};
}

Eigen::VectorXd MeiCamera::Intrinsics() const {
  const MeiParameters& p = parameters_;
  Eigen::VectorXd v(kNumIntrinsics);
  v << p.xi, p.fx_px, p.fy_px, p.skew, p.cx_px, p.cy_px, p.k1, p.k2, p.p1, p.p2, p.focus_height_m,
      p.mount_roll_rad, p.mount_pitch_rad, p.mount_yaw_rad;
  return v;
}

void MeiCamera::SetIntrinsics(const Eigen::VectorXd& v) {
  if (v.size() != kNumIntrinsics) {
    throw Error("mei camera: expected " + std::to_string(kNumIntrinsics) + " intrinsics, got " +
                std::to_string(v.size()));
  }
  MeiParameters& p = parameters_;
  p.xi = v[0];
  p.fx_px = v[1];
  p.fy_px = v[2];
  p.skew = v[3];
  p.cx_px = v[4];
  p.cy_px = v[5];
  p.k1 = v[6];
  p.k2 = v[7];
  p.p1 = v[8];
  p.p2 = v[9];
  p.focus_height_m = v[10];
  p.mount_roll_rad = v[11];
  p.mount_pitch_rad = v[12];
  p.mount_yaw_rad = v[13];
}

bool MeiCamera::Validate(std::string* why) const {
  if (!CameraModel::Validate(why)) return false;
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (parameters_.xi < 0) return fail("xi must be >= 0");
  if (parameters_.fx_px <= 0 || parameters_.fy_px <= 0)
    return fail("fx_px and fy_px must be positive");
  if (parameters_.focus_height_m <= 0) return fail("focus_height_m must be above the floor (> 0)");
  const MeiParameters& p = parameters_;
  const double angle = bounds::kAngleRad;
  // xi: 0 a pinhole, (0, 1) a hyperbolic, 1 a parabolic mirror, above 1
  // fisheye-like lenses; beyond 3 the model sees less than a hemisphere's
  // third and is no catadioptric camera.
  return CheckIntrinsic("xi", p.xi, 0, kMaxXi, "", why) &&
         CheckIntrinsic("fx_px", p.fx_px, 0, kMaxFocalPx, "px", why) &&
         CheckIntrinsic("fy_px", p.fy_px, 0, kMaxFocalPx, "px", why) &&
         CheckIntrinsic("skew_px", p.skew, -kMaxFocalPx, kMaxFocalPx, "px", why) &&
         CheckIntrinsic("k1", p.k1, -kMaxDistortion, kMaxDistortion, "", why) &&
         CheckIntrinsic("k2", p.k2, -kMaxDistortion, kMaxDistortion, "", why) &&
         CheckIntrinsic("p1", p.p1, -kMaxDistortion, kMaxDistortion, "", why) &&
         CheckIntrinsic("p2", p.p2, -kMaxDistortion, kMaxDistortion, "", why) &&
         CheckIntrinsic("focus_height_m", p.focus_height_m, 0, kMaxHeightM, "m", why) &&
         CheckIntrinsic("mount_roll_rad", p.mount_roll_rad, -angle, angle, "rad", why) &&
         CheckIntrinsic("mount_pitch_rad", p.mount_pitch_rad, -angle, angle, "rad", why) &&
         CheckIntrinsic("mount_yaw_rad", p.mount_yaw_rad, -angle, angle, "rad", why) &&
         CheckPrincipalPoint(p.cx_px, p.cy_px, why);
}

Eigen::Matrix3d MeiCamera::RobotFromMirrorRotation() const {
  const MeiParameters& p = parameters_;
  return (Eigen::AngleAxisd(p.mount_yaw_rad, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(p.mount_pitch_rad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(p.mount_roll_rad, Eigen::Vector3d::UnitX()))
             .toRotationMatrix() *
         Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
}

bool MeiCamera::ProjectMirrorPoint(const Eigen::Vector3d& point, Eigen::Vector2d* pixel,
                                   Eigen::Matrix<double, 2, 3>* jacobian) const {
  const MeiParameters& p = parameters_;
  const double norm = point.norm();
  if (!(norm > 0.0) || !std::isfinite(norm)) return false;
  const Eigen::Vector3d s = point / norm;
  const double limit = p.xi > 1.0 ? 1.0 / p.xi : p.xi;
  if (!(s.z() > -limit + 1e-9)) return false;
  const double denominator = s.z() + p.xi;
  const Eigen::Vector2d m(s.x() / denominator, s.y() / denominator);
  Eigen::Matrix2d d_distorted_d_m;
  const Eigen::Vector2d d = Distort(p, m, jacobian ? &d_distorted_d_m : nullptr);
  *pixel = Eigen::Vector2d(p.fx_px * d.x() + p.skew * d.y() + p.cx_px, p.fy_px * d.y() + p.cy_px);
  if (jacobian) {
    Eigen::Matrix2d k;
    k << p.fx_px, p.skew, 0.0, p.fy_px;
    Eigen::Matrix<double, 2, 3> d_m_d_s;
    d_m_d_s << 1.0 / denominator, 0.0, -s.x() / (denominator * denominator),  //
        0.0, 1.0 / denominator, -s.y() / (denominator * denominator);
    const Eigen::Matrix3d d_s_d_point = (Eigen::Matrix3d::Identity() - s * s.transpose()) / norm;
    *jacobian = k * d_distorted_d_m * d_m_d_s * d_s_d_point;
  }
  return true;
}

bool MeiCamera::BackProjectToMirror(const Eigen::Vector2d& pixel,
                                    Eigen::Vector3d* direction) const {
  const MeiParameters& p = parameters_;
  if (!pixel.allFinite()) return false;
  // Distorted normalised point: invert K.
  const double dy = (pixel.y() - p.cy_px) / p.fy_px;
  const double dx = (pixel.x() - p.cx_px - p.skew * dy) / p.fx_px;
  const Eigen::Vector2d target(dx, dy);
  // Newton on Distort(m) = target, starting at the distorted point.
  Eigen::Vector2d m = target;
  bool converged = false;
  for (int iteration = 0; iteration < 50; ++iteration) {
    Eigen::Matrix2d jacobian;
    const Eigen::Vector2d residual = Distort(p, m, &jacobian) - target;
    if (residual.norm() < 1e-14 * (1.0 + target.norm())) {
      converged = true;
      break;
    }
    const double det = jacobian.determinant();
    if (!(std::abs(det) > 1e-12)) return false;
    m -= jacobian.inverse() * residual;
    if (!m.allFinite()) return false;
  }
  if (!converged) {
    Eigen::Matrix2d unused;
    if ((Distort(p, m, &unused) - target).norm() > 1e-10 * (1.0 + target.norm())) return false;
  }
  const double r2 = m.squaredNorm();
  const double discriminant = 1.0 + (1.0 - p.xi * p.xi) * r2;
  if (discriminant < 0.0) return false;
  const double scale = (p.xi + std::sqrt(discriminant)) / (r2 + 1.0);
  *direction = Eigen::Vector3d(scale * m.x(), scale * m.y(), scale - p.xi).normalized();
  const double limit = p.xi > 1.0 ? 1.0 / p.xi : p.xi;
  return direction->z() > -limit + 1e-9;
}

bool MeiCamera::ProjectToPixel(const Eigen::Vector3d& point_robot, Eigen::Vector2d* pixel,
                               Eigen::Matrix<double, 2, 3>* jacobian) const {
  const Eigen::Matrix3d mirror_from_robot = RobotFromMirrorRotation().transpose();
  const Eigen::Vector3d point_mirror = mirror_from_robot * (point_robot - ViewpointInRobot());
  Eigen::Matrix<double, 2, 3> d_pixel_d_mirror;
  if (!ProjectMirrorPoint(point_mirror, pixel, jacobian ? &d_pixel_d_mirror : nullptr))
    return false;
  if (jacobian) *jacobian = d_pixel_d_mirror * mirror_from_robot;
  return true;
}

bool MeiCamera::BackProjectPixel(const Eigen::Vector2d& pixel, Ray* ray) const {
  Eigen::Vector3d direction_mirror;
  if (!BackProjectToMirror(pixel, &direction_mirror)) return false;
  ray->origin_robot = ViewpointInRobot();
  ray->direction_robot = (RobotFromMirrorRotation() * direction_mirror).normalized();
  return true;
}

}  // namespace oslam

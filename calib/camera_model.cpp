#include "calib/camera_model.h"

#include <cmath>
#include <string>

#include "core/angles.h"
#include "core/bounds.h"

namespace oslam {

bool CameraModel::Validate(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (image_width_ <= 0 || image_height_ <= 0) return fail("image size must be positive");
  // Per-pixel tables (polar coordinates, masks) are made at this size.
  if (image_width_ > bounds::kImageSidePx || image_height_ > bounds::kImageSidePx ||
      static_cast<long>(image_width_) * image_height_ > bounds::kImagePixels)
    return fail("image size " + std::to_string(image_width_) + "x" + std::to_string(image_height_) +
                " is beyond the image bounds (at most " + std::to_string(bounds::kImageSidePx) +
                " per side and " + std::to_string(bounds::kImagePixels / 1000000) +
                " million pixels; docs/formats.md, Bounds)");
  if (!std::isfinite(annulus_.blind_radius_px) || !std::isfinite(annulus_.rim_radius_px) ||
      annulus_.blind_radius_px < 0 || annulus_.rim_radius_px <= annulus_.blind_radius_px) {
    return fail("mirror annulus needs 0 <= blind_radius_px < rim_radius_px");
  }
  if (annulus_.rim_radius_px > bounds::kImageRadiusPx)
    return fail("rim_radius_px: " +
                bounds::OutsideMessage(annulus_.rim_radius_px, 0, bounds::kImageRadiusPx, "px"));
  if (!Intrinsics().allFinite()) return fail("intrinsics contain NaN or infinity");
  return true;
}

bool CameraModel::CheckIntrinsic(const std::string& name, double value, double low, double high,
                                 const std::string& unit, std::string* why) {
  if (bounds::Within(value, low, high)) return true;
  if (why) *why = name + ": " + bounds::OutsideMessage(value, low, high, unit);
  return false;
}

bool CameraModel::CheckPrincipalPoint(double x_px, double y_px, std::string* why) const {
  // Within the image, give or take one image size (a decentred mirror).
  return CheckIntrinsic("principal point x", x_px, -image_width_, 2.0 * image_width_, "px", why) &&
         CheckIntrinsic("principal point y", y_px, -image_height_, 2.0 * image_height_, "px", why);
}

bool CameraModel::ProjectToPolar(const Eigen::Vector3d& point_robot, PolarPoint* polar,
                                 Eigen::Matrix<double, 2, 3>* jacobian) const {
  Eigen::Vector2d pixel;
  Eigen::Matrix<double, 2, 3> pixel_jacobian;
  if (!ProjectToPixel(point_robot, &pixel, jacobian ? &pixel_jacobian : nullptr)) return false;
  *polar = PixelToPolar(pixel);
  if (jacobian) *jacobian = PolarJacobianWrtPixel(pixel) * pixel_jacobian;
  return true;
}

bool CameraModel::ProjectRadius(const Eigen::Vector3d& point_robot, double* radius_px,
                                Eigen::RowVector3d* jacobian) const {
  PolarPoint polar;
  Eigen::Matrix<double, 2, 3> polar_jacobian;
  if (!ProjectToPolar(point_robot, &polar, jacobian ? &polar_jacobian : nullptr)) return false;
  *radius_px = polar.radius_px;
  if (jacobian) *jacobian = polar_jacobian.row(0);
  return true;
}

PolarPoint CameraModel::PixelToPolar(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d offset = pixel - ImageCenter();
  return {offset.norm(), std::atan2(offset.y(), offset.x())};
}

Eigen::Vector2d CameraModel::PolarToPixel(const PolarPoint& polar) const {
  return ImageCenter() +
         polar.radius_px * Eigen::Vector2d(std::cos(polar.angle_rad), std::sin(polar.angle_rad));
}

Eigen::Matrix2d CameraModel::PolarJacobianWrtPixel(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d offset = pixel - ImageCenter();
  const double radius_sq = offset.squaredNorm();
  const double radius = std::sqrt(radius_sq);
  Eigen::Matrix2d jacobian;
  if (radius == 0.0) return Eigen::Matrix2d::Zero();     // the angle is undefined at the centre
  jacobian << offset.x() / radius, offset.y() / radius,  //
      -offset.y() / radius_sq, offset.x() / radius_sq;
  return jacobian;
}

bool CameraModel::IsInAnnulus(const Eigen::Vector2d& pixel) const {
  if (pixel.x() < -0.5 || pixel.y() < -0.5 || pixel.x() > image_width_ - 0.5 ||
      pixel.y() > image_height_ - 0.5) {
    return false;
  }
  const double radius = (pixel - ImageCenter()).norm();
  return radius >= annulus_.blind_radius_px && radius <= annulus_.rim_radius_px;
}

}  // namespace oslam

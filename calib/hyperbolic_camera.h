// Central catadioptric camera with a hyperbolic mirror (docs/method.md §4.3, after
// Zivkovic & Booij 2005): the mirror's outer focus is at height z_m on the
// robot's vertical axis, the lens centre at the second focus below it, the
// camera looking up.
//
//   T(r, z) = (f/c) b^2 r / (2 a e sqrt(r^2 + w^2) - (a^2 + e^2) w),  w = z - z_m
//
// is the image radius of a point at horizontal range r and height z. The image
// angle is angle_offset + s * bearing, with s = -1 when the image is mirrored
// (flip_image_angle) and bearing = atan2(y, x) in the robot frame.
#pragma once

#include "calib/camera_model.h"

namespace oslam {

struct HyperbolicMirrorParameters {
  double mirror_a_m = 0.0;      // semi-major axis a
  double mirror_b_m = 0.0;      // semi-minor axis b
  double focus_height_m = 0.0;  // z_m: outer mirror focus above the floor
  double focal_px = 0.0;        // f/c
  double center_x_px = 0.0;
  double center_y_px = 0.0;
  double angle_offset_rad = 0.0;
  bool flip_image_angle = false;
};

class HyperbolicCamera final : public CameraModel {
 public:
  static constexpr const char* kModelName = "hyperbolic";

  HyperbolicCamera() = default;
  HyperbolicCamera(const HyperbolicMirrorParameters& parameters, int image_width, int image_height,
                   const MirrorAnnulus& annulus);

  // The two rigs of the thesis (docs/method.md §4.3 table): "lpa", "cogniron". Image
  // size and annulus are our guesses (see docs/formats.md). Throws
  // oslam::Error for an unknown name.
  static HyperbolicCamera Preset(const std::string& name);
  static std::vector<std::string> PresetNames();

  std::string ModelName() const override { return kModelName; }
  std::unique_ptr<CameraModel> Clone() const override;
  std::vector<std::string> IntrinsicNames() const override;
  Eigen::VectorXd Intrinsics() const override;
  void SetIntrinsics(const Eigen::VectorXd& intrinsics) override;
  bool Validate(std::string* why) const override;
  Eigen::Vector2d ImageCenter() const override {
    return {parameters_.center_x_px, parameters_.center_y_px};
  }

  bool ProjectToPixel(const Eigen::Vector3d& point_robot, Eigen::Vector2d* pixel,
                      Eigen::Matrix<double, 2, 3>* jacobian = nullptr) const override;
  bool ProjectToPolar(const Eigen::Vector3d& point_robot, PolarPoint* polar,
                      Eigen::Matrix<double, 2, 3>* jacobian = nullptr) const override;
  bool ProjectRadius(const Eigen::Vector3d& point_robot, double* radius_px,
                     Eigen::RowVector3d* jacobian = nullptr) const override;
  bool BackProjectPixel(const Eigen::Vector2d& pixel, Ray* ray) const override;

  // T(r, z) and its partial derivatives. Returns false when the ray from the
  // mirror focus towards (r, z) misses the mirror (elevation >= asin(a/e)).
  bool ImageRadius(double range_m, double height_m, double* radius_px,
                   double* d_radius_d_range = nullptr, double* d_radius_d_height = nullptr) const;
  // Inverse of T along a ray from the mirror focus: the elevation angle (rad,
  // 0 = horizontal, negative = down) imaged at `radius_px`, and
  // d(elevation)/d(radius).
  double ElevationOfRadius(double radius_px, double* d_elevation_d_radius = nullptr) const;
  // Image radius of the horizon (elevation 0), (f/c) b^2 / (2 a e).
  double HorizonRadius() const;
  double Eccentricity() const;  // e = sqrt(a^2 + b^2)

  const HyperbolicMirrorParameters& parameters() const { return parameters_; }
  void set_parameters(const HyperbolicMirrorParameters& parameters) { parameters_ = parameters; }

 private:
  double ImageAngleOfBearing(double bearing_rad) const;
  double BearingOfImageAngle(double image_angle_rad) const;
  double AngleSign() const { return parameters_.flip_image_angle ? -1.0 : 1.0; }

  HyperbolicMirrorParameters parameters_;
};

}  // namespace oslam

// Mei's unified model of central catadioptric cameras (Mei & Rives, ICRA
// 2007), parameter-compatible with OpenCV's cv::omnidir (ξ, K with skew,
// D = k1 k2 p1 p2):
//
//   mirror frame: origin at the mirror's single effective viewpoint, z axis
//   along the mirror axis pointing towards the camera (the image centre sees
//   +z), x and y along the image's x and y.
//   Xs = X / |X|                                   (point on the unit sphere)
//   m  = (Xs.x, Xs.y) / (Xs.z + ξ)                 (normalised plane)
//   r² = |m|²,  radial = 1 + k1 r² + k2 r⁴
//   d  = m radial + (2 p1 mx my + p2 (r² + 2 mx²),  p1 (r² + 2 my²) + 2 p2 mx my)
//   u  = fx d.x + skew d.y + cx,  v = fy d.y + cy
//
// A point is imaged when Xs.z > -min(ξ, 1/ξ) (for ξ > 1 the sphere points
// beyond -1/ξ fold back and are hidden by the mirror).
//
// Mount (robot frame: x forward, y left, z up): the viewpoint is on the
// robot's vertical axis at focus_height_m above the floor, and
//   R_robot_from_mirror = Rz(mount_yaw) Ry(mount_pitch) Rx(mount_roll) Rx(pi),
// so with zero angles the mirror axis points straight down to the camera below
// the mirror (the usual upward-looking rig), the image's x axis is the robot's
// forward direction and the image is mirrored (image angle = -bearing). Small
// roll/pitch model a tilted axis; yaw turns the image about the axis.
//
// Back-projection inverts the distortion with Newton iterations on the 2x2
// distortion map (converges to < 1e-12 on the normalised plane for the mild
// distortion of real mirrors; fails, returning false, when the distortion is
// not invertible there), then lifts m onto the sphere in closed form:
//   Xs = (ξ + sqrt(1 + (1 - ξ²) r²)) / (r² + 1) (mx, my, 1) - (0, 0, ξ).
#pragma once

#include "calib/camera_model.h"

namespace oslam {

struct MeiParameters {
  double xi = 1.0;
  double fx_px = 0.0;
  double fy_px = 0.0;
  double skew = 0.0;  // K(0,1), pixels
  double cx_px = 0.0;
  double cy_px = 0.0;
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0;
  // Mount in the robot frame.
  double focus_height_m = 1.0;
  double mount_roll_rad = 0.0;
  double mount_pitch_rad = 0.0;
  double mount_yaw_rad = 0.0;
};

class MeiCamera final : public CameraModel {
 public:
  static constexpr const char* kModelName = "mei";
  static constexpr int kNumIntrinsics = 14;

  MeiCamera() = default;
  MeiCamera(const MeiParameters& parameters, int image_width, int image_height,
            const MirrorAnnulus& annulus);

  std::string ModelName() const override { return kModelName; }
  std::unique_ptr<CameraModel> Clone() const override;
  // xi, fx_px, fy_px, skew_px, cx_px, cy_px, k1, k2, p1, p2, focus_height_m,
  // mount_roll_rad, mount_pitch_rad, mount_yaw_rad.
  std::vector<std::string> IntrinsicNames() const override;
  Eigen::VectorXd Intrinsics() const override;
  void SetIntrinsics(const Eigen::VectorXd& intrinsics) override;
  bool Validate(std::string* why) const override;
  Eigen::Vector2d ImageCenter() const override { return {parameters_.cx_px, parameters_.cy_px}; }

  bool ProjectToPixel(const Eigen::Vector3d& point_robot, Eigen::Vector2d* pixel,
                      Eigen::Matrix<double, 2, 3>* jacobian = nullptr) const override;
  bool BackProjectPixel(const Eigen::Vector2d& pixel, Ray* ray) const override;

  // The same in the mirror frame (used by calibration, where board poses are
  // expressed in the mirror frame). Jacobian is d(pixel)/d(point_mirror).
  bool ProjectMirrorPoint(const Eigen::Vector3d& point_mirror, Eigen::Vector2d* pixel,
                          Eigen::Matrix<double, 2, 3>* jacobian = nullptr) const;
  // Unit direction in the mirror frame imaged at `pixel`.
  bool BackProjectToMirror(const Eigen::Vector2d& pixel, Eigen::Vector3d* direction_mirror) const;

  Eigen::Matrix3d RobotFromMirrorRotation() const;
  Eigen::Vector3d ViewpointInRobot() const { return {0.0, 0.0, parameters_.focus_height_m}; }

  const MeiParameters& parameters() const { return parameters_; }
  void set_parameters(const MeiParameters& parameters) { parameters_ = parameters; }

 private:
  MeiParameters parameters_;
};

}  // namespace oslam

// The factors of geometric O-SLAM (docs/method.md §5.1): odometry, bounding-slice
// observation, and the class priors on object size and location.
#pragma once

#include <memory>
#include <string>

#include <Eigen/Core>

#include "calib/camera_model.h"
#include "calib/observation_model.h"
#include "core/bounding_slice.h"
#include "core/motion_model.h"
#include "solver/factor.h"

namespace oslam {

// x_i = f(x_{i-1}, v_i) + e, e ~ N(0, Q_i) (docs/method.md §4.1). The error is taken in
// the frame of the midpoint heading alpha = theta_{i-1} + v^phi/2,
//
//   e = diag(sigma)^{-1} Rot(alpha)^T (f(x_{i-1}, v_i) - x_i)   (heading wrapped),
//
// which is the Gaussian with Q_i = Rot(alpha) diag(sigma^2) Rot(alpha)^T of
// docs/method.md §4.1 with its dependence on theta_{i-1} kept exactly (its
// determinant does not depend on alpha). With options.world_frame the
// rotation is dropped. Keys: (pose i-1, pose i).
class OdometryFactor final : public Factor {
 public:
  OdometryFactor(int previous_pose_key, int pose_key, const OdometryIncrement& increment,
                 const MotionNoiseOptions& options);

  int Dimension() const override { return 3; }
  bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                 Eigen::MatrixXd* jacobian) const override;
  double LogDetCovariance() const override { return log_det_; }
  std::string Name() const override { return "odometry"; }

  const OdometryIncrement& increment() const { return increment_; }

 private:
  OdometryIncrement increment_;
  Eigen::Vector3d inverse_sigma_;  // robot-frame (forward, lateral, heading)
  bool world_frame_;
  double log_det_;
};

// A detection's bounding slice z = (u_r, u_phi, s_r, s_phi) of the object with
// base point l and cylinder g = (d, h), seen from pose x (docs/method.md §4.2):
// z = (h^u(x, l), h^s(x, l, g)) + noise, with R = diag(E^2, (E/u_r)^2) on u and
// W = 2R on s, u_r the *measured* radius. The u_phi residual is wrapped.
// Keys: (pose, base point, cylinder). The camera must outlive the factor.
//
// Beyond the thesis (docs/method.md §4.2): with `model` the prediction is the
// class's silhouette, and a slice end cut by the image's limits
// (CensoringOf) is a one-sided bound: a censored outer end gives the residual
// min(0, predicted - measured outer radius u_r + s_r) in place of the s_r
// row, a censored inner end max(0, predicted - measured u_r) in the u_r row
// (and the s_r row then compares the outer ends).
// A panel's silhouette (SilhouetteModel::panel) also depends on its
// orientation: `yaw_key` is then a 1-D variable, the panel's yaw (rad), the
// fourth key; it must be given for a panel and only for one (throws).
class BoundingSliceFactor final : public Factor {
 public:
  BoundingSliceFactor(const CameraModel* camera, int pose_key, int base_key, int size_key,
                      const BoundingSlice& measured, double pixel_std_px,
                      const SliceModel& model = {}, int yaw_key = -1);

  int Dimension() const override { return 4; }
  bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                 Eigen::MatrixXd* jacobian) const override;
  double LogDetCovariance() const override { return log_det_; }
  std::string Name() const override { return "bounding slice"; }

  const BoundingSlice& measured() const { return measured_; }

  // The model's pieces, for code that fits one object outside a graph
  // (object initialisation): the noise sigmas (E, E/u_r, sqrt(2)E,
  // sqrt(2)E/u_r) and the unwhitened residual, u_phi wrapped.
  // With `bearing_std_px` > 0 the u_phi row's is bearing_std_px / u_r
  // (SliceModel::bearing_noise_px).
  static Eigen::Vector4d NoiseSigma(const BoundingSlice& measured, double pixel_std_px,
                                    double bearing_std_px = 0.0);
  static Eigen::Vector4d Residual(const BoundingSlice& predicted, const BoundingSlice& measured);
  // The residual with censored ends applied (see the class comment); when
  // `jacobians` is given its rows are changed to match.
  static Eigen::Vector4d CensoredResidual(const BoundingSlice& predicted,
                                          const BoundingSlice& measured,
                                          const SliceCensoring& censoring,
                                          SliceJacobians* jacobians);

  const SliceCensoring& censoring() const { return censoring_; }

 private:
  const CameraModel* camera_;
  BoundingSlice measured_;
  SilhouetteModel silhouette_;
  SliceCensoring censoring_;
  Eigen::Vector4d inverse_sigma_;
  double log_det_;
};

// A Gaussian prior x ~ N(mean, covariance) on one variable: the class prior on
// size, g_j ~ N(varsigma(c), Sigma(c)), and on location, l_j ~ N(gamma(c),
// Gamma(c)) (docs/method.md §5.1). If the variable has an angle component, that
// residual is wrapped.
class PriorFactor final : public Factor {
 public:
  // Throws oslam::Error unless covariance is symmetric positive definite and
  // the sizes agree.
  PriorFactor(int key, const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance,
              std::string name = "prior");

  int Dimension() const override { return static_cast<int>(mean_.size()); }
  bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                 Eigen::MatrixXd* jacobian) const override;
  double LogDetCovariance() const override { return log_det_; }
  std::string Name() const override { return name_; }

 private:
  Eigen::VectorXd mean_;
  Eigen::MatrixXd sqrt_information_;  // L^{-1}
  double log_det_;
  std::string name_;
};

// A panel's orientation prior (docs/method.md §4.2, "Panels"): flat over its
// period pi, the density 1/pi. The Gaussian factor's residual is the yaw
// wrapped to (-pi/2, pi/2] over kPanelYawPriorStd, a regulariser that keeps
// J'J definite when the views leave the yaw free (at most 0.012 nats), and
// its log |P| is chosen so that its normaliser is the flat prior's:
// -log|P|/2 - log(2 pi)/2 = -log(pi).
inline constexpr double kPanelYawPriorStd = 10.0;  // rad
class PanelYawPrior final : public Factor {
 public:
  explicit PanelYawPrior(int yaw_key) : Factor({yaw_key}) {}

  int Dimension() const override { return 1; }
  bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                 Eigen::MatrixXd* jacobian) const override;
  double LogDetCovariance() const override { return kLogDet; }
  std::string Name() const override { return "panel yaw prior"; }

  // The whitened residual at `yaw_rad`.
  static double Error(double yaw_rad);
  static constexpr double kLogDet = 0.45158270528945486;  // log(pi / 2)
};

// Diagonal-covariance helpers for the two class priors.
std::unique_ptr<PriorFactor> MakeSizePrior(int size_key, const Eigen::Vector2d& mean_m,
                                           const Eigen::Vector2d& std_m);
std::unique_ptr<PriorFactor> MakeLocationPrior(int base_key, const Eigen::Vector3d& mean_m,
                                               const Eigen::Vector3d& std_m);

}  // namespace oslam

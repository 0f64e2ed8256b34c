#include "slam/factors.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Cholesky>

#include "calib/observation_model.h"
#include "core/angles.h"
#include "core/error.h"

namespace oslam {

namespace {

// Planar pose stored in Values as (x, y, theta).
Pose2 PoseOf(const Values& values, int key) {
  const double* p = values.Data(key);
  return {p[0], p[1], p[2]};
}

}  // namespace

// ---------------------------------------------------------------------------

OdometryFactor::OdometryFactor(int previous_pose_key, int pose_key,
                               const OdometryIncrement& increment,
                               const MotionNoiseOptions& options)
    : Factor({previous_pose_key, pose_key}),
      increment_(increment),
      world_frame_(options.world_frame) {
  // The robot-frame diagonal; the rotation is applied in Linearize.
  MotionNoiseOptions robot_frame = options;
  robot_frame.world_frame = true;
  const Eigen::Vector3d variances = MotionCovariance(0.0, increment, robot_frame).diagonal();
  if (!(variances.minCoeff() > 0.0)) throw Error("odometry noise must be positive");
  inverse_sigma_ = variances.cwiseSqrt().cwiseInverse();
  log_det_ = variances.array().log().sum();
}

bool OdometryFactor::Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                               Eigen::MatrixXd* jacobian) const {
  const Pose2 previous = PoseOf(values, keys()[0]);
  const Pose2 current = PoseOf(values, keys()[1]);
  Eigen::Matrix3d f_wrt_previous;
  const Pose2 predicted = ApplyIncrement(previous, increment_, &f_wrt_previous);
  const Eigen::Vector3d delta(predicted.x - current.x, predicted.y - current.y,
                              WrapAngle(predicted.theta - current.theta));

  Eigen::Matrix3d rotation_t = Eigen::Matrix3d::Identity();  // Rot(alpha)^T
  Eigen::Matrix3d d_rotation_t = Eigen::Matrix3d::Zero();    // d Rot(alpha)^T / d alpha
  if (!world_frame_) {
    const double alpha = previous.theta + 0.5 * increment_.turn_rad;
    const double c = std::cos(alpha), s = std::sin(alpha);
    rotation_t.topLeftCorner<2, 2>() << c, s, -s, c;
    d_rotation_t.topLeftCorner<2, 2>() << -s, c, -c, -s;
  }
  error = inverse_sigma_.asDiagonal() * (rotation_t * delta);
  if (!jacobian) return true;
  // alpha moves with theta_{i-1} one to one.
  Eigen::Matrix3d wrt_previous = rotation_t * f_wrt_previous;
  wrt_previous.col(2) += d_rotation_t * delta;
  jacobian->leftCols<3>() = inverse_sigma_.asDiagonal() * wrt_previous;
  jacobian->rightCols<3>() = -(inverse_sigma_.asDiagonal() * rotation_t);
  return true;
}

// ---------------------------------------------------------------------------

BoundingSliceFactor::BoundingSliceFactor(const CameraModel* camera, int pose_key, int base_key,
                                         int size_key, const BoundingSlice& measured,
                                         double pixel_std_px, const SliceModel& model, int yaw_key)
    : Factor(yaw_key >= 0 ? std::vector<int>{pose_key, base_key, size_key, yaw_key}
                          : std::vector<int>{pose_key, base_key, size_key}),
      camera_(camera),
      measured_(measured),
      silhouette_(model.silhouette) {
  if (!camera) throw Error("BoundingSliceFactor needs a camera");
  if ((yaw_key >= 0) != (model.silhouette.enabled && model.silhouette.panel))
    throw Error("BoundingSliceFactor: a panel's silhouette needs its yaw, and only a panel's");
  if (!(pixel_std_px > 0.0) || !std::isfinite(pixel_std_px))
    throw Error("the pixel noise E must be positive");
  if (!(measured.u_r_px > 0.0) || !std::isfinite(measured.u_r_px))
    throw Error("a bounding slice needs a positive radius u_r");
  if (model.censor_at_image_limits)
    censoring_ = CensoringOf(*camera, measured, model.censor_margin_px);
  if (!(model.bearing_noise_px >= 0.0) || !std::isfinite(model.bearing_noise_px))
    throw Error("the bearing noise must be >= 0 px");
  const Eigen::Vector4d sigma = NoiseSigma(measured, pixel_std_px, model.bearing_noise_px);
  inverse_sigma_ = sigma.cwiseInverse();
  // log |R| |W| = 2 sum log sigma, sigma = (E, E_phi/u_r, sqrt2 E, sqrt2 E/u_r),
  // with few logs (O-SLAM builds these per proposal).
  const double bearing = model.bearing_noise_px > 0.0 ? model.bearing_noise_px : pixel_std_px;
  log_det_ = 6.0 * std::log(pixel_std_px) + 2.0 * std::log(bearing) + 2.0 * std::log(2.0) -
             4.0 * std::log(measured.u_r_px);
}

Eigen::Vector4d BoundingSliceFactor::NoiseSigma(const BoundingSlice& measured, double pixel_std_px,
                                                double bearing_std_px) {
  // sigma of (u_r, u_phi, s_r, s_phi): R = diag(E^2, (E/u_r)^2), W = 2R.
  const double e = pixel_std_px, sqrt2 = std::sqrt(2.0);
  const double bearing = bearing_std_px > 0.0 ? bearing_std_px : e;
  return {e, bearing / measured.u_r_px, sqrt2 * e, sqrt2 * e / measured.u_r_px};
}

Eigen::Vector4d BoundingSliceFactor::Residual(const BoundingSlice& predicted,
                                              const BoundingSlice& measured) {
  return {predicted.u_r_px - measured.u_r_px, WrapAngle(predicted.u_phi_rad - measured.u_phi_rad),
          predicted.s_r_px - measured.s_r_px, predicted.s_phi_rad - measured.s_phi_rad};
}

Eigen::Vector4d BoundingSliceFactor::CensoredResidual(const BoundingSlice& predicted,
                                                      const BoundingSlice& measured,
                                                      const SliceCensoring& censoring,
                                                      SliceJacobians* jacobians) {
  Eigen::Vector4d residual = Residual(predicted, measured);
  if (!censoring.inner && !censoring.outer) return residual;
  // Rows 0 and 2 of every Jacobian block, changed together.
  auto rows = [jacobians](auto&& change) {
    if (!jacobians) return;
    change(jacobians->wrt_pose);
    change(jacobians->wrt_base);
    change(jacobians->wrt_size);
    change(jacobians->wrt_yaw);
  };
  const double inner = residual[0];
  const double outer = residual[0] + residual[2];  // predicted - measured outer radius
  // Row 2 compares the outer ends once either end is a bound (the measured
  // s_r is then not a length); a censored outer end is a lower bound on the
  // true outer radius, a censored inner end an upper bound on the inner.
  residual[2] = censoring.outer ? std::min(0.0, outer) : outer;
  const bool outer_free = censoring.outer && outer >= 0.0;
  rows([outer_free](auto& j) {
    if (outer_free)
      j.row(2).setZero();
    else
      j.row(2) += j.row(0);
  });
  if (censoring.inner) {
    residual[0] = std::max(0.0, inner);
    if (inner <= 0.0) rows([](auto& j) { j.row(0).setZero(); });
  }
  return residual;
}

bool BoundingSliceFactor::Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                                    Eigen::MatrixXd* jacobian) const {
  const Pose2 pose = PoseOf(values, keys()[0]);
  CylinderGeometry object;
  object.base_world = Eigen::Map<const Eigen::Vector3d>(values.Data(keys()[1]));
  object.diameter_m = values.Data(keys()[2])[0];
  object.height_m = values.Data(keys()[2])[1];
  const bool has_yaw = keys().size() == 4;
  if (has_yaw) object.yaw_rad = values.Data(keys()[3])[0];
  BoundingSlice predicted;
  SliceJacobians jacobians;
  // A censored outer end is satisfied by a top beyond the mirror's view.
  bool beyond = false;
  if (!PredictSlice(*camera_, pose, object, &predicted, jacobian ? &jacobians : nullptr,
                    silhouette_, censoring_.outer ? &beyond : nullptr))
    return false;
  error = inverse_sigma_.cwiseProduct(
      CensoredResidual(predicted, measured_, censoring_, jacobian ? &jacobians : nullptr));
  if (!jacobian) return true;
  jacobian->leftCols<3>() = inverse_sigma_.asDiagonal() * jacobians.wrt_pose;
  jacobian->middleCols<3>(3) = inverse_sigma_.asDiagonal() * jacobians.wrt_base;
  jacobian->middleCols<2>(6) = inverse_sigma_.asDiagonal() * jacobians.wrt_size;
  if (has_yaw) jacobian->col(8) = inverse_sigma_.cwiseProduct(jacobians.wrt_yaw);
  return true;
}

// ---------------------------------------------------------------------------

PriorFactor::PriorFactor(int key, const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance,
                         std::string name)
    : Factor({key}), mean_(mean), name_(std::move(name)) {
  if (covariance.rows() != mean.size() || covariance.cols() != mean.size() || mean.size() == 0)
    throw Error(name_ + ": the covariance must be square and match the mean");
  if (!covariance.allFinite() || !mean.allFinite())
    throw Error(name_ + ": mean and covariance must be finite");
  const Eigen::LLT<Eigen::MatrixXd> llt(covariance);
  if (llt.info() != Eigen::Success || !(llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0))
    throw Error(name_ + ": the covariance must be positive definite (a proper prior)");
  const Eigen::MatrixXd l = llt.matrixL();
  sqrt_information_ =
      l.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(mean.size(), mean.size()));
  log_det_ = 2.0 * l.diagonal().array().log().sum();
}

bool PriorFactor::Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                            Eigen::MatrixXd* jacobian) const {
  const int key = keys()[0];
  if (values.Dim(key) != mean_.size()) return false;
  Eigen::VectorXd difference = values.Get(key) - mean_;
  const int angle = values.AngleIndex(key);
  if (angle >= 0) difference[angle] = WrapAngle(difference[angle]);
  error = sqrt_information_ * difference;
  if (jacobian) *jacobian = sqrt_information_;
  return true;
}

double PanelYawPrior::Error(double yaw_rad) {
  // The yaw modulo pi, in (-pi/2, pi/2].
  return 0.5 * WrapAngle(2.0 * yaw_rad) / kPanelYawPriorStd;
}

bool PanelYawPrior::Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                              Eigen::MatrixXd* jacobian) const {
  if (values.Dim(keys()[0]) != 1) return false;
  error[0] = Error(values.Data(keys()[0])[0]);
  if (jacobian) (*jacobian)(0, 0) = 1.0 / kPanelYawPriorStd;
  return true;
}

std::unique_ptr<PriorFactor> MakeSizePrior(int size_key, const Eigen::Vector2d& mean_m,
                                           const Eigen::Vector2d& std_m) {
  return std::make_unique<PriorFactor>(
      size_key, mean_m, Eigen::Matrix2d(std_m.cwiseAbs2().asDiagonal()), "size prior");
}

std::unique_ptr<PriorFactor> MakeLocationPrior(int base_key, const Eigen::Vector3d& mean_m,
                                               const Eigen::Vector3d& std_m) {
  return std::make_unique<PriorFactor>(
      base_key, mean_m, Eigen::Matrix3d(std_m.cwiseAbs2().asDiagonal()), "location prior");
}

}  // namespace oslam

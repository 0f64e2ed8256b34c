#include "slam/landmark_factors.h"

#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "core/angles.h"
#include "core/error.h"

namespace oslam {

namespace {

Pose2 PoseOf(const Values& values, int key) {
  const double* p = values.Data(key);
  return {p[0], p[1], p[2]};
}

}  // namespace

// ---------------------------------------------------------------------------

RangeBearingFactor::RangeBearingFactor(int pose_key, int landmark_key, double range_m,
                                       double bearing_rad, double range_std_m,
                                       double bearing_std_rad,
                                       const Eigen::Vector2d& mount_offset_m)
    : Factor({pose_key, landmark_key}),
      range_m_(range_m),
      bearing_rad_(WrapAngle(bearing_rad)),
      mount_offset_m_(mount_offset_m) {
  if (!std::isfinite(range_m) || range_m < 0.0)
    throw Error("range-bearing factor: the range must be finite and >= 0");
  if (!std::isfinite(bearing_rad)) throw Error("range-bearing factor: the bearing must be finite");
  if (!(range_std_m > 0.0) || !std::isfinite(range_std_m) || !(bearing_std_rad > 0.0) ||
      !std::isfinite(bearing_std_rad))
    throw Error("range-bearing factor: the range and bearing noise must be positive");
  if (!mount_offset_m.allFinite())
    throw Error("range-bearing factor: the sensor mount offset must be finite");
  inverse_sigma_ = Eigen::Vector2d(1.0 / range_std_m, 1.0 / bearing_std_rad);
  log_det_ = 2.0 * (std::log(range_std_m) + std::log(bearing_std_rad));
}

bool RangeBearingFactor::Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                                   Eigen::MatrixXd* jacobian) const {
  const Pose2 pose = PoseOf(values, keys()[0]);
  const double* landmark = values.Data(keys()[1]);
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double mx = mount_offset_m_.x(), my = mount_offset_m_.y();
  const double dx = landmark[0] - (pose.x + c * mx - s * my);
  const double dy = landmark[1] - (pose.y + s * mx + c * my);
  const double range_sq = dx * dx + dy * dy;
  if (!(range_sq > 0.0) || !std::isfinite(range_sq)) return false;
  const double range = std::sqrt(range_sq);
  error[0] = inverse_sigma_[0] * (range - range_m_);
  error[1] = inverse_sigma_[1] * WrapAngle(std::atan2(dy, dx) - pose.theta - bearing_rad_);
  if (!jacobian) return true;
  // d(d)/d(pose) = [-I, -dRot/dtheta mount]; d(d)/d(landmark) = I.
  const double ddx_dtheta = s * mx + c * my, ddy_dtheta = -c * mx + s * my;
  const Eigen::RowVector2d range_wrt_d(dx / range, dy / range);
  const Eigen::RowVector2d bearing_wrt_d(-dy / range_sq, dx / range_sq);
  Eigen::MatrixXd& j = *jacobian;
  j(0, 0) = -range_wrt_d[0];
  j(0, 1) = -range_wrt_d[1];
  j(0, 2) = range_wrt_d[0] * ddx_dtheta + range_wrt_d[1] * ddy_dtheta;
  j(1, 0) = -bearing_wrt_d[0];
  j(1, 1) = -bearing_wrt_d[1];
  j(1, 2) = bearing_wrt_d[0] * ddx_dtheta + bearing_wrt_d[1] * ddy_dtheta - 1.0;
  j.block<1, 2>(0, 3) = range_wrt_d;
  j.block<1, 2>(1, 3) = bearing_wrt_d;
  j.row(0) *= inverse_sigma_[0];
  j.row(1) *= inverse_sigma_[1];
  return true;
}

Eigen::Vector2d LandmarkFromRangeBearing(const Pose2& pose, double range_m, double bearing_rad,
                                         const Eigen::Vector2d& mount_offset_m) {
  const Eigen::Vector3d sensor =
      pose.RobotToWorld(Eigen::Vector3d(mount_offset_m.x(), mount_offset_m.y(), 0.0));
  const double heading = pose.theta + bearing_rad;
  return {sensor.x() + range_m * std::cos(heading), sensor.y() + range_m * std::sin(heading)};
}

PointSightingFactor::PointSightingFactor(int pose_key, int landmark_key,
                                         const Eigen::Vector2d& measured_m,
                                         const Eigen::Matrix2d& covariance,
                                         const Eigen::Vector2d& mount_offset_m)
    : Factor({pose_key, landmark_key}), measured_m_(measured_m), mount_offset_m_(mount_offset_m) {
  if (!measured_m.allFinite() || !mount_offset_m.allFinite())
    throw Error("point sighting factor: the measurement and the mount offset must be finite");
  if (!covariance.allFinite() || !covariance.isApprox(covariance.transpose(), 1e-9))
    throw Error("point sighting factor: the covariance must be finite and symmetric");
  const Eigen::LLT<Eigen::Matrix2d> llt(covariance);
  if (llt.info() != Eigen::Success || !(llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0))
    throw Error("point sighting factor: the covariance must be positive definite");
  const Eigen::Matrix2d l = llt.matrixL();
  sqrt_information_ = l.triangularView<Eigen::Lower>().solve(Eigen::Matrix2d::Identity());
  log_det_ = 2.0 * l.diagonal().array().log().sum();
}

bool PointSightingFactor::Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                                    Eigen::MatrixXd* jacobian) const {
  const Pose2 pose = PoseOf(values, keys()[0]);
  const double* landmark = values.Data(keys()[1]);
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double dx = landmark[0] - pose.x, dy = landmark[1] - pose.y;
  const Eigen::Vector2d h(c * dx + s * dy - mount_offset_m_.x(),
                          -s * dx + c * dy - mount_offset_m_.y());
  error = sqrt_information_ * (h - measured_m_);
  if (!jacobian) return true;
  Eigen::Matrix<double, 2, 5> j;
  j << -c, -s, -s * dx + c * dy, c, s,  //
      s, -c, -c * dx - s * dy, -s, c;
  *jacobian = sqrt_information_ * j;
  return true;
}

void AddSightingFactor(FactorGraph* graph, int pose_key, int landmark_key,
                       const LandmarkSighting& s, const Eigen::Vector2d& mount_offset_m) {
  if (s.cartesian)
    graph->Emplace<PointSightingFactor>(
        pose_key, landmark_key,
        Eigen::Vector2d(s.range_m * std::cos(s.bearing_rad), s.range_m * std::sin(s.bearing_rad)),
        s.xy_covariance, mount_offset_m);
  else
    graph->Emplace<RangeBearingFactor>(pose_key, landmark_key, s.range_m, s.bearing_rad,
                                       s.range_std_m, s.bearing_std_rad, mount_offset_m);
}

double SightingSquaredError(const LandmarkSighting& s, const Pose2& pose,
                            const Eigen::Vector2d& landmark_m,
                            const Eigen::Vector2d& mount_offset_m) {
  const Eigen::Vector3d sensor =
      pose.RobotToWorld(Eigen::Vector3d(mount_offset_m.x(), mount_offset_m.y(), 0.0));
  const Eigen::Vector2d d = landmark_m - sensor.head<2>();
  if (s.cartesian) {
    // The sensor faces the robot's heading: the point in its frame.
    const double c = std::cos(pose.theta), sn = std::sin(pose.theta);
    const Eigen::Vector2d r(c * d.x() + sn * d.y() - s.range_m * std::cos(s.bearing_rad),
                            -sn * d.x() + c * d.y() - s.range_m * std::sin(s.bearing_rad));
    return r.dot(s.xy_covariance.llt().solve(r));
  }
  const double range = d.norm();
  if (!(range > 0)) return std::numeric_limits<double>::infinity();
  const double range_error = (range - s.range_m) / s.range_std_m;
  const double bearing_error =
      WrapAngle(std::atan2(d.y(), d.x()) - pose.theta - s.bearing_rad) / s.bearing_std_rad;
  return range_error * range_error + bearing_error * bearing_error;
}

Eigen::Matrix2d SightingInformation(const LandmarkSighting& s, const Pose2& pose,
                                    const Eigen::Vector2d& landmark_m,
                                    const Eigen::Vector2d& mount_offset_m) {
  if (s.cartesian) {
    // e = L^-1 R^T (l - sensor) - ...: J = L^-1 R^T, J^T J = R C^-1 R^T.
    const Eigen::Matrix2d rotation = Eigen::Rotation2Dd(pose.theta).toRotationMatrix();
    return rotation * s.xy_covariance.inverse() * rotation.transpose();
  }
  const Eigen::Vector3d sensor =
      pose.RobotToWorld(Eigen::Vector3d(mount_offset_m.x(), mount_offset_m.y(), 0.0));
  const Eigen::Vector2d d = landmark_m - sensor.head<2>();
  const double range = d.norm();
  if (!(range > 0)) return Eigen::Matrix2d::Zero();
  // d(range)/dl = u^T, d(bearing)/dl = n^T / range (u along d, n across).
  const Eigen::Vector2d u = d / range, n(-u.y(), u.x());
  return u * u.transpose() / (s.range_std_m * s.range_std_m) +
         n * n.transpose() / (range * range * s.bearing_std_rad * s.bearing_std_rad);
}

// ---------------------------------------------------------------------------

RelativePoseFactor::RelativePoseFactor(int pose_a_key, int pose_b_key, const Pose2& measured,
                                       const Eigen::Matrix3d& covariance)
    : Factor({pose_a_key, pose_b_key}), measured_(measured) {
  if (!measured.Vector().allFinite())
    throw Error("relative pose factor: the measurement must be finite");
  if (!covariance.allFinite() || !covariance.isApprox(covariance.transpose(), 1e-9))
    throw Error("relative pose factor: the covariance must be finite and symmetric");
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance);
  if (llt.info() != Eigen::Success || !(llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0))
    throw Error("relative pose factor: the covariance must be positive definite");
  const Eigen::Matrix3d l = llt.matrixL();
  sqrt_information_ = l.triangularView<Eigen::Lower>().solve(Eigen::Matrix3d::Identity());
  log_det_ = 2.0 * l.diagonal().array().log().sum();
}

bool RelativePoseFactor::Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                                   Eigen::MatrixXd* jacobian) const {
  const Pose2 a = PoseOf(values, keys()[0]);
  const Pose2 b = PoseOf(values, keys()[1]);
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double hx = c * dx + s * dy, hy = -s * dx + c * dy;
  const Eigen::Vector3d residual(hx - measured_.x, hy - measured_.y,
                                 WrapAngle(b.theta - a.theta - measured_.theta));
  error = sqrt_information_ * residual;
  if (!jacobian) return true;
  Eigen::Matrix<double, 3, 6> j;
  j << -c, -s, hy, c, s, 0.0,  //
      s, -c, -hx, -s, c, 0.0,  //
      0.0, 0.0, -1.0, 0.0, 0.0, 1.0;
  *jacobian = sqrt_information_ * j;
  return true;
}

Pose2 ComposePose(const Pose2& a, const Pose2& z) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {a.x + c * z.x - s * z.y, a.y + s * z.x + c * z.y, WrapAngle(a.theta + z.theta)};
}

Pose2 BetweenPoses(const Pose2& a, const Pose2& b) {
  const Eigen::Vector3d local = a.WorldToRobot(Eigen::Vector3d(b.x, b.y, 0.0));
  return {local.x(), local.y(), WrapAngle(b.theta - a.theta)};
}

}  // namespace oslam

#include "core/motion_model.h"

#include <cmath>

namespace oslam {

Pose2 ApplyIncrement(const Pose2& previous, const OdometryIncrement& increment,
                     Eigen::Matrix3d* jacobian_wrt_previous) {
  const double alpha = previous.theta + 0.5 * increment.turn_rad;
  const double c = std::cos(alpha), s = std::sin(alpha);
  if (jacobian_wrt_previous) {
    *jacobian_wrt_previous << 1, 0, -increment.distance_m * s,  //
        0, 1, increment.distance_m * c,                          //
        0, 0, 1;
  }
  return {previous.x + increment.distance_m * c, previous.y + increment.distance_m * s,
          WrapAngle(previous.theta + increment.turn_rad)};
}

OdometryIncrement IncrementBetween(const Pose2& previous, const Pose2& next) {
  OdometryIncrement increment;
  increment.turn_rad = WrapAngle(next.theta - previous.theta);
  const double alpha = previous.theta + 0.5 * increment.turn_rad;
  increment.distance_m =
      std::cos(alpha) * (next.x - previous.x) + std::sin(alpha) * (next.y - previous.y);
  return increment;
}

bool MotionNoiseOptions::Validate(std::string* why) const {
  for (int row = 0; row < 3; ++row) {
    if (!std::isfinite(additive_std[row]) || additive_std[row] < 0 ||
        !std::isfinite(multiplicative[row]) || multiplicative[row] < 0) {
      if (why) *why = "motion noise entries must be finite and non-negative";
      return false;
    }
  }
  if (additive_std.minCoeff() <= 0) {
    if (why) *why = "additive motion noise must be positive, or Q is singular when standing still";
    return false;
  }
  return true;
}

Eigen::Matrix3d MotionCovariance(double previous_heading_rad, const OdometryIncrement& increment,
                                 const MotionNoiseOptions& options) {
  const double abs_distance = std::abs(increment.distance_m);
  const double heading_scale =
      options.heading_scales_with_distance ? abs_distance : std::abs(increment.turn_rad);
  const Eigen::Vector3d scale(abs_distance, abs_distance, heading_scale);
  const Eigen::Vector3d entries = options.additive_std + options.multiplicative.cwiseProduct(scale);
  const Eigen::Vector3d variances =
      options.entries_are_variances ? entries : Eigen::Vector3d(entries.cwiseAbs2());
  const Eigen::Matrix3d q_robot = variances.asDiagonal();
  if (options.world_frame) return q_robot;
  const double alpha = previous_heading_rad + 0.5 * increment.turn_rad;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  rotation.topLeftCorner<2, 2>() << std::cos(alpha), -std::sin(alpha), std::sin(alpha),
      std::cos(alpha);
  return rotation * q_robot * rotation.transpose();
}

}  // namespace oslam

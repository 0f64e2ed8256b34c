// Odometry motion model of docs/method.md §4.1 (thesis Appendix A.1): midpoint
// integration of a (distance, heading change) increment, and the noise
// Q_i = Q_add + Q_mult * |v_i| read as standard deviations in the robot frame.
#pragma once

#include <string>

#include <Eigen/Core>

#include "core/pose2.h"

namespace oslam {

// v_i = (v^r, v^phi): distance travelled (m) and heading change (rad) from
// pose i-1 to pose i.
struct OdometryIncrement {
  double distance_m = 0.0;
  double turn_rad = 0.0;
};

// f(x_{i-1}, v_i), midpoint model (A.4-A.6). Optional Jacobian w.r.t. x_{i-1}.
Pose2 ApplyIncrement(const Pose2& previous, const OdometryIncrement& increment,
                     Eigen::Matrix3d* jacobian_wrt_previous = nullptr);

// The increment that takes `previous` exactly to `next` under the midpoint
// model (inverse of ApplyIncrement; the lateral part of the displacement,
// which the model cannot express, is dropped).
OdometryIncrement IncrementBetween(const Pose2& previous, const Pose2& next);

struct MotionNoiseOptions {
  // Standard deviations (forward m, lateral m, heading rad): docs/method.md §13 #1.
  Eigen::Vector3d additive_std{0.005, 0.005, 0.017453292519943295};
  Eigen::Vector3d multiplicative{0.1, 0.01, 0.15};
  // docs/method.md §13 #2 alternatives, switchable.
  bool entries_are_variances = false;  // read Q_add/Q_mult as variances, not std devs
  bool heading_scales_with_distance = false;  // |v^r| instead of |v^phi| in the heading row
  bool world_frame = false;                   // skip the rotation into the world frame

  bool Validate(std::string* why) const;
};

// Q_i (world frame unless options.world_frame), the covariance of
// x_i - f(x_{i-1}, v_i). `previous_heading_rad` is theta_{i-1}.
Eigen::Matrix3d MotionCovariance(double previous_heading_rad, const OdometryIncrement& increment,
                                 const MotionNoiseOptions& options);

}  // namespace oslam

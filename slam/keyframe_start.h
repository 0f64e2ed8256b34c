// Pieces of GeometricSlam's keyframe start (keyframe_start.cpp) that stand on
// their own: the odometry between two keyframes as one relative pose with
// its covariance.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "core/motion_model.h"
#include "core/pose2.h"

namespace oslam {

struct KeyframeLink {
  Pose2 relative;  // the later keyframe in the earlier one's frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of `relative`
};

// The odometry of frames (first, last] (increments[i] takes frame i-1 to i)
// composed in frame `first`'s robot frame, with the covariance of the
// composition propagated to first order: P <- F P F' + Q_i per step, F the
// motion model's Jacobian and Q_i its noise (docs/method.md §4.1).
KeyframeLink ComposeOdometrySteps(const std::vector<OdometryIncrement>& increments, long first,
                                  long last, const MotionNoiseOptions& motion);

}  // namespace oslam

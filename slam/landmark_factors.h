// Factors of planar landmark SLAM (docs/method.md §16): a range-bearing sighting of a
// 2D point landmark (e.g. a tree trunk seen by a laser), and the relative-pose
// odometry of data sets that give a full Pose2 increment with a covariance
// (GTSAM's ODOMETRY lines, Ackermann dead reckoning). Both follow factor.h:
// whitened error and Jacobians only. A trunk diameter measurement needs no
// class of its own: it is a PriorFactor (factors.h) on the landmark's
// diameter variable, named "diameter".
#pragma once

#include <string>

#include <Eigen/Core>

#include "core/pose2.h"
#include "slam/landmark_data.h"
#include "solver/factor.h"
#include "solver/factor_graph.h"

namespace oslam {

// z = (range, bearing) of landmark l = (x, y) seen from pose x = (x, y, theta)
// by a sensor mounted at `mount_offset_m` (forward, left) in the robot frame
// and facing the robot's heading:
//
//   s = (x, y) + Rot(theta) mount,  d = l - s,
//   h(x, l) = (|d|, atan2(d_y, d_x) - theta),
//   e = diag(range_std, bearing_std)^{-1} (h - z),  bearing residual wrapped.
//
// Keys: (pose, landmark). Linearize returns false when the landmark sits on
// the sensor (|d| = 0: no bearing).
class RangeBearingFactor final : public Factor {
 public:
  // Throws oslam::Error unless the range is finite and >= 0, the bearing is
  // finite and both standard deviations are positive and finite.
  RangeBearingFactor(int pose_key, int landmark_key, double range_m, double bearing_rad,
                     double range_std_m, double bearing_std_rad,
                     const Eigen::Vector2d& mount_offset_m = Eigen::Vector2d::Zero());

  int Dimension() const override { return 2; }
  bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                 Eigen::MatrixXd* jacobian) const override;
  double LogDetCovariance() const override { return log_det_; }
  std::string Name() const override { return "range-bearing"; }

  double range_m() const { return range_m_; }
  double bearing_rad() const { return bearing_rad_; }

 private:
  double range_m_, bearing_rad_;
  Eigen::Vector2d inverse_sigma_;  // (range, bearing)
  Eigen::Vector2d mount_offset_m_;
  double log_det_;
};

// z = (x, y) of landmark l seen in the frame of a sensor mounted at
// `mount_offset_m` and facing the robot's heading (g2o's EdgeSE2PointXY,
// iSAM's Pose2d_Point2d_Factor with the mount at the origin):
//
//   h(x, l) = Rot(theta)^T (l - (x, y)) - mount,  e = L^{-1} (h - z),  L L^T = P.
//
// Keys: (pose, landmark).
class PointSightingFactor final : public Factor {
 public:
  // Throws oslam::Error unless z is finite and P symmetric positive definite.
  PointSightingFactor(int pose_key, int landmark_key, const Eigen::Vector2d& measured_m,
                      const Eigen::Matrix2d& covariance,
                      const Eigen::Vector2d& mount_offset_m = Eigen::Vector2d::Zero());

  int Dimension() const override { return 2; }
  bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                 Eigen::MatrixXd* jacobian) const override;
  double LogDetCovariance() const override { return log_det_; }
  std::string Name() const override { return "point sighting"; }

 private:
  Eigen::Vector2d measured_m_, mount_offset_m_;
  Eigen::Matrix2d sqrt_information_;  // L^{-1}
  double log_det_;
};

// The factor of sighting `s` (a RangeBearingFactor, or a
// PointSightingFactor when s.cartesian) between a pose and a landmark.
void AddSightingFactor(FactorGraph* graph, int pose_key, int landmark_key,
                       const LandmarkSighting& s, const Eigen::Vector2d& mount_offset_m);

// The world position of a landmark at (range, bearing) from the sensor of
// `pose` (the inverse of RangeBearingFactor's h without noise), for
// initialisation.
Eigen::Vector2d LandmarkFromRangeBearing(const Pose2& pose, double range_m, double bearing_rad,
                                         const Eigen::Vector2d& mount_offset_m);

// The squared whitened error of sighting `s` of a landmark at `landmark_m`
// from `pose` (its factor's ||e||^2; infinite for a range-bearing sighting
// of a landmark on the sensor).
double SightingSquaredError(const LandmarkSighting& s, const Pose2& pose,
                            const Eigen::Vector2d& landmark_m,
                            const Eigen::Vector2d& mount_offset_m);

// The information (inverse covariance) that sighting `s` from `pose` gives
// about the position of a landmark at `landmark_m`, the pose held: the
// factor's J^T J in the landmark's coordinates (zero for a range-bearing
// sighting of a landmark on the sensor).
Eigen::Matrix2d SightingInformation(const LandmarkSighting& s, const Pose2& pose,
                                    const Eigen::Vector2d& landmark_m,
                                    const Eigen::Vector2d& mount_offset_m);

// Pose b seen from pose a: z = (dx, dy, dtheta) in a's frame with a full
// covariance P (GTSAM's BetweenFactor<Pose2> up to second order):
//
//   h(a, b) = (Rot(theta_a)^T (p_b - p_a), theta_b - theta_a),
//   e = L^{-1} (h - z),  L L^T = P,  heading residual wrapped.
//
// Keys: (pose a, pose b). Unlike OdometryFactor (the thesis' midpoint
// model with a noise law of its own) this takes the increment's lateral part
// and the covariance the data set gives.
class RelativePoseFactor final : public Factor {
 public:
  // Throws oslam::Error unless the measurement is finite and the covariance
  // symmetric positive definite.
  RelativePoseFactor(int pose_a_key, int pose_b_key, const Pose2& measured,
                     const Eigen::Matrix3d& covariance);

  int Dimension() const override { return 3; }
  bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                 Eigen::MatrixXd* jacobian) const override;
  double LogDetCovariance() const override { return log_det_; }
  std::string Name() const override { return "relative pose"; }

  const Pose2& measured() const { return measured_; }

 private:
  Pose2 measured_;
  Eigen::Matrix3d sqrt_information_;  // L^{-1}
  double log_det_;
};

// a (+) z: the pose reached from a by the relative pose z (in a's frame).
Pose2 ComposePose(const Pose2& a, const Pose2& z);

// Pose b seen from pose a (in a's frame): the z with ComposePose(a, z) = b.
Pose2 BetweenPoses(const Pose2& a, const Pose2& b);

}  // namespace oslam

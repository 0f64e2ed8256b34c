#include "calib/observation_model.h"

#include <cmath>

namespace oslam {

bool PredictSlice(const CameraModel& camera, const Pose2& robot_pose_world,
                  const CylinderGeometry& object, BoundingSlice* slice,
                  SliceJacobians* jacobians) {
  // Pose2::WorldToRobot, with cos and sin kept for the Jacobians below (one
  // sincos per prediction instead of two).
  const double c = std::cos(robot_pose_world.theta), s = std::sin(robot_pose_world.theta);
  const double dx = object.base_world.x() - robot_pose_world.x,
               dy = object.base_world.y() - robot_pose_world.y;
  const Eigen::Vector3d base_robot(c * dx + s * dy, -s * dx + c * dy, object.base_world.z());
  const Eigen::Vector3d top_robot = base_robot + Eigen::Vector3d(0, 0, object.height_m);
  const double range = std::sqrt(base_robot.x() * base_robot.x() + base_robot.y() * base_robot.y());
  if (!(range > 0.0)) return false;

  PolarPoint base_polar;
  double top_radius = 0.0;
  Eigen::Matrix<double, 2, 3> base_jacobian;
  Eigen::RowVector3d top_jacobian;
  Eigen::Matrix<double, 2, 3>* want_base = jacobians ? &base_jacobian : nullptr;
  Eigen::RowVector3d* want_top = jacobians ? &top_jacobian : nullptr;
  if (!camera.ProjectToPolar(base_robot, &base_polar, want_base)) return false;
  // The top has the base's bearing: only its radius is needed.
  if (!camera.ProjectRadius(top_robot, &top_radius, want_top)) return false;

  const double d = object.diameter_m;
  slice->u_r_px = base_polar.radius_px;
  slice->u_phi_rad = base_polar.angle_rad;
  slice->s_r_px = top_radius - base_polar.radius_px;
  slice->s_phi_rad = 2.0 * std::atan(d / (2.0 * range));
  if (!jacobians) return true;

  // d(slice)/d(point in robot frame); the top point moves with the base.
  Eigen::Matrix<double, 4, 3> wrt_point;
  wrt_point.row(0) = base_jacobian.row(0);
  wrt_point.row(1) = base_jacobian.row(1);
  wrt_point.row(2) = top_jacobian - base_jacobian.row(0);
  const double d_width_d_range = -4.0 * d / (4.0 * range * range + d * d);
  wrt_point.row(3) << d_width_d_range * base_robot.x() / range,
      d_width_d_range * base_robot.y() / range, 0.0;

  // point_robot = R(theta)^T (base_world - t) with z passed through.
  Eigen::Matrix3d point_wrt_base;
  point_wrt_base << c, s, 0, -s, c, 0, 0, 0, 1;
  Eigen::Matrix3d point_wrt_pose;
  point_wrt_pose << -c, -s, base_robot.y(),  //
      s, -c, -base_robot.x(),                //
      0, 0, 0;
  jacobians->wrt_base = wrt_point * point_wrt_base;
  jacobians->wrt_pose = wrt_point * point_wrt_pose;
  jacobians->wrt_size.setZero();
  jacobians->wrt_size(2, 1) = top_jacobian(2);  // d(s_r)/d(h) = d(radius_top)/dz
  jacobians->wrt_size(3, 0) = 4.0 * range / (4.0 * range * range + d * d);
  return true;
}

}  // namespace oslam

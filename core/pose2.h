// Planar robot pose (x, y, theta) in the world frame: metres and radians.
#pragma once

#include <Eigen/Core>

#include "core/angles.h"

namespace oslam {

struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;

  Eigen::Vector3d Vector() const { return {x, y, theta}; }
  static Pose2 FromVector(const Eigen::Vector3d& v) { return {v.x(), v.y(), WrapAngle(v.z())}; }

  // World-frame point -> robot frame (x forward, y left, z up; z unchanged).
  Eigen::Vector3d WorldToRobot(const Eigen::Vector3d& p_world) const {
    const double c = std::cos(theta), s = std::sin(theta);
    const double dx = p_world.x() - x, dy = p_world.y() - y;
    return {c * dx + s * dy, -s * dx + c * dy, p_world.z()};
  }
  Eigen::Vector3d RobotToWorld(const Eigen::Vector3d& p_robot) const {
    const double c = std::cos(theta), s = std::sin(theta);
    return {x + c * p_robot.x() - s * p_robot.y(), y + s * p_robot.x() + c * p_robot.y(),
            p_robot.z()};
  }
};

}  // namespace oslam

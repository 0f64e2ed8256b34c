// Observation model of docs/method.md §4.2 (thesis A.2): the bounding slice an upright
// cylinder produces in the omnidirectional image of a robot at pose x_i,
// through any CameraModel.
//
//   u   = polar image coordinates of the base point l_j          (A.7-A.8)
//   s^r = radius(l_j + h_j e_z) - radius(l_j)                     (A.9)
//   s^phi = 2 atan(d_j / (2 rho)), rho = horizontal range          (A.10)
#pragma once

#include <Eigen/Core>

#include "calib/camera_model.h"
#include "core/bounding_slice.h"
#include "core/pose2.h"

namespace oslam {

// An O-Map object's geometry: base point (centre of the cylinder base) in the
// world frame, diameter and height.
struct CylinderGeometry {
  Eigen::Vector3d base_world = Eigen::Vector3d::Zero();
  double diameter_m = 0.0;
  double height_m = 0.0;
};

// d(u_r, u_phi, s_r, s_phi) / d(variables).
struct SliceJacobians {
  Eigen::Matrix<double, 4, 3> wrt_pose;  // (x, y, theta)
  Eigen::Matrix<double, 4, 3> wrt_base;  // (x, y, z) of the base point
  Eigen::Matrix<double, 4, 2> wrt_size;  // (diameter, height)
};

// Returns false when the base or the top has no image (or the object stands on
// the camera axis). Does not check occlusion or the mirror annulus.
bool PredictSlice(const CameraModel& camera, const Pose2& robot_pose_world,
                  const CylinderGeometry& object, BoundingSlice* slice,
                  SliceJacobians* jacobians = nullptr);

}  // namespace oslam

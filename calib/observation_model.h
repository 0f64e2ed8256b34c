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
#include "core/run_folder.h"

namespace oslam {

// An O-Map object's geometry: base point (centre of the cylinder base) in the
// world frame, diameter and height. A panel (a door) also has an orientation:
// the world-frame direction of its length (its diameter), defined modulo pi;
// other shapes ignore it.
struct CylinderGeometry {
  Eigen::Vector3d base_world = Eigen::Vector3d::Zero();
  double diameter_m = 0.0;
  double height_m = 0.0;
  double yaw_rad = 0.0;
};

// Beyond the thesis (docs/method.md §4.2, "Silhouette model"): what a detector
// measures is the whole silhouette, not the longitudinal section. Its inner
// end is the nearest point of the footprint, its outer end the farthest point
// of the top face (a camera above the object sees the top) or the nearest
// top edge (an object taller than the viewpoint). The footprint is summarised
// by its half extents along and across the line of sight, per unit diameter:
// 0.5 for a cylinder (the thesis' angular width), the mean over yaw for a box;
// a panel's follow from its orientation; a ball's ends are its tangent rays.
struct SilhouetteModel {
  bool enabled = false;            // false: the thesis' section, A.7-A.10
  double depth_half_extent = 0.5;  // along the line of sight, per unit diameter
  double width_half_extent = 0.5;  // across it, per unit diameter
  // A panel: a vertical rectangle of width d (the diameter) turned to
  // `CylinderGeometry::yaw_rad`. With alpha the angle between the line of
  // sight and the panel, its half extents are (d/2)|cos alpha| along the
  // line of sight and (d/2)|sin alpha| across it (the two above are then
  // unused); |.| is smoothed as sqrt(x^2 + kPanelSmoothing^2) so that the
  // face-on and edge-on views stay differentiable.
  bool panel = false;
  // A ball: the radial ends are its tangent rays from the camera's
  // viewpoint (at this height), the ball's centre at half its height and
  // its vertical radius half its height.
  bool sphere = false;
  double viewpoint_height_m = 0.0;
};

// The silhouette of an object shape (core/run_folder.h): cylinder 0.5 / 0.5;
// box with footprint width/length `footprint_aspect` a: both (1 + a) / (pi
// sqrt(1 + a^2)) (the mean half extent of a rectangle over yaw, per unit
// diagonal); panel: from its orientation (`panel`); sphere: tangent rays from
// `camera`'s viewpoint, width 0.5.
SilhouetteModel SilhouetteOf(const CameraModel& camera, ObjectShape shape,
                             double footprint_aspect = 1.0);

// The height of a central camera's viewpoint above the floor (robot frame).
double ViewpointHeight(const CameraModel& camera);

inline constexpr double kPanelSmoothing = 0.03;

// d(u_r, u_phi, s_r, s_phi) / d(variables).
struct SliceJacobians {
  Eigen::Matrix<double, 4, 3> wrt_pose;               // (x, y, theta)
  Eigen::Matrix<double, 4, 3> wrt_base;               // (x, y, z) of the base point
  Eigen::Matrix<double, 4, 2> wrt_size;               // (diameter, height)
  Eigen::Vector4d wrt_yaw = Eigen::Vector4d::Zero();  // a panel's orientation; else zero
};

// Returns false when the base or the top has no image (or the object stands on
// the camera axis; with a silhouette, when the robot is inside the footprint).
// Does not check occlusion or the mirror annulus.
// With `top_beyond_view`, a top with no image (beyond the mirror's field of
// view) does not fail: the flag is set, the outer end is put at
// kBeyondViewRadiusPx and its derivatives are zero (for censored slices).
bool PredictSlice(const CameraModel& camera, const Pose2& robot_pose_world,
                  const CylinderGeometry& object, BoundingSlice* slice,
                  SliceJacobians* jacobians = nullptr, const SilhouetteModel& silhouette = {},
                  bool* top_beyond_view = nullptr);
inline constexpr double kBeyondViewRadiusPx = 1e6;

// Which radial ends of a measured slice are bounds rather than values: the
// blob reaches the mirror's outer limit (rim) or the image border (outer end:
// the object goes on beyond it), or the blind disc (inner end). Within
// `margin_px` of the limit counts as touching.
struct SliceCensoring {
  bool inner = false;  // the true inner radius is at most u_r
  bool outer = false;  // the true outer radius is at least u_r + s_r
};
SliceCensoring CensoringOf(const CameraModel& camera, const BoundingSlice& measured,
                           double margin_px);

// How a class's detections relate to its geometry: the silhouette, and
// whether slice ends cut by the image's limits are bounds (docs/method.md
// §4.2). The default is the thesis' model.
struct SliceModel {
  SilhouetteModel silhouette;
  bool censor_at_image_limits = false;
  double censor_margin_px = 2.0;  // CensoringOf's margin
  // The bearing's noise E_phi (px at the slice's radius: sigma(u_phi) =
  // E_phi / u_r); 0: the detection noise E, as in the thesis (A.11).
  double bearing_noise_px = 0.0;
};

}  // namespace oslam

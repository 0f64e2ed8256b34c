// The camera's mount on the robot (the mirror viewpoint's height above the
// floor and the camera's yaw about the vertical axis), which checkerboards
// held around the mirror cannot show, estimated from one picture of a
// checkerboard lying flat on the floor at a known place (docs/calibration.md,
// "Mount").
//
// Each corner's pixel is back-projected through the calibrated camera and the
// ray met with the floor: for a viewpoint at height h the floor point is
// h (d_x, d_y) / (-d_z) for the ray direction d, so the corners seen from a
// camera of height 1 and the corners where the board lies differ by a scale
// (the height) and a rotation about the vertical (the yaw error): a 2D
// similarity without translation, solved in closed form (least squares on
// the floor, Umeyama/Procrustes). The grid's corner order is ambiguous (the
// image is mirrored, a board can be read from either end), so every
// relabelling of the grid that maps it onto itself is tried and the one
// that fits best kept. The corners are also fitted reflected, for an image
// mirrored against the model.
#pragma once

#include <memory>
#include <string>

#include "calib/calibration.h"
#include "calib/camera_model.h"

namespace oslam {

// Where the board lies, in the robot frame (x forward, y left, metres): the
// centre of its inner-corner grid and the direction of its rows (the
// pattern's COLS axis), radians counter-clockwise from forward. The
// direction matters only up to half a turn (a quarter for a square grid).
struct FloorBoardPlace {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

struct MountEstimate {
  double focus_height_m = 0.0;
  // Yaw to add to the camera's (its mount_yaw_rad for Mei, its image angle
  // offset for the hyperbolic model; WithMount applies it).
  double yaw_change_rad = 0.0;
  // The image is mirrored against the camera's model (calibration from
  // boards cannot tell a mirror image from a direct one): the bearing's
  // sign flips (WithMount applies it; hyperbolic model only).
  bool mirrored = false;
  double floor_rms_m = 0.0;   // corners on the floor against where they lie
  double image_rms_px = 0.0;  // where the re-mounted camera images them against the detected ones
  int corners = 0;
};

// Throws oslam::Error when a corner's ray does not reach the floor or the
// corner count does not match the pattern.
MountEstimate EstimateMountFromFloorBoard(const CameraModel& camera, const Corners& corners,
                                          const BoardPattern& pattern,
                                          const FloorBoardPlace& place);

// The camera with its viewpoint at `focus_height_m` and turned by
// `yaw_change_rad` about the vertical (a point at robot bearing b then
// images where the unturned camera imaged b - yaw_change_rad); `mirrored`:
// the image's bearings reflected first (bearing b images where the camera
// imaged -b). Mei and hyperbolic models (Mei not mirrored); throws
// oslam::Error otherwise.
std::unique_ptr<CameraModel> WithMount(const CameraModel& camera, double focus_height_m,
                                       double yaw_change_rad, bool mirrored = false);

}  // namespace oslam

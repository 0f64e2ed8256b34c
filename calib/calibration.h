// Intrinsic calibration of a catadioptric camera from checkerboard views:
// corners found on the raw image (cv::findChessboardCornersSB, refined with
// cv::cornerSubPix), then Levenberg-Marquardt over the intrinsics and one
// board pose per view (mirror_from_board), with central-difference Jacobians
// per view block and dense normal equations (a few hundred residuals, < 100
// unknowns).
//
// Models: "mei" (MeiCamera: ξ, fx, fy, [skew], cx, cy, k1, k2, p1, p2) and
// "hyperbolic" (HyperbolicCamera, docs/method.md §4.3: focal_px, cx, cy and the mirror's
// b with a fixed; only b/a changes the projection, so a is a scale taken from
// the data sheet). The mount (focus height, yaw) cannot be seen from board
// views; it is taken from the options.
//
// Every view with a detected board is used. Views whose RMS exceeds
// `outlier_view_factor` times the median view RMS are reported as outliers in
// the result, never dropped.
#pragma once

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/mei_camera.h"

namespace oslam {

struct BoardPattern {
  int cols = 0;  // inner corners along a row
  int rows = 0;
  double square_m = 0.0;
  // Board-frame points (z = 0), row-major like the detector's corners.
  std::vector<Eigen::Vector3d> ObjectPoints() const;
};

using Corners = std::vector<Eigen::Vector2d>;

struct CornerDetectionOptions {
  // findChessboardCornersSB with CALIB_CB_ACCURACY is already sub-pixel; a
  // cornerSubPix pass on top made both real sets worse (RMS VMR 0.309 ->
  // 0.347 px, Mei 0.378 -> 0.634 px, docs/calibration.md), so it is opt-in.
  bool refine_with_corner_subpix = false;
  // cornerSubPix half window = this fraction of the smallest corner spacing,
  // clamped to [2, 6] px.
  double subpix_window_fraction = 0.25;
};

// Corners of `pattern` in an 8-bit image (grey or BGR); false when the board
// is not found.
bool DetectBoardCorners(const cv::Mat& image, const BoardPattern& pattern,
                        const CornerDetectionOptions& options, Corners* corners);

struct CalibrationOptions {
  std::string model = "mei";  // "mei" or "hyperbolic"
  // Mei
  bool fix_skew = true;  // like cv::omnidir::CALIB_FIX_SKEW
  bool estimate_distortion = true;
  // Hyperbolic
  double mirror_a_m = 0.03929;  // fixed (scale only); default: the LPA mirror
  double mirror_b_m = 0.0;      // > 0: fixed from a data sheet; 0: estimated
  // Mount on the robot, not observable from boards (their own poses absorb
  // it): the mirror viewpoint's height above the floor and the camera's yaw
  // (the image direction of the robot's forward axis, rad, counter-clockwise
  // about the robot's z). Measured on the robot and given; the mirror axis is
  // taken as vertical.
  double focus_height_m = 1.0;
  double mount_yaw_rad = 0.0;
  // Initial image centre; NaN: the image centre (W-1)/2, (H-1)/2.
  double initial_cx_px = std::numeric_limits<double>::quiet_NaN();
  double initial_cy_px = std::numeric_limits<double>::quiet_NaN();
  // Solver
  int max_iterations = 300;
  double function_tolerance = 1e-12;  // relative cost decrease to stop
  double outlier_view_factor = 3.0;
  bool Validate(std::string* why) const;
};

struct CalibrationView {
  std::string name;
  bool board_found = false;
  Corners corners;  // detected (empty when not found)
  // Filled by the calibration:
  Corners reprojected;
  double rms_px = 0.0;
  bool outlier = false;
  Eigen::Vector3d rotation_mirror_from_board = Eigen::Vector3d::Zero();  // angle-axis
  Eigen::Vector3d translation_mirror_from_board_m = Eigen::Vector3d::Zero();
};

struct CalibrationSummary {
  int iterations = 0;
  int views_used = 0;
  int points_used = 0;
  double initial_rms_px = 0.0;
  double final_rms_px = 0.0;  // sqrt(mean over corners of |error|²), as cv::omnidir
  double seconds = 0.0;
  std::string termination;
  std::string BriefReport() const;
};

struct CalibrationResult {
  std::unique_ptr<CameraModel> camera;
  std::vector<CalibrationView> views;
  std::vector<std::string> parameter_names;  // the estimated intrinsics
  Eigen::VectorXd parameters;
  Eigen::VectorXd standard_deviations;  // from sigma² (JᵀJ)⁻¹
  CalibrationSummary summary;
};

// Calibrates from views whose corners are already detected (views without a
// board are kept in the result, unused). Throws oslam::Error when fewer than
// 3 views have a board or the options are invalid.
CalibrationResult CalibrateFromCorners(const std::vector<CalibrationView>& views,
                                       const BoardPattern& pattern, int image_width,
                                       int image_height, const CalibrationOptions& options);

// RMS of the Mei model `camera` over views, re-estimating only the board
// poses (used to score other tools' intrinsics on every view).
double MeiRmsWithFixedIntrinsics(const MeiCamera& camera, const std::vector<CalibrationView>& views,
                                 const BoardPattern& pattern);

// cv::omnidir::calibrate (CALIB_FIX_SKEW when fix_skew) on the same corners.
struct OpenCvOmnidirResult {
  bool ok = false;
  std::string error;            // OpenCV's message when !ok
  double rms_px = 0.0;          // as returned (over the views it used)
  std::vector<int> used_views;  // indices into the views given
  MeiParameters parameters;     // xi, K, D
  double seconds = 0.0;
};
OpenCvOmnidirResult CalibrateWithOpenCvOmnidir(const std::vector<CalibrationView>& views,
                                               const BoardPattern& pattern, int image_width,
                                               int image_height, bool fix_skew);

// A picture of one view: detected corners (green circles), reprojected
// corners (red crosses), the view's RMS. Written atomically.
void WriteViewReportImage(const cv::Mat& image, const CalibrationView& view,
                          const std::string& path);

}  // namespace oslam

// Calibration of a catadioptric camera from a folder of checkerboard
// images: corners on the raw images, the mirror rim (the annulus and the
// initial image centre), Levenberg-Marquardt over the intrinsics and board
// poses with every found board, outlier views reported; optionally
// cv::omnidir on the same corners for comparison, and one picture per view.
#pragma once

#include <string>

#include "calib/calibration.h"
#include "calib/mount_estimation.h"
#include "pipeline/stage_output.h"

namespace oslam {

struct CalibrationFlowOptions {
  CalibrationOptions calibration;          // model, mirror, focus height, solver
  bool refine_with_corner_subpix = false;  // CornerDetectionOptions
  bool detect_rim = true;                  // the mirror rim and blind disc bound the annulus
  bool compare_opencv = false;             // also cv::omnidir::calibrate, printed beside ours
  std::string report_dir;                  // "" = none; else <view>_corners.png per view
  // The mount from a picture of the board lying flat on the floor at
  // `floor_board` (calib/mount_estimation.h): "" = none, the mount is
  // calibration.focus_height_m and mount_yaw_rad as given. Else those are
  // ignored and estimated.
  std::string floor_board_image;
  FloorBoardPlace floor_board;
  // The floor board's pattern and square; 0 (each) = the boards'.
  BoardPattern floor_board_pattern;

  bool Validate(std::string* why) const { return calibration.Validate(why); }
};

// Reads IMAGES_DIR's images (sorted by name, one size), calibrates and
// reports through `output`: the corners found per view, the rim, the
// solve, parameters with standard deviations and each view's RMS. The
// comparison with cv::omnidir is printed even when quiet. With a floor
// board, the camera is mounted as that board shows (its height and yaw
// printed with their fit). Throws
// oslam::Error naming the folder or file and problem.
CalibrationResult CalibrateFromImages(const std::string& images_dir, const BoardPattern& pattern,
                                      const CalibrationFlowOptions& options,
                                      const StageOutput& output);

}  // namespace oslam

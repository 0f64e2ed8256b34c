// What a real omnidirectional camera on a real robot adds to the ideal
// render (docs/simulator.md, "Realistic recordings"): the robot's own body
// and the mirror's support rods in the image, motion blur from the robot's
// turn, auto-exposure following the scene's brightness, lens vignetting and
// lossy (JPEG) compression. Applied by the simulator after each frame is
// rendered; every random draw comes from the generator it is given (seeded).
#pragma once

#include <random>

#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"

namespace oslam {

struct RealismOptions {
  bool enabled = false;
  // Brightness lost at the mirror rim: each pixel is scaled by
  // 1 − vignetting (r / r_rim)².
  double vignetting = 0.3;
  // Auto-exposure: the gain moves this share (in log) of the way to the one
  // that brings the frame's mean brightness back to the first frame's, plus
  // a random change of this log standard deviation per frame.
  double auto_exposure_rate = 0.5;
  double exposure_jitter = 0.05;
  // The exposure lasts this share of the frame's turn: the image is blurred
  // by rotating it about its centre through that angle.
  double motion_blur = 0.15;
  int jpeg_quality = 60;  // JPEG round trip of every frame; 0 = none
  // The rig in the image: `rods` radial support rods of `rod_width_px`
  // across the annulus, and the robot's body behind the camera as a sector
  // `body_angle_rad` wide from the blind disc to `body_depth` of the annulus.
  int rods = 3;
  double rod_width_px = 5.0;
  double body_angle_rad = 1.2;
  double body_depth = 0.3;
};

class CameraEffects {
 public:
  // Lays out the rig's pixels for `camera` (its annulus and the image
  // direction straight behind the robot); the rig's texture is drawn from
  // `rng`.
  CameraEffects(const CameraModel& camera, const RealismOptions& options, std::mt19937_64& rng);

  // Applies the effects to a rendered BGR frame; `turn_rad` is the robot's
  // turn since the previous frame, `noise_std` the sensor noise (grey levels)
  // added to the rig's pixels.
  void Apply(cv::Mat* bgr, double turn_rad, double noise_std, std::mt19937_64& rng);

  // 0 where the rig is (the true static mask), 255 elsewhere.
  const cv::Mat& rig_mask() const { return usable_; }

 private:
  RealismOptions options_;
  cv::Point2f centre_;
  cv::Mat usable_;      // CV_8U
  cv::Mat rig_colour_;  // CV_8UC3, the rig's pixels' colour
  cv::Mat vignette_;    // CV_32F, per-pixel brightness factor
  cv::Mat annulus_;     // CV_8U
  double gain_ = 1.0;
  double target_brightness_ = -1.0;
};

}  // namespace oslam

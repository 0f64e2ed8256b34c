// The static mask of a camera rig: the pixels that show the robot itself
// (its body, the mirror's support rods, the camera in the blind disc) rather
// than the world, so that detection ignores them (docs/formats.md,
// "mask.png"). Given by the user as an image, or detected from a recording:
// while the robot drives, every pixel that sees the world changes, and the
// rig's own pixels only follow the exposure.
#pragma once

#include <functional>
#include <string>

#include <opencv2/core/mat.hpp>

namespace oslam {

class CameraModel;
class FrameSource;

struct StaticMaskOptions {
  int samples = 60;  // frames read, spread evenly over the recording (all when fewer)
  // A pixel is the rig's when its grey level, scaled by the frame's median
  // brightness (which removes the exposure's changes), has a standard
  // deviation below this over the samples, in grey levels at the first
  // frame's brightness. Sensor noise and compression give 2-3; pixels that
  // see the world while the robot drives, 10 and more.
  double max_change = 5.0;
  int min_region_px = 30;  // static regions smaller than this are the world's (flat patches)
  int margin_px = 2;       // the mask grows by this much (blur and compression at its edges)
  bool Validate(std::string* why) const;
};

struct StaticMaskResult {
  cv::Mat mask;  // CV_8U, image size: 0 = the rig's (ignored), 255 = the world's
  int samples = 0;
  double masked_share_of_annulus = 0.0;
};

// Throws oslam::Error naming the source when it has fewer than 5 frames or a
// frame is not the camera's size. `progress` (may be empty) gets (done, total).
StaticMaskResult DetectStaticMask(const FrameSource& frames, const CameraModel& camera,
                                  const StaticMaskOptions& options,
                                  const std::function<void(size_t, size_t)>& progress = {});

// A mask image (grey or colour, the camera's size; 0 = ignored, any other
// value = used), as CV_8U 0/255. Throws oslam::Error naming the file.
cv::Mat ReadStaticMask(const std::string& path, int width, int height);
void WriteStaticMask(const cv::Mat& mask, const std::string& path);

}  // namespace oslam

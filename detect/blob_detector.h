// Colour-blob detector (CMVision-style, spec §10.2): per-pixel class by YUV
// box, optional opening, connected components, minimum area, restricted to the
// mirror annulus; each blob becomes a bounding slice in polar image
// coordinates (spec §10.1: u_r = inner radius, u_phi = middle angle).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"
#include "core/bounding_slice.h"
#include "core/run_folder.h"
#include "detect/colour_classifier.h"

namespace oslam {

struct Detection {
  long frame = 0;
  int class_index = -1;
  std::string class_name;
  BoundingSlice slice;
  int area_px = 0;
  std::array<double, 3> mean_yuv{};
  // exp(-D²/2) of the blob's mean colour to the class box centre, with D the
  // distance in standard deviations under the detector's box shape
  // (ColourClassifier::SquaredDistance): 1 = the class's typical colour.
  double score = 0.0;
};

struct BlobDetectorOptions {
  int min_area_px = 40;            // smaller blobs are noise
  int opening_radius_px = 1;       // morphological opening per class mask; 0 = off
  bool annulus_only = true;        // ignore the blind disc and everything beyond the mirror rim
  ColourClassifierOptions colour;  // box shape (thesis YUV box or brightness-scaled)
  bool Validate(std::string* why) const;
};

class BlobDetector {
 public:
  // Keeps a copy of what it needs from the camera (polar coordinates of every
  // pixel, the annulus mask); throws oslam::Error on invalid options.
  BlobDetector(const CameraModel& camera, const std::vector<ObjectClass>& classes,
               const BlobDetectorOptions& options = {});

  // Detections in a BGR frame of the camera's image size.
  std::vector<Detection> Detect(const cv::Mat& bgr, long frame) const;

  const cv::Mat& annulus_mask() const { return mask_; }

 private:
  // `labels` covers the image region starting at `offset`; `box` is in labels' coordinates.
  Detection DescribeBlob(const cv::Mat& labels, int label, const cv::Rect& box,
                         const cv::Point& offset, const cv::Mat& yuv, int class_index,
                         long frame) const;

  std::vector<ObjectClass> classes_;
  BlobDetectorOptions options_;
  ColourClassifier classifier_;
  cv::Mat mask_;       // CV_8U, 255 inside the annulus
  cv::Mat radius_px_;  // CV_32F polar radius of each pixel centre
  cv::Mat angle_rad_;  // CV_32F polar angle of each pixel centre
};

// Writes detections as CSV (docs/formats.md), atomically.
void WriteDetections(const std::vector<Detection>& detections, const std::string& path);
// Reads them back; class names must be in `classes`.
std::vector<Detection> ReadDetections(const std::string& path,
                                      const std::vector<ObjectClass>& classes);

// The outline of a bounding slice (annular sector) in pixels: inner arc,
// then outer arc backwards; what DrawSlice draws.
std::vector<cv::Point> SliceOutline(const CameraModel& camera, const BoundingSlice& slice);

// Draws a bounding slice (annular sector outline) on an image.
void DrawSlice(cv::Mat* image, const CameraModel& camera, const BoundingSlice& slice,
               const cv::Scalar& colour, int thickness = 1);

}  // namespace oslam

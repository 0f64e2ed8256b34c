// SIFT verification of colour detections (docs/method.md §10.3, after Ekvall, Kragic &
// Jensfelt 2007): a candidate blob of a class that has template images is kept
// only when enough SIFT matches between the candidate's region and a template
// pass Lowe's ratio test and a RANSAC affine check. Same-coloured clutter
// (a plain box the colour of a textured one) has no such matches.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "calib/camera_model.h"
#include "core/bounding_slice.h"
#include "core/run_folder.h"
#include "detect/blob_detector.h"

namespace oslam {

struct SiftVerifierOptions {
  double ratio = 0.75;  // Lowe's ratio test
  int min_inliers = 6;  // RANSAC inliers needed to accept
  double ransac_threshold_px = 4.0;
  // The slice is widened by this share on every side; negative shrinks it.
  // Looking only inside the blob keeps the object's silhouette out: any box
  // outline matches any other, so it must not count as evidence.
  double padding = -0.1;
  int min_patch_px = 96;  // patches are upsampled to at least this size
  bool Validate(std::string* why) const;
};

// The image region of a bounding slice, unwarped to a rectangle: columns
// follow the angle (arc length at the middle radius), rows the radius, outer
// radius (higher elevation) on top, so objects stand upright.
cv::Mat ExtractSlicePatch(const cv::Mat& frame, const CameraModel& camera,
                          const BoundingSlice& slice, double padding, int min_size_px);

struct VerificationResult {
  bool verified = false;  // true also for classes without templates
  bool checked = false;   // the class has templates, so SIFT was run
  int good_matches = 0;   // after the ratio test, best template
  int inliers = 0;        // after RANSAC, best template
};

class SiftVerifier {
 public:
  // templates[c]: template images (BGR) of class c; may be empty for a class.
  SiftVerifier(const std::vector<std::vector<cv::Mat>>& templates,
               const SiftVerifierOptions& options = {});

  VerificationResult Verify(const cv::Mat& frame, const CameraModel& camera,
                            const Detection& detection) const;
  // Keeps the detections that pass.
  std::vector<Detection> Filter(const cv::Mat& frame, const CameraModel& camera,
                                const std::vector<Detection>& detections) const;
  bool HasTemplates(int class_index) const;

 private:
  struct Template {
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
  };
  SiftVerifierOptions options_;
  cv::Ptr<cv::SIFT> sift_;
  std::vector<std::vector<Template>> templates_;
};

// templates.yaml: `templates: [{class: NAME, image: PATH}, ...]`, paths
// relative to the file. Returns templates per class index of `classes`.
std::vector<std::vector<cv::Mat>> ReadSiftTemplates(const std::string& path,
                                                    const std::vector<ObjectClass>& classes);

}  // namespace oslam

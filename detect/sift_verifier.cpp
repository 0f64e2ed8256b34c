#include "detect/sift_verifier.h"

#include <cmath>
#include <filesystem>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/image_file.h"
#include "core/yaml.h"

namespace oslam {

bool SiftVerifierOptions::Validate(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!(ratio > 0 && ratio < 1)) return fail("ratio must be in (0, 1)");
  if (min_inliers < 3) return fail("min_inliers must be at least 3 (an affine map has 6 unknowns)");
  if (!(ransac_threshold_px > 0)) return fail("ransac_threshold_px must be positive");
  if (!(padding >= -0.4 && padding <= 2)) return fail("padding must be in [-0.4, 2]");
  return true;
}

cv::Mat ExtractSlicePatch(const cv::Mat& frame, const CameraModel& camera,
                          const BoundingSlice& slice, double padding, int min_size_px) {
  const double radial = slice.s_r_px * (1 + 2 * padding);
  const double angular = slice.s_phi_rad * (1 + 2 * padding);
  const double r_outer = slice.u_r_px + slice.s_r_px * (1 + padding);
  const double angle_begin = slice.u_phi_rad - 0.5 * angular;
  const double r_middle = r_outer - 0.5 * radial;
  // Native resolution: one column per pixel of arc, one row per pixel of radius.
  double width = std::max(1.0, angular * r_middle), height = std::max(1.0, radial);
  const double upscale = std::max(1.0, min_size_px / std::min(width, height));
  width *= upscale;
  height *= upscale;
  const int cols = static_cast<int>(std::ceil(width)), rows = static_cast<int>(std::ceil(height));
  cv::Mat map_x(rows, cols, CV_32FC1), map_y(rows, cols, CV_32FC1);
  for (int row = 0; row < rows; ++row) {
    const double radius = r_outer - (row + 0.5) / rows * radial;
    for (int col = 0; col < cols; ++col) {
      const double angle = angle_begin + (col + 0.5) / cols * angular;
      const Eigen::Vector2d pixel = camera.PolarToPixel({radius, angle});
      map_x.at<float>(row, col) = static_cast<float>(pixel.x());
      map_y.at<float>(row, col) = static_cast<float>(pixel.y());
    }
  }
  cv::Mat patch;
  cv::remap(frame, patch, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return patch;
}

namespace {

// Grey levels stretched to the full range, so texture contrast does not
// depend on how brightly the object happens to be lit.
cv::Mat Normalised(const cv::Mat& bgr) {
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::normalize(grey, grey, 0, 255, cv::NORM_MINMAX);
  return grey;
}

}  // namespace

SiftVerifier::SiftVerifier(const std::vector<std::vector<cv::Mat>>& templates,
                           const SiftVerifierOptions& options)
    // A lower contrast threshold than SIFT's default (0.04): omnidirectional
    // patches are small and soft, and the patches are contrast-stretched first.
    : options_(options), sift_(cv::SIFT::create(0, 3, 0.02)) {
  std::string why;
  if (!options.Validate(&why)) throw Error("SIFT verifier: " + why);
  templates_.resize(templates.size());
  for (size_t c = 0; c < templates.size(); ++c) {
    for (const cv::Mat& image : templates[c]) {
      Template t;
      sift_->detectAndCompute(Normalised(image), cv::noArray(), t.keypoints, t.descriptors);
      // A template without features can never verify anything; keep it out.
      if (t.keypoints.size() >= static_cast<size_t>(options.min_inliers))
        templates_[c].push_back(t);
    }
  }
}

bool SiftVerifier::HasTemplates(int class_index) const {
  return class_index >= 0 && class_index < static_cast<int>(templates_.size()) &&
         !templates_[class_index].empty();
}

VerificationResult SiftVerifier::Verify(const cv::Mat& frame, const CameraModel& camera,
                                        const Detection& detection) const {
  VerificationResult result;
  if (!HasTemplates(detection.class_index)) {
    result.verified = true;
    return result;
  }
  result.checked = true;
  const cv::Mat patch =
      ExtractSlicePatch(frame, camera, detection.slice, options_.padding, options_.min_patch_px);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  sift_->detectAndCompute(Normalised(patch), cv::noArray(), keypoints, descriptors);
  if (keypoints.size() < 3) return result;
  const cv::BFMatcher matcher(cv::NORM_L2);
  for (const Template& t : templates_[detection.class_index]) {
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(descriptors, t.descriptors, knn, 2);
    std::vector<cv::Point2f> from, to;
    for (const auto& pair : knn) {
      if (pair.size() < 2 || pair[0].distance >= options_.ratio * pair[1].distance) continue;
      from.push_back(keypoints[pair[0].queryIdx].pt);
      to.push_back(t.keypoints[pair[0].trainIdx].pt);
    }
    result.good_matches = std::max(result.good_matches, static_cast<int>(from.size()));
    if (from.size() < 3) continue;
    std::vector<uchar> inlier_mask;
    const cv::Mat affine =
        cv::estimateAffine2D(from, to, inlier_mask, cv::RANSAC, options_.ransac_threshold_px);
    if (affine.empty()) continue;
    result.inliers = std::max(result.inliers, cv::countNonZero(inlier_mask));
  }
  result.verified = result.inliers >= options_.min_inliers;
  return result;
}

std::vector<Detection> SiftVerifier::Filter(const cv::Mat& frame, const CameraModel& camera,
                                            const std::vector<Detection>& detections) const {
  std::vector<Detection> kept;
  for (const Detection& d : detections)
    if (Verify(frame, camera, d).verified) kept.push_back(d);
  return kept;
}

std::vector<std::vector<cv::Mat>> ReadSiftTemplates(const std::string& path,
                                                    const std::vector<ObjectClass>& classes) {
  YamlFile file(path);
  file.RequireOnlyKeys(file.root(), "", {"templates"});
  const cv::FileNode list = file.Seq(file.root(), "templates");
  const std::filesystem::path base = std::filesystem::path(path).parent_path();
  std::vector<std::vector<cv::Mat>> templates(classes.size());
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string key = "templates[" + std::to_string(i) + "].";
    const cv::FileNode node = list[static_cast<int>(i)];
    file.RequireOnlyKeys(node, key, {"class", "image"});
    const std::string name = file.String(node, "class", key);
    const int class_index = FindClass(classes, name);
    if (class_index < 0) file.Fail(key + "class", "unknown class '" + name + "'");
    const std::string image_path = (base / file.String(node, "image", key)).string();
    cv::Mat image;
    try {
      image = ReadImage(image_path);
    } catch (const Error& e) {
      file.Fail(key + "image", e.what());
    }
    templates[class_index].push_back(image);
  }
  return templates;
}

}  // namespace oslam

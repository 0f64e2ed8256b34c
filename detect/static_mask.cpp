#include "detect/static_mask.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "calib/camera_model.h"
#include "core/error.h"
#include "core/image_file.h"
#include "core/run_folder.h"

namespace oslam {
namespace {

// Median grey level of the annulus pixels (from the histogram).
double MedianGrey(const cv::Mat& grey, const cv::Mat& annulus) {
  int histogram[256] = {0};
  long count = 0;
  for (int y = 0; y < grey.rows; ++y) {
    const uint8_t* g = grey.ptr<uint8_t>(y);
    const uint8_t* a = annulus.ptr<uint8_t>(y);
    for (int x = 0; x < grey.cols; ++x)
      if (a[x]) {
        ++histogram[g[x]];
        ++count;
      }
  }
  long seen = 0;
  for (int v = 0; v < 256; ++v) {
    seen += histogram[v];
    if (2 * seen >= count) return v;
  }
  return 128;
}

cv::Mat AnnulusMask(const CameraModel& camera) {
  cv::Mat annulus(camera.image_height(), camera.image_width(), CV_8UC1);
  for (int y = 0; y < annulus.rows; ++y)
    for (int x = 0; x < annulus.cols; ++x)
      annulus.at<uint8_t>(y, x) = camera.IsInAnnulus(Eigen::Vector2d(x, y)) ? 255 : 0;
  return annulus;
}

// Removes the static regions (non-zero in `rig`) smaller than min_px.
void DropSmallRegions(cv::Mat* rig, int min_px) {
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(*rig, labels, stats, centroids, 8, CV_32S);
  for (int y = 0; y < rig->rows; ++y) {
    const int* label = labels.ptr<int>(y);
    uint8_t* r = rig->ptr<uint8_t>(y);
    for (int x = 0; x < rig->cols; ++x)
      if (label[x] > 0 && label[x] < n && stats.at<int>(label[x], cv::CC_STAT_AREA) < min_px)
        r[x] = 0;
  }
}

}  // namespace

bool StaticMaskOptions::Validate(std::string* why) const {
  auto fail = [why](const std::string& what) {
    if (why) *why = what;
    return false;
  };
  if (samples < 5 || samples > 10000) return fail("mask samples must be in 5..10000");
  if (!(max_change > 0 && max_change < 128))
    return fail("mask max_change must be in (0, 128) grey levels");
  if (min_region_px < 0) return fail("mask min_region_px must be >= 0");
  if (margin_px < 0 || margin_px > 50) return fail("mask margin_px must be in 0..50");
  return true;
}

StaticMaskResult DetectStaticMask(const FrameSource& frames, const CameraModel& camera,
                                  const StaticMaskOptions& options,
                                  const std::function<void(size_t, size_t)>& progress) {
  std::string why;
  if (!options.Validate(&why)) throw Error(why);
  const size_t total = frames.size();
  if (total < 5)
    throw Error::InFile(frames.Name(0), "has " + std::to_string(total) +
                                            " frames; the mask needs at least 5 of a drive");
  const size_t samples = std::min(total, static_cast<size_t>(options.samples));
  const cv::Mat annulus = AnnulusMask(camera);
  const cv::Size size(camera.image_width(), camera.image_height());
  cv::Mat sum = cv::Mat::zeros(size, CV_64FC1), sum2 = cv::Mat::zeros(size, CV_64FC1);
  cv::Mat grey, level;
  double reference = -1.0;  // the first sample's median brightness
  for (size_t k = 0; k < samples; ++k) {
    // Evenly spread and increasing, so a video is decoded in one pass.
    const size_t index = samples == 1 ? 0 : k * (total - 1) / (samples - 1);
    const cv::Mat frame = frames.Read(index);
    if (frame.size() != size)
      throw Error::InFile(frames.Name(index),
                          "frame " + std::to_string(index) + " is " + std::to_string(frame.cols) +
                              "x" + std::to_string(frame.rows) + ", the camera " +
                              std::to_string(size.width) + "x" + std::to_string(size.height));
    cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
    // Scaled to the first sample's brightness: the exposure's changes removed.
    const double median = std::max(1.0, MedianGrey(grey, annulus));
    if (reference < 0) reference = median;
    grey.convertTo(level, CV_64FC1, reference / median);
    sum += level;
    sum2 += level.mul(level);
    if (progress) progress(k + 1, samples);
  }
  const double n = static_cast<double>(samples);
  cv::Mat variance = sum2 / n - (sum / n).mul(sum / n);
  cv::Mat rig = variance < options.max_change * options.max_change;  // 255 = static
  rig &= annulus;
  DropSmallRegions(&rig, options.min_region_px);
  if (options.margin_px > 0) {
    const int d = 2 * options.margin_px + 1;
    cv::dilate(rig, rig, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(d, d)));
  }
  StaticMaskResult result;
  result.samples = static_cast<int>(samples);
  result.mask = 255 - rig;
  result.mask.setTo(0, annulus == 0);  // outside the mirror: nothing of the world either
  const double annulus_px = cv::countNonZero(annulus);
  result.masked_share_of_annulus =
      annulus_px > 0 ? cv::countNonZero(rig & annulus) / annulus_px : 0.0;
  return result;
}

cv::Mat ReadStaticMask(const std::string& path, int width, int height) {
  const cv::Mat image = ReadImage(path, ImageColour::kGray);
  if (image.cols != width || image.rows != height)
    throw Error::InFile(path, "mask is " + std::to_string(image.cols) + "x" +
                                  std::to_string(image.rows) + ", the camera " +
                                  std::to_string(width) + "x" + std::to_string(height));
  return image != 0;
}

void WriteStaticMask(const cv::Mat& mask, const std::string& path) {
  WriteImage(path, mask);
}

}  // namespace oslam

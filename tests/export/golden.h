// Golden-image comparison shared by the figure, overlay, viewer and Blender
// tests. A pixel matches when every channel is within kToleranceGreyLevels of
// the golden; an image matches when at least kMinMatchingFraction of its
// pixels do (room for anti-aliasing differences between builds) and the
// differing pixels form no blob: after a 2x2 erosion none is left, so a seam
// of edge noise one pixel wide passes while a missing object or trajectory
// tube (a region several pixels across) fails. Regenerate on purpose with
// tests/golden/regenerate.sh (OSLAM_REGENERATE_GOLDEN=1), then look at the
// PNGs before committing.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace oslam::testing {

constexpr int kToleranceGreyLevels = 2;
constexpr double kMinMatchingFraction = 0.995;

inline std::string GoldenPath(const std::string& name) {
  return std::string(OSLAM_SOURCE_DIR) + "/tests/golden/" + name;
}

inline bool Regenerating() {
  const char* value = std::getenv("OSLAM_REGENERATE_GOLDEN");
  return value && std::string(value) == "1";
}

// Pixels whose channels are not all within the tolerance (255), others 0.
inline cv::Mat DifferingPixels(const cv::Mat& image, const cv::Mat& golden) {
  cv::Mat difference;
  cv::absdiff(image, golden, difference);
  std::vector<cv::Mat> channels;
  cv::split(difference, channels);
  cv::Mat worst = channels[0];
  for (const cv::Mat& c : channels) worst = cv::max(worst, c);
  return worst > kToleranceGreyLevels;
}

// Share of pixels within the tolerance; 0 when the sizes or types differ.
inline double MatchingFraction(const cv::Mat& image, const cv::Mat& golden) {
  if (image.size() != golden.size() || image.type() != golden.type()) return 0.0;
  const int differing = cv::countNonZero(DifferingPixels(image, golden));
  return 1.0 - static_cast<double>(differing) / static_cast<double>(image.total());
}

// Differing pixels left after a 2x2 erosion: 0 unless some differing region
// is at least 2 pixels wide both ways. Size mismatch: every pixel.
inline int DifferingBlobPixels(const cv::Mat& image, const cv::Mat& golden) {
  if (image.size() != golden.size() || image.type() != golden.type())
    return static_cast<int>(image.total());
  cv::Mat eroded;
  cv::erode(DifferingPixels(image, golden), eroded, cv::Mat::ones(2, 2, CV_8U));
  return cv::countNonZero(eroded);
}

inline bool MatchesGolden(const cv::Mat& image, const cv::Mat& golden) {
  return MatchingFraction(image, golden) >= kMinMatchingFraction &&
         DifferingBlobPixels(image, golden) == 0;
}

inline void ExpectMatchesGolden(const cv::Mat& image, const std::string& name) {
  const std::string path = GoldenPath(name);
  if (Regenerating()) {
    ASSERT_TRUE(cv::imwrite(path, image)) << path;
    std::cout << "regenerated " << path << "\n";
    return;
  }
  const cv::Mat golden = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(golden.empty()) << path << " missing: run tests/golden/regenerate.sh";
  if (!MatchesGolden(image, golden)) {
    const std::string actual =
        (std::filesystem::temp_directory_path() / ("actual_" + name)).string();
    cv::imwrite(actual, image);
    ADD_FAILURE() << name << ": " << 100.0 * MatchingFraction(image, golden)
                  << " % of pixels within " << kToleranceGreyLevels << " grey levels (need "
                  << 100.0 * kMinMatchingFraction << " %), " << DifferingBlobPixels(image, golden)
                  << " differing pixels in regions 2 pixels wide or more (need 0); rendered image "
                     "saved as "
                  << actual;
  }
}

}  // namespace oslam::testing

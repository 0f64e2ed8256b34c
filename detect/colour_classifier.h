// CMVision-style colour classification (spec §10.2): each class is a box in
// YUV space, mean ± k·σ per channel. Three 256-entry lookup tables hold one
// bit per class, so a pixel's classes are the AND of three table reads.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/run_folder.h"

namespace oslam {

class ColourClassifier {
 public:
  static constexpr int kMaxClasses = 32;

  // Classes without a colour box are never detected. Throws oslam::Error when
  // there are more than kMaxClasses classes.
  explicit ColourClassifier(const std::vector<ObjectClass>& classes);

  // Where each class occurs in an image: pixel count and bounding box.
  struct ClassExtent {
    int count = 0;
    cv::Rect box;
  };

  // Per pixel, bit c set when the pixel is inside class c's box. `yuv` is an
  // 8-bit 3-channel YUV image (cv::COLOR_BGR2YUV); only pixels where `mask`
  // (8-bit) is non-zero are classified (an empty mask means all). `extents[c]`
  // receives class c's pixel count and bounding box, so later stages can work
  // on that box only.
  void Classify(const cv::Mat& yuv, const cv::Mat& mask, cv::Mat* class_bits,
                std::vector<ClassExtent>* extents) const;

  bool InBox(int class_index, const cv::Vec3b& yuv) const;
  int num_classes() const { return num_classes_; }

 private:
  int num_classes_ = 0;
  std::array<std::array<uint32_t, 256>, 3> tables_{};
};

// Mean and standard deviation per YUV channel of the pixels of `bgr` where
// `mask` is non-zero (the thesis' class colour model).
ColourBox LearnColourBox(const std::vector<cv::Mat>& bgr_images, const std::vector<cv::Mat>& masks,
                         double k_sigma);

// P(detected a | true c) from the Mahalanobis distance between colour models
// (spec §7.1): D²(a, c) = Σ_ch (μ_a − μ_c)² / σ_c², P(a | c) ∝ exp(−D²/2),
// then floored at `floor` and renormalised so no entry is exactly 0.
// Returned as matrix[c][a] (rows: true class, columns: detected class).
// Classes without a colour box get the identity row.
std::vector<std::vector<double>> ColourConfusion(const std::vector<ObjectClass>& classes,
                                                 double floor = 1e-3);

}  // namespace oslam

// CMVision-style colour classification (docs/method.md §10.2): each class is a box in
// YUV space, mean ± k·σ per channel (the thesis), or that box with its chroma
// scaled by the pixel's brightness (illumination-robust). Two 256 × 256
// lookup tables, indexed by (Y, U) and (Y, V), hold one bit per class, so a
// pixel's classes are the AND of two table reads.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/run_folder.h"

namespace oslam {

// How a class's colour model (YUV mean μ and spread σ, k) becomes a region of
// YUV space.
enum class ColourBoxShape {
  // The thesis' box: |Y − μ_Y|, |U − μ_U|, |V − μ_V| each ≤ k·σ.
  kYuv,
  // Chroma scaled by brightness: under a dimmer or brighter light an object's
  // R, G, B scale together, so its chroma (U − 128, V − 128) scales with Y.
  // With s = Y / μ_Y: Y within [(μ_Y − kσ_Y) / r, μ_Y + kσ_Y] (r =
  // brightness_range) and at least min_y, and
  // |(U − 128) − s·(μ_U − 128)| ≤ s·k·σ_U, the same for V: the thesis box at
  // the class's mean brightness, slid along the line of constant
  // brightness-normalised chroma. Brighter than the examples is not widened
  // (a dark-red model would fire on an orange object), and the half-width
  // shrinks with s (kept at k·σ in the dark, every near-grey dark pixel would
  // pass as a saturated class); docs/detection.md gives the measurements.
  kBrightnessScaled,
};

struct ColourClassifierOptions {
  ColourBoxShape shape = ColourBoxShape::kBrightnessScaled;
  double brightness_range = 2.5;  // r above: how much darker or brighter than its examples
  int min_y = 12;                 // darker pixels carry no usable chroma
  bool Validate(std::string* why) const;
};

// Parses "yuv" / "scaled"; returns false for anything else.
bool ParseColourBoxShape(const std::string& text, ColourBoxShape* shape);

class ColourClassifier {
 public:
  static constexpr int kMaxClasses = 32;

  // Classes without a colour box are never detected. Throws oslam::Error when
  // there are more than kMaxClasses classes or the options are invalid.
  explicit ColourClassifier(const std::vector<ObjectClass>& classes,
                            const ColourClassifierOptions& options = {});

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
  const ColourClassifierOptions& options() const { return options_; }

  // Distance (in standard deviations) of a YUV colour from class c's model
  // under the box shape: D² summed over the channels the shape constrains
  // (kBrightnessScaled compares the chroma rescaled to the class's brightness
  // and leaves Y out).
  double SquaredDistance(const ColourBox& box, const std::array<double, 3>& yuv) const;

 private:
  int num_classes_ = 0;
  ColourClassifierOptions options_;
  // y_u_[Y * 256 + U], y_v_[Y * 256 + V]: class bits.
  std::vector<uint32_t> y_u_, y_v_;
};

// A colour's chroma (U − 128, V − 128) scaled to the brightness `reference_y`
// (times reference_y / Y, Y at least 1): BlobChroma's coordinates.
std::array<double, 2> ChromaAtBrightness(const std::array<double, 3>& yuv, double reference_y);

// D² (two degrees of freedom) of a blob's mean colour from its class's blob
// chroma (ColourBox::blob_chroma, which must be set).
double BlobChromaSquaredDistance(const ColourBox& box, const std::array<double, 3>& mean_yuv);

// Mean and standard deviation per YUV channel of the pixels of `bgr` where
// `mask` is non-zero (the thesis' class colour model).
ColourBox LearnColourBox(const std::vector<cv::Mat>& bgr_images, const std::vector<cv::Mat>& masks,
                         double k_sigma);

// P(detected a | true c) from the Mahalanobis distance between colour models
// (docs/method.md §7.1): D²(a, c) = Σ_ch (μ_a − μ_c)² / σ_c², P(a | c) ∝ exp(−D²/2),
// then floored at `floor` and renormalised so no entry is exactly 0.
// Returned as matrix[c][a] (rows: true class, columns: detected class).
// Classes without a colour box get the identity row.
std::vector<std::vector<double>> ColourConfusion(const std::vector<ObjectClass>& classes,
                                                 double floor = 1e-3);

}  // namespace oslam

// The colour classifier (colour_classifier.h, docs/detection.md): its
// lookup tables hold exactly the documented region of each box shape; a
// whole image is classified with per-class extents and a mask; colour boxes
// are learnt as mean and sample spread of the example pixels; the
// Mahalanobis confusion between colour models (docs/method.md §7.1).
#include "detect/colour_classifier.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "detect/painted_slices.h"

namespace oslam {
namespace {

using testing::ClassWithColour;
using testing::kBlue;
using testing::kGreen;
using testing::kPink;
using testing::Scaled;
using testing::ToYuv;

TEST(ColourClassifier, BrightnessScaledBoxKeepsAnObjectUnderDimLightThatTheThesisBoxLoses) {
  const std::vector<ObjectClass> classes = {ClassWithColour("green box", kGreen, 3),
                                            ClassWithColour("pink ball", kPink, 3)};
  ColourClassifierOptions thesis;
  thesis.shape = ColourBoxShape::kYuv;
  ColourClassifierOptions scaled;
  scaled.shape = ColourBoxShape::kBrightnessScaled;
  scaled.brightness_range = 2.5;
  const ColourClassifier yuv_box(classes, thesis), scaled_box(classes, scaled);
  for (int c = 0; c < 2; ++c) {
    const cv::Vec3b bgr = c == 0 ? kGreen : kPink;
    // Both accept the class's own colour.
    EXPECT_TRUE(yuv_box.InBox(c, ToYuv(bgr)));
    EXPECT_TRUE(scaled_box.InBox(c, ToYuv(bgr)));
    // Half the light: R, G, B halve. Only the scaled box still accepts it.
    EXPECT_FALSE(yuv_box.InBox(c, ToYuv(Scaled(bgr, 0.5))));
    EXPECT_TRUE(scaled_box.InBox(c, ToYuv(Scaled(bgr, 0.5))));
    // A quarter of it is beyond brightness_range: rejected.
    EXPECT_FALSE(scaled_box.InBox(c, ToYuv(Scaled(bgr, 0.2))));
    // Brighter than the examples is not widened.
    EXPECT_FALSE(scaled_box.InBox(c, ToYuv(Scaled(bgr, 1.6))));
  }
  // Dimmed grey and the other class's dimmed colour stay out.
  EXPECT_FALSE(scaled_box.InBox(0, ToYuv(cv::Vec3b(60, 60, 60))));
  EXPECT_FALSE(scaled_box.InBox(1, ToYuv(cv::Vec3b(60, 60, 60))));
  EXPECT_FALSE(scaled_box.InBox(0, ToYuv(Scaled(kPink, 0.5))));
  EXPECT_FALSE(scaled_box.InBox(1, ToYuv(Scaled(kGreen, 0.5))));
  // The score measures the chroma against the class's, rescaled: a dimmed
  // exact colour scores near 1 with the scaled shape.
  const cv::Vec3b dim = ToYuv(Scaled(kGreen, 0.5));
  const std::array<double, 3> dim_yuv = {double(dim[0]), double(dim[1]), double(dim[2])};
  EXPECT_LT(scaled_box.SquaredDistance(*classes[0].colour, dim_yuv), 1.0);
  EXPECT_GT(yuv_box.SquaredDistance(*classes[0].colour, dim_yuv), 9.0);
}

// The region each shape stands for, written out from its definition:
// kYuv, every channel within mean +- k sigma; kBrightnessScaled, with
// s = Y / mean_Y, Y from max(min_y, (mean_Y - k sigma_Y) / r) to
// mean_Y + k sigma_Y and each chroma within s k sigma of 128 + s (mean - 128).
bool InRegion(const ColourBox& box, const ColourClassifierOptions& options, int y, int u, int v) {
  const double k = box.k_sigma;
  const double y_low = box.yuv_mean[0] - k * box.yuv_std[0];
  const double y_high = box.yuv_mean[0] + k * box.yuv_std[0];
  const int yuv[3] = {y, u, v};
  if (options.shape == ColourBoxShape::kYuv) {
    if (y < y_low || y > y_high) return false;
    for (int ch = 1; ch < 3; ++ch)
      if (yuv[ch] < box.yuv_mean[ch] - k * box.yuv_std[ch] ||
          yuv[ch] > box.yuv_mean[ch] + k * box.yuv_std[ch])
        return false;
    return true;
  }
  if (y < options.min_y || y < y_low / options.brightness_range || y > y_high) return false;
  const double s = y / std::max(1.0, box.yuv_mean[0]);
  for (int ch = 1; ch < 3; ++ch) {
    const double centre = 128.0 + s * (box.yuv_mean[ch] - 128.0);
    const double half_width = k * box.yuv_std[ch] * s;
    if (yuv[ch] < centre - half_width || yuv[ch] > centre + half_width) return false;
  }
  return true;
}

TEST(ColourClassifier, TablesHoldExactlyTheDocumentedRegionOfEachShape) {
  std::vector<ObjectClass> classes = {ClassWithColour("green box", kGreen, 3),
                                      ClassWithColour("pink ball", kPink, 5)};
  // Unequal spreads per channel and a fractional k, so that no bound is an integer.
  classes[0].colour->yuv_std = {4.3, 2.7, 3.1};
  classes[1].colour->k_sigma = 2.5;
  ColourClassifierOptions yuv, scaled, narrow;
  yuv.shape = ColourBoxShape::kYuv;
  narrow.brightness_range = 1.3;
  narrow.min_y = 60;
  for (const ColourClassifierOptions& options : {yuv, scaled, narrow}) {
    const ColourClassifier classifier(classes, options);
    for (int c = 0; c < 2; ++c) {
      long inside = 0, mismatches = 0;
      auto check = [&](int y, int u, int v) {
        const bool expected = InRegion(*classes[c].colour, options, y, u, v);
        inside += expected;
        mismatches += classifier.InBox(c, cv::Vec3b(y, u, v)) != expected;
      };
      // Every (U, V) at some brightnesses, and every brightness on a (U, V) grid.
      for (int y = 0; y < 256; y += 11)
        for (int u = 0; u < 256; ++u)
          for (int v = 0; v < 256; ++v) check(y, u, v);
      for (int y = 0; y < 256; ++y)
        for (int u = 0; u < 256; u += 8)
          for (int v = 0; v < 256; v += 8) check(y, u, v);
      EXPECT_EQ(mismatches, 0) << "class " << c << ", shape " << static_cast<int>(options.shape);
      EXPECT_GT(inside, 100) << "class " << c;
    }
  }
}

TEST(ColourClassifier, ClassifiesAnImageWithExtentsAndAMask) {
  // Two look-alike classes of one colour (a pixel of it is in both boxes), a
  // third one, and a class with no colour box, which is never detected.
  ObjectClass no_colour = ClassWithColour("grey thing", cv::Vec3b(128, 128, 128), 3);
  no_colour.colour.reset();
  const std::vector<ObjectClass> classes = {ClassWithColour("green box", kGreen, 3),
                                            ClassWithColour("green ball", kGreen, 3),
                                            ClassWithColour("pink ball", kPink, 3), no_colour};
  const ColourClassifier classifier(classes);
  EXPECT_EQ(classifier.num_classes(), 4);
  cv::Mat bgr(6, 8, CV_8UC3, cv::Scalar(128, 128, 128));
  bgr.at<cv::Vec3b>(1, 2) = kGreen;  // (row, column)
  bgr.at<cv::Vec3b>(4, 6) = kGreen;
  bgr.at<cv::Vec3b>(3, 3) = kGreen;
  bgr.at<cv::Vec3b>(5, 0) = kPink;
  cv::Mat yuv;
  cv::cvtColor(bgr, yuv, cv::COLOR_BGR2YUV);
  cv::Mat bits;
  std::vector<ColourClassifier::ClassExtent> extents;
  classifier.Classify(yuv, cv::Mat(), &bits, &extents);
  ASSERT_EQ(bits.type(), CV_32SC1);
  ASSERT_EQ(extents.size(), 4u);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) {
      const cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
      const int expected = p == kGreen ? 0b0011 : p == kPink ? 0b0100 : 0;
      EXPECT_EQ(bits.at<int32_t>(y, x), expected) << x << " " << y;
    }
  EXPECT_EQ(extents[0].count, 3);
  EXPECT_EQ(extents[0].box, cv::Rect(2, 1, 5, 4));  // x 2..6, y 1..4
  EXPECT_EQ(extents[1].count, 3);
  EXPECT_EQ(extents[1].box, extents[0].box);
  EXPECT_EQ(extents[2].count, 1);
  EXPECT_EQ(extents[2].box, cv::Rect(0, 5, 1, 1));
  EXPECT_EQ(extents[3].count, 0);
  EXPECT_TRUE(extents[3].box.empty());
  // Masked-out pixels get no class and leave the extents.
  cv::Mat mask(6, 8, CV_8UC1, cv::Scalar(255));
  mask.at<uint8_t>(4, 6) = 0;
  mask.at<uint8_t>(5, 0) = 0;
  classifier.Classify(yuv, mask, &bits, &extents);
  EXPECT_EQ(bits.at<int32_t>(4, 6), 0);
  EXPECT_EQ(bits.at<int32_t>(1, 2), 0b0011);
  EXPECT_EQ(extents[0].count, 2);
  EXPECT_EQ(extents[0].box, cv::Rect(2, 1, 2, 3));  // x 2..3, y 1..3
  EXPECT_EQ(extents[2].count, 0);
  // Only 8-bit, 3-channel images and matching 8-bit masks are taken.
  EXPECT_THROW(classifier.Classify(cv::Mat(6, 8, CV_8UC1), cv::Mat(), &bits, &extents),
               cv::Exception);
  EXPECT_THROW(classifier.Classify(yuv, cv::Mat(5, 8, CV_8UC1), &bits, &extents), cv::Exception);
}

TEST(ColourClassifier, AtMost32Classes) {
  std::vector<ObjectClass> classes(32, ClassWithColour("green box", kGreen, 3));
  classes.back() = ClassWithColour("pink ball", kPink, 3);
  // Class 31 uses the top bit of the tables.
  const ColourClassifier most(classes);
  EXPECT_TRUE(most.InBox(31, ToYuv(kPink)));
  EXPECT_FALSE(most.InBox(30, ToYuv(kPink)));
  classes.push_back(classes.back());
  try {
    ColourClassifier too_many(classes);
    FAIL() << "33 classes were taken";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "the colour detector handles at most 32 classes, got 33");
  }
}

TEST(ColourClassifier, BoxShapeParsingAndOptionChecks) {
  ColourBoxShape shape = ColourBoxShape::kBrightnessScaled;
  EXPECT_TRUE(ParseColourBoxShape("yuv", &shape));
  EXPECT_EQ(shape, ColourBoxShape::kYuv);
  EXPECT_TRUE(ParseColourBoxShape("scaled", &shape));
  EXPECT_EQ(shape, ColourBoxShape::kBrightnessScaled);
  EXPECT_FALSE(ParseColourBoxShape("hsv", &shape));
  ColourClassifierOptions bad;
  bad.brightness_range = 0.5;
  EXPECT_THROW(ColourClassifier({ClassWithColour("green box", kGreen, 3)}, bad), Error);
}

TEST(ColourClassifier, OptionsNameTheBadValue) {
  auto why = [](const ColourClassifierOptions& options) {
    std::string message;
    EXPECT_FALSE(options.Validate(&message));
    return message;
  };
  EXPECT_TRUE(ColourClassifierOptions().Validate(nullptr));
  ColourClassifierOptions options;
  options.brightness_range = 16.5;
  EXPECT_EQ(why(options), "brightness_range must be in 1..16");
  options.brightness_range = std::nan("");
  EXPECT_EQ(why(options), "brightness_range must be in 1..16");
  options = {};
  options.min_y = 256;
  EXPECT_EQ(why(options), "min_y must be in 0..255");
  options.min_y = -1;
  EXPECT_EQ(why(options), "min_y must be in 0..255");
  try {
    ColourClassifier({ClassWithColour("green box", kGreen, 3)}, options);
    FAIL() << "invalid options were taken";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "colour classifier: min_y must be in 0..255");
  }
}

TEST(ColourModel, LearntBoxRecoversMeanAndSpread) {
  cv::Mat image(200, 200, CV_8UC3);
  cv::RNG rng(5);
  rng.fill(image, cv::RNG::NORMAL, cv::Scalar(100, 150, 80), cv::Scalar(5, 5, 5));
  const cv::Mat mask(200, 200, CV_8UC1, cv::Scalar(255));
  const ColourBox box = LearnColourBox({image}, {mask}, 3.0);
  cv::Mat yuv;
  cv::cvtColor(cv::Mat(1, 1, CV_8UC3, cv::Scalar(100, 150, 80)), yuv, cv::COLOR_BGR2YUV);
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(box.yuv_mean[ch], yuv.at<cv::Vec3b>(0, 0)[ch], 1.0);
  EXPECT_GT(box.yuv_std[0], 2.0);  // Y mixes the three channels' noise
  EXPECT_LT(box.yuv_std[0], 6.0);
  EXPECT_EQ(box.k_sigma, 3.0);
}

TEST(ColourModel, MeanAndSampleSpreadOfTheMaskedPixelsOfAllImages) {
  // Two images; the masks pick three pixels of the first and two of the second.
  cv::Mat first(2, 3, CV_8UC3, cv::Scalar(0, 0, 0)),
      second(1, 4, CV_8UC3, cv::Scalar(255, 255, 255));
  first.at<cv::Vec3b>(0, 0) = {60, 170, 40};
  first.at<cv::Vec3b>(0, 2) = {70, 160, 50};
  first.at<cv::Vec3b>(1, 1) = {50, 180, 45};
  second.at<cv::Vec3b>(0, 1) = {65, 175, 35};
  second.at<cv::Vec3b>(0, 3) = {55, 165, 42};
  cv::Mat first_mask(2, 3, CV_8UC1, cv::Scalar(0)), second_mask(1, 4, CV_8UC1, cv::Scalar(0));
  first_mask.at<uint8_t>(0, 0) = first_mask.at<uint8_t>(0, 2) = first_mask.at<uint8_t>(1, 1) = 1;
  second_mask.at<uint8_t>(0, 1) = second_mask.at<uint8_t>(0, 3) = 255;
  const ColourBox box = LearnColourBox({first, second}, {first_mask, second_mask}, 2.5);
  const std::vector<cv::Vec3b> examples = {first.at<cv::Vec3b>(0, 0), first.at<cv::Vec3b>(0, 2),
                                           first.at<cv::Vec3b>(1, 1), second.at<cv::Vec3b>(0, 1),
                                           second.at<cv::Vec3b>(0, 3)};
  for (int ch = 0; ch < 3; ++ch) {
    double mean = 0;
    for (const cv::Vec3b& bgr : examples) mean += ToYuv(bgr)[ch];
    mean /= examples.size();
    double squares = 0;
    for (const cv::Vec3b& bgr : examples) squares += std::pow(ToYuv(bgr)[ch] - mean, 2);
    EXPECT_NEAR(box.yuv_mean[ch], mean, 1e-12) << ch;
    EXPECT_NEAR(box.yuv_std[ch], std::sqrt(squares / (examples.size() - 1)), 1e-9) << ch;
  }
  EXPECT_EQ(box.k_sigma, 2.5);
}

TEST(ColourModel, FewerThanTwoExamplePixelsIsAnError) {
  const cv::Mat image(4, 4, CV_8UC3, cv::Scalar(60, 170, 40));
  cv::Mat mask(4, 4, CV_8UC1, cv::Scalar(0));
  mask.at<uint8_t>(2, 2) = 255;
  try {
    LearnColourBox({image}, {mask}, 3.0);
    FAIL() << "a colour model from one pixel";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "colour model needs at least 2 example pixels, got 1");
  }
  // Two pixels of one colour: zero spread, which the classifier must still take.
  mask.at<uint8_t>(0, 0) = 255;
  const ColourBox flat = LearnColourBox({image}, {mask}, 3.0);
  EXPECT_EQ(flat.yuv_std, (std::array<double, 3>{0.0, 0.0, 0.0}));
  ObjectClass c = ClassWithColour("green box", kGreen, 3);
  c.colour = flat;
  EXPECT_TRUE(ColourClassifier({c}, {ColourBoxShape::kYuv}).InBox(0, ToYuv(kGreen)));
}

TEST(ColourConfusion, RowsAreDistributionsWithTheTrueClassMostLikely) {
  std::vector<ObjectClass> classes = {ClassWithColour("orange door", cv::Vec3b(0, 128, 255), 10),
                                      ClassWithColour("orange ball", cv::Vec3b(10, 140, 250), 10),
                                      ClassWithColour("blue ball", kBlue, 4)};
  const auto confusion = ColourConfusion(classes, 1e-3);
  for (size_t c = 0; c < classes.size(); ++c) {
    double total = 0;
    for (size_t a = 0; a < classes.size(); ++a) {
      total += confusion[c][a];
      EXPECT_GE(confusion[c][a], 1e-3 * 0.99);
      if (a != c) {
        EXPECT_GT(confusion[c][c], confusion[c][a]);
      }
    }
    EXPECT_NEAR(total, 1.0, 1e-12);
  }
  // Look-alike oranges confuse each other far more than orange and blue do.
  EXPECT_GT(confusion[0][1], 0.05);
  EXPECT_LT(confusion[0][2], 0.002);
}

TEST(ColourConfusion, FollowsTheMahalanobisDistanceUnderTheTrueClassesSpread) {
  // D^2(a | c) is measured in the true class c's spread: a is spread out and
  // b tight, so a is taken for b far more often than b for a.
  ObjectClass a = ClassWithColour("a", kGreen, 1), b = ClassWithColour("b", kGreen, 1);
  a.colour->yuv_mean = {100, 120, 130};
  a.colour->yuv_std = {2, 4, 5};
  b.colour->yuv_mean = {104, 116, 130};
  b.colour->yuv_std = {1, 2, 3};
  const auto confusion = ColourConfusion({a, b}, 1e-3);
  // Row a: D^2 = (4/2)^2 + (4/4)^2 = 5, so P(b | a) = e^-2.5 / (1 + e^-2.5).
  EXPECT_NEAR(confusion[0][1], std::exp(-2.5) / (1 + std::exp(-2.5)), 1e-12);
  EXPECT_NEAR(confusion[0][0], 1 / (1 + std::exp(-2.5)), 1e-12);
  // Row b: D^2 = (4/1)^2 + (4/2)^2 = 20: e^-10 is below the floor, which
  // then takes its place before the row is renormalised.
  const double b_row_total = 1 / (1 + std::exp(-10.0)) + 1e-3;
  EXPECT_NEAR(confusion[1][0], 1e-3 / b_row_total, 1e-12);
  EXPECT_NEAR(confusion[1][1], 1 / (1 + std::exp(-10.0)) / b_row_total, 1e-12);
}

TEST(ColourConfusion, ClassesWithoutAColourBoxAreNeverConfused) {
  ObjectClass plain = ClassWithColour("plain", kGreen, 3);
  plain.colour.reset();
  // A zero spread is taken as one grey level, so distances stay finite.
  ObjectClass exact = ClassWithColour("exact", kGreen, 0);
  const std::vector<ObjectClass> classes = {ClassWithColour("green", kGreen, 3), plain, exact};
  const auto confusion = ColourConfusion(classes, 1e-3);
  EXPECT_EQ(confusion[1], (std::vector<double>{0.0, 1.0, 0.0}));
  // Detected as the colourless class only at the floor's rate.
  EXPECT_LT(confusion[0][1], 1.01e-3);
  EXPECT_LT(confusion[2][1], 1.01e-3);
  for (int c : {0, 2}) {
    double total = 0;
    for (double p : confusion[c]) {
      EXPECT_TRUE(std::isfinite(p));
      total += p;
    }
    EXPECT_NEAR(total, 1.0, 1e-12);
  }
  // Same mean: equally likely either way.
  EXPECT_NEAR(confusion[2][0], confusion[2][2], 1e-12);
}

}  // namespace
}  // namespace oslam

// Colour verification by a blob's mean colour (BlobDetectorOptions::
// max_blob_colour_distance, ColourBox::blob_chroma; docs/detection.md
// "Blob colour").
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "detect/blob_detector.h"
#include "detect/colour_classifier.h"
#include "detect/evaluation.h"
#include "detect/trained_classes.h"
#include "samples/scene.h"
#include "samples/simulator.h"
#include "test_util.h"

namespace oslam {
namespace {

// The same paint under a dimmer light (Y and the chroma scaled together)
// lands on the same point.
TEST(BlobColour, ChromaIsScaledToTheReferenceBrightness) {
  const std::array<double, 2> bright = ChromaAtBrightness({160, 80, 170}, 100);
  EXPECT_DOUBLE_EQ(bright[0], -30);
  EXPECT_DOUBLE_EQ(bright[1], 26.25);
  const std::array<double, 2> dim = ChromaAtBrightness({80, 128 - 24, 128 + 21}, 100);
  EXPECT_DOUBLE_EQ(dim[0], -30);
  EXPECT_DOUBLE_EQ(dim[1], 26.25);
  // A black pixel does not divide by zero.
  EXPECT_TRUE(std::isfinite(ChromaAtBrightness({0, 130, 126}, 100)[0]));
}

TEST(BlobColour, DistanceAndGateInStandardDeviations) {
  ColourBox box;
  box.yuv_mean = {100, 90, 150};
  box.blob_chroma = BlobChroma{{-38, 22}, {2, 0.5}};
  EXPECT_DOUBLE_EQ(BlobChromaSquaredDistance(box, {100, 90, 150}), 0.0);
  // 2 σ off in U and 1 σ in V, at twice the brightness.
  EXPECT_NEAR(BlobChromaSquaredDistance(box, {200, 128 - 2 * 34, 128 + 2 * 22.5}), 4 + 1, 1e-12);
  // The gate has the tail probability of ± k σ of a normal.
  EXPECT_NEAR(TwoDofSquaredDistanceOfSigmas(1), -2 * std::log(1 - 0.682689492), 1e-6);
  EXPECT_NEAR(TwoDofSquaredDistanceOfSigmas(3), 11.829, 1e-3);
  EXPECT_TRUE(std::isinf(TwoDofSquaredDistanceOfSigmas(std::numeric_limits<double>::infinity())));
  BlobDetectorOptions options;
  std::string why;
  options.max_blob_colour_distance = 0;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_EQ(why, "max_blob_colour_distance must be positive (inf = off)");
}

// tests/data/blob_colour.yaml: a yellow box and a carton of its size in a
// paler yellow. The colour box fires on the carton in every frame; the
// blob colour learnt in training keeps every view of the box and none of
// the carton.
TEST(BlobColour, APalerLookAlikeIsDroppedAndEveryTrueViewKept) {
  testing::TempDir dir;
  const std::string run = dir.Path("run");
  Simulate(LoadScene(std::string(OSLAM_SOURCE_DIR) + "/tests/data/blob_colour.yaml"), run, {});
  const std::vector<ObjectClass> classes = ClassesTrainedOnGroundTruth(run);
  ASSERT_TRUE(classes[0].colour && classes[0].colour->blob_chroma);
  const BlobChroma& blob = *classes[0].colour->blob_chroma;
  std::printf("yellow box blob chroma (%.2f, %.2f) +- (%.2f, %.2f)\n", blob.mean[0], blob.mean[1],
              blob.std[0], blob.std[1]);
  // A yellow: U below neutral, V above; the spread at least the floor.
  EXPECT_LT(blob.mean[0], -20);
  EXPECT_GT(blob.mean[1], 10);
  for (int ch = 0; ch < 2; ++ch)
    EXPECT_GE(blob.std[ch],
              kDefaultBlobChromaFloor * std::max(1.0, classes[0].colour->yuv_std[ch + 1]) - 1e-12);
  auto evaluate = [&](const BlobDetectorOptions& options) {
    return EvaluateDetectorOnRun(run, classes, options).per_class[0];
  };
  BlobDetectorOptions box_only;
  box_only.max_blob_colour_distance = std::numeric_limits<double>::infinity();
  const ClassDetectionStats before = evaluate(box_only), after = evaluate(BlobDetectorOptions{});
  std::printf("colour box only: found %d of %d, %d spurious; with the blob colour %d, %d\n",
              before.sightings_found, before.sightings, before.spurious, after.sightings_found,
              after.spurious);
  ASSERT_GE(before.sightings, 10);
  EXPECT_GE(before.spurious, 0.5 * before.sightings);  // the carton passes the colour box
  EXPECT_EQ(after.sightings_found, before.sightings_found);
  EXPECT_EQ(before.sightings_found, before.sightings);
  EXPECT_EQ(after.spurious, 0);
}

}  // namespace
}  // namespace oslam

// Colour-blob detection on synthetic omnidirectional frames with known slices.
#include "detect/blob_detector.h"

#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "calib/hyperbolic_camera.h"
#include "core/angles.h"
#include "core/error.h"
#include "detect/colour_classifier.h"
#include "detect/painted_slices.h"
#include "test_util.h"

namespace oslam {
namespace {

using testing::ClassWithColour;
using testing::kBlue;
using testing::kGreen;
using testing::kPink;
using testing::PaintSlice;
using testing::Scaled;

struct Scene {
  HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  std::vector<ObjectClass> classes = {ClassWithColour("green box", kGreen, 4),
                                      ClassWithColour("pink ball", kPink, 4),
                                      ClassWithColour("blue ball", kBlue, 4)};
  std::vector<std::pair<int, BoundingSlice>> truth = {
      {0, {120.0, 0.5, 40.0, 0.35}},
      {1, {90.0, -2.0, 15.0, 0.2}},
      {2, {150.0, kPi - 0.02, 20.0, 0.15}},  // straddles the ±π seam
  };
  cv::Mat Render(uint64_t seed) const {
    cv::Mat image(camera.image_height(), camera.image_width(), CV_8UC3, cv::Scalar(128, 128, 128));
    for (const auto& [c, slice] : truth) {
      const ColourBox& box = *classes[c].colour;
      cv::Mat pixel(1, 1, CV_8UC3, cv::Scalar(box.yuv_mean[0], box.yuv_mean[1], box.yuv_mean[2]));
      cv::cvtColor(pixel, pixel, cv::COLOR_YUV2BGR);
      PaintSlice(&image, camera, slice, pixel.at<cv::Vec3b>(0, 0));
    }
    cv::Mat noise(image.size(), CV_16SC3);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0, 2.0);
    cv::Mat noisy;
    image.convertTo(noisy, CV_16SC3);
    noisy += noise;
    noisy.convertTo(image, CV_8UC3);
    return image;
  }
};

TEST(BlobDetector, FindsEachPaintedSliceWithItsClassAndExtent) {
  const Scene scene;
  const BlobDetector detector(scene.camera, scene.classes);
  const std::vector<Detection> detections = detector.Detect(scene.Render(7), 3);
  ASSERT_EQ(detections.size(), scene.truth.size());
  for (const auto& [c, slice] : scene.truth) {
    const auto it = std::find_if(detections.begin(), detections.end(),
                                 [&](const Detection& d) { return d.class_index == c; });
    ASSERT_NE(it, detections.end()) << scene.classes[c].name;
    EXPECT_EQ(it->frame, 3);
    EXPECT_EQ(it->class_name, scene.classes[c].name);
    // Pixel quantisation: within 1 px radially and 1 px of arc angularly.
    EXPECT_NEAR(it->slice.u_r_px, slice.u_r_px, 1.0);
    EXPECT_NEAR(it->slice.s_r_px, slice.s_r_px, 1.0);
    EXPECT_NEAR(WrapAngle(it->slice.u_phi_rad - slice.u_phi_rad), 0.0, 1.0 / slice.u_r_px);
    EXPECT_NEAR(it->slice.s_phi_rad, slice.s_phi_rad, 1.5 / slice.u_r_px);
    EXPECT_GT(it->score, 0.5);
  }
}

TEST(BlobDetector, IgnoresColourOutsideTheMirrorAnnulusAndTinyBlobs) {
  const Scene scene;
  cv::Mat image(scene.camera.image_height(), scene.camera.image_width(), CV_8UC3,
                cv::Scalar(128, 128, 128));
  cv::rectangle(image, cv::Rect(0, 0, 40, 40), cv::Scalar(kGreen), cv::FILLED);   // beyond the rim
  cv::circle(image, cv::Point(320, 240), 20, cv::Scalar(kPink), cv::FILLED);      // blind disc
  cv::rectangle(image, cv::Rect(400, 240, 3, 3), cv::Scalar(kBlue), cv::FILLED);  // 9 px
  const BlobDetector detector(scene.camera, scene.classes);
  EXPECT_TRUE(detector.Detect(image, 0).empty());
}

TEST(BlobDetector, WrongFrameSizeIsAnError) {
  const Scene scene;
  const BlobDetector detector(scene.camera, scene.classes);
  EXPECT_THROW(detector.Detect(cv::Mat(10, 10, CV_8UC3), 0), Error);
  BlobDetectorOptions bad;
  bad.min_area_px = 0;
  EXPECT_THROW(BlobDetector(scene.camera, scene.classes, bad), Error);
}

TEST(BlobDetector, FindsADimlyLitSliceOnlyWithTheBrightnessScaledBox) {
  Scene scene;
  scene.truth = {{0, {120.0, 0.5, 40.0, 0.35}}};
  cv::Mat image(scene.camera.image_height(), scene.camera.image_width(), CV_8UC3,
                cv::Scalar(40, 40, 40));
  PaintSlice(&image, scene.camera, scene.truth[0].second, Scaled(kGreen, 0.55));
  BlobDetectorOptions thesis;
  thesis.colour.shape = ColourBoxShape::kYuv;
  EXPECT_TRUE(BlobDetector(scene.camera, scene.classes, thesis).Detect(image, 0).empty());
  const std::vector<Detection> found = BlobDetector(scene.camera, scene.classes).Detect(image, 0);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].class_index, 0);
  EXPECT_NEAR(found[0].slice.u_r_px, 120.0, 1.0);
  EXPECT_NEAR(found[0].slice.s_r_px, 40.0, 1.0);
}

TEST(Detections, CsvRoundTripAndUnknownClass) {
  const Scene scene;
  const BlobDetector detector(scene.camera, scene.classes);
  const std::vector<Detection> detections = detector.Detect(scene.Render(1), 12);
  testing::TempDir dir;
  WriteDetections(detections, dir.Path("detections.csv"));
  const std::vector<Detection> read = ReadDetections(dir.Path("detections.csv"), scene.classes);
  ASSERT_EQ(read.size(), detections.size());
  for (size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].frame, 12);
    EXPECT_EQ(read[i].class_index, detections[i].class_index);
    EXPECT_EQ(read[i].slice.s_phi_rad, detections[i].slice.s_phi_rad);
  }
  std::vector<ObjectClass> fewer = {scene.classes[0]};
  EXPECT_THROW(ReadDetections(dir.Path("detections.csv"), fewer), Error);
}

// Two classes of one colour (an orange ball and an orange bucket): both colour
// boxes hold both blobs. Their image shapes differ: the ball's slice is as long
// as it is wide, the bucket's 1.4 times longer.
struct LookAlikeScene {
  HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const cv::Vec3b orange{30, 130, 250};
  std::vector<ObjectClass> classes = {ClassWithColour("orange ball", orange, 4),
                                      ClassWithColour("orange bucket", orange, 4),
                                      ClassWithColour("blue ball", kBlue, 4)};
  // Elongation s_r / (s_phi · (u_r + s_r / 2)): 1.0 and 1.4.
  const BoundingSlice ball{120.0, 1.0, 20.0, 20.0 / 130.0};
  const BoundingSlice bucket{120.0, -1.5, 28.0, 28.0 / (1.4 * 134.0)};
  // Blue, touching the ball's slice from outside: not a look-alike of it.
  const BoundingSlice blue{140.0, 1.0, 20.0, 20.0 / 150.0};
  LookAlikeScene() {
    classes[0].image_shape = ImageShapeModel{1.0, 0.05};
    classes[1].image_shape = ImageShapeModel{1.4, 0.05};
    classes[2].image_shape = ImageShapeModel{3.0, 0.05};  // fits nothing here
  }
  cv::Mat Render() const {
    cv::Mat image(camera.image_height(), camera.image_width(), CV_8UC3, cv::Scalar(128, 128, 128));
    PaintSlice(&image, camera, ball, orange);
    PaintSlice(&image, camera, bucket, orange);
    PaintSlice(&image, camera, blue, kBlue);
    return image;
  }
};

std::vector<std::string> ClassesOn(const std::vector<Detection>& detections,
                                   const BoundingSlice& slice) {
  std::vector<std::string> names;
  for (const Detection& d : detections)
    if (SliceCoverage(d.slice, slice) > 0.5) names.push_back(d.class_name);
  std::sort(names.begin(), names.end());
  return names;
}

TEST(BlobDetector, OfLookAlikeClassesOnTheSamePixelsKeepsTheBetterShapedOne) {
  const LookAlikeScene scene;
  const cv::Mat image = scene.Render();
  using Names = std::vector<std::string>;

  // The separation alone, without the view checks (which judge each blob on its own).
  BlobDetectorOptions separate;
  separate.max_view_distance = std::numeric_limits<double>::infinity();
  const std::vector<Detection> separated =
      BlobDetector(scene.camera, scene.classes, separate).Detect(image, 0);
  EXPECT_EQ(ClassesOn(separated, scene.ball), Names{"orange ball"});
  EXPECT_EQ(ClassesOn(separated, scene.bucket), Names{"orange bucket"});
  // The blue blob overlaps the ball's slice but shares no pixels with it: kept, although
  // its shape fits badly.
  EXPECT_EQ(ClassesOn(separated, scene.blue), Names{"blue ball"});
  for (const Detection& d : separated) {
    if (d.class_name == "blue ball")
      EXPECT_EQ(d.look_alike_classes, 0u);
    else
      EXPECT_EQ(d.look_alike_classes, d.class_index == 0 ? 2u : 1u) << d.class_name;
  }

  BlobDetectorOptions keep = separate;
  keep.separate_look_alikes = false;
  const std::vector<Detection> kept =
      BlobDetector(scene.camera, scene.classes, keep).Detect(image, 0);
  EXPECT_EQ(ClassesOn(kept, scene.ball), (Names{"orange ball", "orange bucket"}));
  EXPECT_EQ(ClassesOn(kept, scene.bucket), (Names{"orange ball", "orange bucket"}));

  // Without an image shape model a class is never dropped.
  std::vector<ObjectClass> no_shapes = scene.classes;
  no_shapes[1].image_shape.reset();
  const std::vector<Detection> unchecked =
      BlobDetector(scene.camera, no_shapes, separate).Detect(image, 0);
  EXPECT_EQ(ClassesOn(unchecked, scene.ball), (Names{"orange ball", "orange bucket"}));

  keep.look_alike_coverage = 0.0;
  EXPECT_THROW(BlobDetector(scene.camera, scene.classes, keep), Error);
}

TEST(BlobDetector, ShapeGateDropsOnlyDetectionsFarFromTheirClassShape) {
  const LookAlikeScene scene;
  BlobDetectorOptions gated;
  gated.max_shape_distance = 5.0;
  const std::vector<Detection> detections =
      BlobDetector(scene.camera, scene.classes, gated).Detect(scene.Render(), 0);
  using Names = std::vector<std::string>;
  EXPECT_EQ(ClassesOn(detections, scene.ball), Names{"orange ball"});
  EXPECT_EQ(ClassesOn(detections, scene.bucket), Names{"orange bucket"});
  // The blue blob is as long as wide; its class's model says 3.0 ± 0.05.
  EXPECT_EQ(ClassesOn(detections, scene.blue), Names{});
  gated.max_shape_distance = -1.0;
  EXPECT_THROW(BlobDetector(scene.camera, scene.classes, gated), Error);
}

TEST(BlobDetector, ShapeDistanceGrowsWithTheElongationErrorAndShrinksWithBlobSize) {
  const ImageShapeModel model{1.0, 0.05};
  const BoundingSlice fitting{100.0, 0.0, 20.0, 20.0 / 110.0};
  const BoundingSlice longer{100.0, 0.0, 26.0, 20.0 / 113.0};
  EXPECT_NEAR(ShapeSquaredDistance(model, fitting), 0.0, 1e-12);
  const double error = SliceElongation(longer) - 1.0;
  EXPECT_GT(ShapeSquaredDistance(model, longer), 0.0);
  EXPECT_LT(ShapeSquaredDistance(model, longer), error * error / (0.05 * 0.05));
  // Twice as large, same shape: quantisation matters less, so the distance grows.
  const BoundingSlice longer_and_larger{100.0, 0.0, 52.0, 40.0 / 126.0};
  EXPECT_NEAR(SliceElongation(longer_and_larger), SliceElongation(longer), 0.02);
  EXPECT_GT(ShapeSquaredDistance(model, longer_and_larger), ShapeSquaredDistance(model, longer));
}

}  // namespace
}  // namespace oslam

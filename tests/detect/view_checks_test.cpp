// The view checks of detect/view_checks.h and BlobDetectorOptions::max_view_distance:
// the size a slice shows when its base stands on the floor, against the
// observation model that made it, and the look-alikes it removes on a
// simulated scene.
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "calib/observation_model.h"
#include "detect/blob_detector.h"
#include "detect/colour_training.h"
#include "detect/evaluation.h"
#include "detect/trained_classes.h"
#include "detect/view_checks.h"
#include "samples/scene.h"
#include "samples/simulator.h"
#include "test_util.h"

namespace oslam {
namespace {

BoundingSlice SliceOf(const CameraModel& camera, double x, double y, double base_z, double diameter,
                      double height) {
  CylinderGeometry object;
  object.base_world = Eigen::Vector3d(x, y, base_z);
  object.diameter_m = diameter;
  object.height_m = height;
  BoundingSlice slice;
  EXPECT_TRUE(PredictSlice(camera, Pose2(), object, &slice));
  return slice;
}

ObjectClass ClassOfSize(double diameter, double diameter_std, double height, double height_std) {
  ObjectClass c;
  c.name = "test";
  c.diameter_mean_m = diameter;
  c.diameter_std_m = diameter_std;
  c.height_mean_m = height;
  c.height_std_m = height_std;
  return c;
}

// Inverting the observation model (method.md §4.2) with the base on the
// floor gives back the range, diameter and height that made the slice.
TEST(ViewChecks, SizeFromSupportInvertsTheObservationModel) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  for (double range : {0.8, 1.5, 2.5})
    for (double bearing : {0.3, 2.0, -2.6})
      for (auto [diameter, height] : {std::pair{0.1, 0.3}, {0.5, 0.6}, {0.13, 0.85}}) {
        SCOPED_TRACE(::testing::Message() << "range " << range << " bearing " << bearing << " size "
                                          << diameter << " x " << height);
        const BoundingSlice slice = SliceOf(camera, range * std::cos(bearing),
                                            range * std::sin(bearing), 0.0, diameter, height);
        SupportedViewSize size;
        ASSERT_TRUE(SizeFromSupport(camera, slice, 0.0, &size));
        EXPECT_NEAR(size.range_m, range, 1e-6 * range);
        EXPECT_NEAR(size.diameter_m, diameter, 1e-6);
        EXPECT_FALSE(size.top_cut);
        EXPECT_NEAR(size.height_m, height, 1e-6);
      }
}

// An object of the class's size standing on the floor is within 1 sigma per
// coordinate; a thin tall leg is no box by size and image shape, a box lifted 0.85 m off the floor
// (seen through the floor-support assumption it looks far larger) is no bottle.
TEST(ViewChecks, SupportedSizeDistanceSeparatesTheClassFromLookAlikes) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const ViewCheckOptions options;
  const ObjectClass box = ClassOfSize(0.6, 0.3, 0.6, 0.15);
  const ObjectClass bottle = ClassOfSize(0.1, 0.05, 0.3, 0.1);
  for (double range : {1.0, 2.0}) {
    SCOPED_TRACE(::testing::Message() << "range " << range);
    EXPECT_LT(SupportedSizeSquaredDistance(camera, box, SliceOf(camera, range, 0.5, 0, 0.5, 0.57),
                                           0.0, options),
              2.0);
    EXPECT_LT(SupportedSizeSquaredDistance(camera, bottle,
                                           SliceOf(camera, range, 0.5, 0, 0.09, 0.3), 0.0, options),
              2.0);
    // The leg is more than 2 sigma off the box's size; its image shape (a box's
    // slice about as long as wide) does the rest.
    const BoundingSlice leg = SliceOf(camera, range, 0.5, 0, 0.13, 0.85);
    EXPECT_GT(SupportedSizeSquaredDistance(camera, box, leg, 0.0, options), 4.0);
    ObjectClass shaped_box = box;
    shaped_box.image_shape = ImageShapeModel{1.06, 0.08};
    EXPECT_GT(ViewSquaredDistance(camera, shaped_box, leg, options), 9.0);
    EXPECT_GT(SupportedSizeSquaredDistance(
                  camera, bottle, SliceOf(camera, range, 0.5, 0.0, 0.45, 0.45), 0.0, options),
              9.0);
  }
  // A slice whose base would lie above the horizon cannot stand on the floor.
  BoundingSlice above = SliceOf(camera, 2.0, 0.0, 1.2, 0.2, 0.3);
  SupportedViewSize size;
  EXPECT_FALSE(SizeFromSupport(camera, above, 0.0, &size));
  EXPECT_TRUE(std::isinf(SupportedSizeSquaredDistance(camera, box, above, 0.0, options)));
}

// A slice cut by the mirror rim shows less than the object's radial length,
// so its elongation is a lower bound: the shape counts against the class only
// when the cut slice is already longer than the class's mean. A measured arc
// error of 1 px (a plain object's blob) makes a thin slice's shape sharper
// evidence than the 3 px assumed without a measurement.
TEST(ViewChecks, ACutSliceCountsItsShapeOnlyWhenAlreadyTooLong) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const ViewCheckOptions options;
  ObjectClass bucket = ClassOfSize(0.3, 0.2, 0.4, 0.2);
  bucket.image_shape = ImageShapeModel{1.33, 0.08};
  const double rim = camera.annulus().rim_radius_px;
  auto cut_slice = [&](double elongation) {
    BoundingSlice slice;
    slice.s_r_px = 40.0;
    slice.u_r_px = rim - slice.s_r_px;  // reaches the rim
    slice.s_phi_rad = slice.s_r_px / (elongation * (slice.u_r_px + 0.5 * slice.s_r_px));
    return slice;
  };
  auto shape_part = [&](const ObjectClass& c, const BoundingSlice& slice) {
    return ViewSquaredDistance(camera, c, slice, options) -
           SupportedSizeSquaredDistance(camera, c, slice, 0.0, options);
  };
  const BoundingSlice short_cut = cut_slice(0.9), long_cut = cut_slice(4.0);
  EXPECT_NEAR(SliceElongation(long_cut), 4.0, 1e-9);
  EXPECT_EQ(shape_part(bucket, short_cut), 0.0);  // could be a bucket's top cut off
  EXPECT_NEAR(shape_part(bucket, long_cut),
              ShapeSquaredDistance(*bucket.image_shape, long_cut, options.pixel_std_px, 3.0), 1e-9);
  ObjectClass measured = bucket;
  measured.image_shape->arc_error_px = 1.0;
  EXPECT_DOUBLE_EQ(ArcStdPx(bucket, options), options.arc_std_px);
  EXPECT_DOUBLE_EQ(ArcStdPx(measured, options), 1.0);
  EXPECT_GT(shape_part(measured, long_cut), 9.0);
  EXPECT_GT(shape_part(measured, long_cut), 2.0 * shape_part(bucket, long_cut));
}

// The ends within the margin of the blind disc and of the mirror rim are the
// cut ones; a camera without a rim cuts no top.
TEST(ViewChecks, CutsAreTheEndsAtTheBlindDiscAndTheRim) {
  const ViewCheckOptions options;  // margin 1.5 px
  MirrorAnnulus annulus;
  annulus.blind_radius_px = 50.0;
  annulus.rim_radius_px = 200.0;
  auto slice = [](double inner, double outer) {
    BoundingSlice s;
    s.u_r_px = inner;
    s.s_r_px = outer - inner;
    s.s_phi_rad = 0.1;
    return s;
  };
  const SliceCuts middle = CutsOf(annulus, slice(60, 150), options);
  EXPECT_FALSE(middle.base);
  EXPECT_FALSE(middle.top);
  EXPECT_FALSE(middle.any());
  EXPECT_TRUE(CutsOf(annulus, slice(51, 150), options).base);
  EXPECT_FALSE(CutsOf(annulus, slice(52, 150), options).base);
  EXPECT_TRUE(CutsOf(annulus, slice(60, 199), options).top);
  EXPECT_FALSE(CutsOf(annulus, slice(60, 198), options).top);
  const SliceCuts both = CutsOf(annulus, slice(50, 200), options);
  EXPECT_TRUE(both.base && both.top && both.any());
  annulus.rim_radius_px = 0.0;  // no rim known
  EXPECT_FALSE(CutsOf(annulus, slice(60, 1000), options).top);
}

TEST(ViewChecks, OptionsAreValidated) {
  ViewCheckOptions options;
  std::string why;
  EXPECT_TRUE(options.Validate(&why));
  options.pixel_std_px = 0;
  EXPECT_FALSE(options.Validate(&why));
  options = {};
  options.edge_margin_px = -1;
  EXPECT_FALSE(options.Validate(&why));
  options = {};
  options.arc_std_px = 0;
  EXPECT_FALSE(options.Validate(&why));
  BlobDetectorOptions detector;
  detector.max_view_distance = 0;
  EXPECT_FALSE(detector.Validate(&why));
  detector = {};
  detector.fragment_gap_px = -1;
  EXPECT_FALSE(detector.Validate(&why));
}

// tests/data/view_checks.yaml: a green box and a red bottle, a person's green
// legs and a red chair. Colour finds all four; the view checks keep every view
// of the two objects and drop the look-alikes.
TEST(ViewChecks, DropLookAlikesOfTheWrongSizeAndKeepEveryTrueView) {
  testing::TempDir dir;
  const std::string run = dir.Path("run");
  Simulate(LoadScene(std::string(OSLAM_SOURCE_DIR) + "/tests/data/view_checks.yaml"), run, {});
  const std::vector<ObjectClass> classes = ClassesTrainedOnGroundTruth(run);
  auto evaluate = [&](const BlobDetectorOptions& options) {
    return EvaluateDetectorOnRun(run, classes, options);
  };
  BlobDetectorOptions colour_only;
  colour_only.max_view_distance = std::numeric_limits<double>::infinity();
  colour_only.max_blob_colour_distance = std::numeric_limits<double>::infinity();
  const DetectionEvaluation before = evaluate(colour_only);
  const DetectionEvaluation after = evaluate(BlobDetectorOptions{});
  for (size_t c = 0; c < classes.size(); ++c) {
    const ClassDetectionStats &b = before.per_class[c], &a = after.per_class[c];
    std::printf(
        "%s: colour only recall %.2f precision %.2f (%d spurious); checked %.2f / %.2f (%d)\n",
        classes[c].name.c_str(), b.Recall(), b.Precision(), b.spurious, a.Recall(), a.Precision(),
        a.spurious);
    SCOPED_TRACE(classes[c].name);
    ASSERT_GE(b.sightings, 10);
    EXPECT_GE(b.spurious, 0.5 * b.sightings);  // the look-alikes fire by colour
    EXPECT_EQ(a.sightings_found, b.sightings_found);
    EXPECT_LE(a.spurious, 0.1 * b.spurious);
  }
}

}  // namespace
}  // namespace oslam

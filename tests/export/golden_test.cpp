// Golden-image tests: fixed inputs rendered and compared with the PNGs in
// tests/golden/ (tolerance and regeneration: tests/export/golden.h).
#include <cstdlib>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/hyperbolic_camera.h"
#include "calib/observation_model.h"
#include "core/error.h"
#include "export/export_fixture.h"
#include "export/figures.h"
#include "export/golden.h"
#include "export/overlay.h"

namespace oslam {
namespace {

using testing::ExpectMatchesGolden;
using testing::kMinMatchingFraction;
using testing::MatchingFraction;

FigureOptions SmallFigure() {
  FigureOptions options;
  options.width_px = 480;
  options.height_px = 400;
  options.min_existence = 0.1;
  return options;
}

TEST(Golden, BirdsEye) {
  ExpectMatchesGolden(BirdsEyeFigure(testing::FixtureScene(), SmallFigure()).image, "birdseye.png");
}

TEST(Golden, Perspective) {
  FigureOptions options = SmallFigure();
  options.width_px = 480;
  options.height_px = 360;
  ExpectMatchesGolden(RenderPerspective(testing::FixtureScene(), options), "perspective.png");
}

TEST(Golden, TrajectoryErrors) {
  ExpectMatchesGolden(TrajectoryErrorFigure(testing::FixtureScene(), SmallFigure()).image,
                      "trajectories.png");
}

// A plain synthetic frame (dark outside the mirror, grey annulus) seen by
// the LPA camera from the first estimated pose, with two detections: one at
// the green box's predicted slice (slightly off), one spurious.
TEST(Golden, Overlay) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  cv::Mat frame(camera.image_height(), camera.image_width(), CV_8UC3, cv::Scalar(40, 40, 40));
  const Eigen::Vector2d centre = camera.ImageCenter();
  const cv::Point c(cvRound(centre.x()), cvRound(centre.y()));
  cv::circle(frame, c, cvRound(camera.annulus().rim_radius_px), cv::Scalar(150, 150, 150),
             cv::FILLED);
  cv::circle(frame, c, cvRound(camera.annulus().blind_radius_px), cv::Scalar(20, 20, 20),
             cv::FILLED);

  const ExportScene scene = testing::FixtureScene();
  const OMapObject& box = scene.map.objects[0];
  BoundingSlice predicted;
  ASSERT_TRUE(PredictSlice(camera, scene.map.trajectory[0],
                           {box.base_world, box.diameter_m, box.height_m}, &predicted));
  Detection near_box;
  near_box.frame = 0;
  near_box.class_name = "green box";
  near_box.slice = predicted;
  near_box.slice.u_r_px += 4.0;
  near_box.slice.u_phi_rad += 0.05;
  Detection spurious = near_box;
  spurious.class_name = "pink ball";
  spurious.slice = {150.0, -2.0, 20.0, 0.2};
  Detection other_frame = near_box;
  other_frame.frame = 1;  // must not be drawn
  other_frame.slice.u_phi_rad += 1.5;

  const cv::Mat overlay =
      DrawOverlay(frame, 0, camera, scene, {near_box, spurious, other_frame}, 0.1);
  ExpectMatchesGolden(overlay, "overlay.png");
}

// The comparison is not vacuous: the same figure with one object's pi
// changed is rejected.
TEST(Golden, ComparisonRejectsAChangedFigure) {
  ExportScene scene = testing::FixtureScene();
  const cv::Mat original = BirdsEyeFigure(scene, SmallFigure()).image;
  scene.map.objects[0].existence_probability = 0.3;
  scene.map.objects[0].base_world.x() += 0.2;
  const cv::Mat changed = BirdsEyeFigure(scene, SmallFigure()).image;
  EXPECT_EQ(MatchingFraction(original, original), 1.0);
  EXPECT_LT(MatchingFraction(changed, original), kMinMatchingFraction);
}

TEST(Overlay, FrameWithoutEstimatedPoseIsAnError) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const cv::Mat frame(camera.image_height(), camera.image_width(), CV_8UC3, cv::Scalar::all(0));
  const ExportScene scene = testing::FixtureScene();
  EXPECT_THROW(
      DrawOverlay(frame, static_cast<long>(scene.map.trajectory.size()), camera, scene, {}, 0.1),
      Error);
}

}  // namespace
}  // namespace oslam

// The VTK views (export/vtk_view.h), rendered off-screen through EGL as
// perspective.png and `oslam view --screenshot` do: compared with golden
// images (tests/export/golden.h); the comparison fails when an object or a
// trajectory is missing, in the 3D drawing itself (the legend masked out).
#include "export/vtk_view.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "apps/commands.h"
#include "core/error.h"
#include "export/display_scene.h"
#include "export/export_fixture.h"
#include "export/golden.h"
#include "test_util.h"

namespace oslam {
namespace {

// The fixture with a second pink ball, so removing the first leaves the
// legend as it is.
ExportScene ViewScene() {
  ExportScene scene = testing::FixtureScene();
  scene.map.objects.push_back(
      testing::FixtureObject(5, "pink ball", {0.9, -1.0, 0.0}, 0.3, 0.28, 0.4));
  return scene;
}

cv::Mat Render(const ExportScene& scene) {
  ViewOptions options;
  options.width_px = 640;
  options.height_px = 480;
  options.selected_pose = 5;
  ExportOptions models;
  models.min_existence = options.min_existence;
  return RenderView(scene, BuildDisplayScene(scene, models), options);
}

TEST(View, MatchesTheGolden) {
  const cv::Mat image = Render(ViewScene());
  ASSERT_EQ(image.cols, 640);
  ASSERT_EQ(image.rows, 480);
  ASSERT_EQ(image.type(), CV_8UC3);
  testing::ExpectMatchesGolden(image, "view.png");
}

TEST(View, ComparisonFailsWithoutAnObjectOrATrajectory) {
  if (testing::Regenerating()) GTEST_SKIP() << "regenerating the goldens";
  const cv::Mat golden = cv::imread(testing::GoldenPath("view.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(golden.empty());
  // The scene below the legend (its rows are the same in all three images).
  const cv::Rect scene_part(0, 200, 640, 280);
  ExportScene no_ball = ViewScene();
  no_ball.map.objects.erase(no_ball.map.objects.begin() + 1);  // pink ball 2
  const cv::Mat without_object = Render(no_ball);
  EXPECT_FALSE(testing::MatchesGolden(without_object, golden));
  EXPECT_GT(testing::DifferingBlobPixels(without_object(scene_part), golden(scene_part)), 0);

  ExportScene no_truth = ViewScene();
  no_truth.ground_truth.clear();
  const cv::Mat without_trajectory = Render(no_truth);
  EXPECT_FALSE(testing::MatchesGolden(without_trajectory, golden));
  EXPECT_GT(testing::DifferingBlobPixels(without_trajectory(scene_part), golden(scene_part)), 0);
}

TEST(View, ScreenshotCommandWritesThePng) {
  testing::TempDir dir;
  const std::string png = dir.Path("view.png");
  ASSERT_EQ(RunViewCommand({std::string(OSLAM_SOURCE_DIR) + "/tests/data/export_omap.json",
                            "--screenshot", png, "--size", "320x240"}),
            0);
  const cv::Mat image = cv::imread(png, cv::IMREAD_COLOR);
  EXPECT_EQ(image.cols, 320);
  EXPECT_EQ(image.rows, 240);
  EXPECT_THROW(RunViewCommand({std::string(OSLAM_SOURCE_DIR) + "/tests/data/export_omap.json",
                               "--screenshot", png, "--size", "320by240"}),
               UsageError);
}

}  // namespace
}  // namespace oslam

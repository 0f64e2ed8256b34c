// The figures of an O-Map (figures.h) on small scenes: the size asked for,
// an object's colour where it is drawn and background where nothing is, the
// trajectory error plot's lines, the PNG files, and invalid options. The
// golden tests compare whole figures; these check what the figures mean.
#include "export/figures.h"

#include <algorithm>
#include <filesystem>
#include <limits>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "export/export_files.h"
#include "export/export_fixture.h"
#include "test_util.h"

namespace oslam {
namespace {

using testing::FixtureClass;
using testing::FixtureObject;

const cv::Vec3b kWhitePixel(255, 255, 255);
const Rgb kGreen{0, 200, 0};

FigureOptions Size(int width, int height) {
  FigureOptions options;
  options.width_px = width;
  options.height_px = height;
  return options;
}

// One green box of 1 m at (1, 0.5), a pink ball below the existence
// threshold, and no trajectories (so no legend).
ExportScene OneObjectScene() {
  ExportScene scene;
  scene.map.objects = {FixtureObject(1, "green box", {1.0, 0.5, 0.0}, 1.0, 0.6, 1.0),
                       FixtureObject(2, "pink ball", {0.3, 1.2, 0.0}, 0.4, 0.4, 0.05)};
  scene.classes = {FixtureClass("green box", kGreen), FixtureClass("pink ball", {240, 110, 170})};
  return scene;
}

// Where the bird's-eye view draws the floor point (x, y): the extent of the
// shown objects and trajectories (0.5 m margin) scaled uniformly to fit,
// centred, world y up the image.
cv::Point BirdsEyePixel(const ExportScene& scene, const FigureOptions& options, double x,
                        double y) {
  const Eigen::Vector4d e = FloorExtent(scene, options.min_existence, 0.5);
  const double scale =
      std::min(options.width_px / (e[2] - e[0]), options.height_px / (e[3] - e[1]));
  const double offset_x = 0.5 * (options.width_px - scale * (e[2] - e[0]));
  const double offset_y = 0.5 * (options.height_px - scale * (e[3] - e[1]));
  return {cvRound(offset_x + scale * (x - e[0])),
          cvRound(options.height_px - offset_y - scale * (y - e[1]))};
}

cv::Vec3b Bgr3(const Rgb& rgb) {
  return cv::Vec3b(rgb[2], rgb[1], rgb[0]);
}

TEST(Figures, OptionsValidationNamesTheBadValue) {
  std::string why;
  EXPECT_TRUE(FigureOptions().Validate(&why));
  EXPECT_TRUE(Size(64, 64).Validate(&why));
  const std::vector<std::pair<FigureOptions, std::string>> bad = {
      {Size(63, 400), "64x64"},
      {Size(400, 10), "64x64"},
      {[] {
         FigureOptions o;
         o.min_existence = -0.1;
         return o;
       }(),
       "min-existence"},
      {[] {
         FigureOptions o;
         o.min_existence = std::numeric_limits<double>::quiet_NaN();
         return o;
       }(),
       "min-existence"},
      {[] {
         FigureOptions o;
         o.min_existence = 1.5;
         return o;
       }(),
       "min-existence"},
      {[] {
         FigureOptions o;
         o.cylinder_segments = 2;
         return o;
       }(),
       "segments"},
  };
  for (const auto& [options, name] : bad) {
    why.clear();
    EXPECT_FALSE(options.Validate(&why)) << name;
    EXPECT_NE(why.find(name), std::string::npos) << "\"" << why << "\" does not name " << name;
  }
}

TEST(Figures, ImagesHaveTheSizeAskedFor) {
  const ExportScene scene = testing::FixtureScene();
  for (const auto& [width, height] : {std::pair{320, 240}, {200, 330}, {64, 64}}) {
    const FigureOptions options = Size(width, height);
    for (const cv::Mat& image : {RenderBirdsEye(scene, options), RenderPerspective(scene, options),
                                 PlotTrajectoryErrors(scene, options)}) {
      EXPECT_EQ(image.cols, width);
      EXPECT_EQ(image.rows, height);
      EXPECT_EQ(image.type(), CV_8UC3);
    }
  }
}

// An opaque object is a disc of its class colour around its place on the
// floor; an object below the existence threshold is not drawn (its place
// stays background), and is once the threshold is lowered.
TEST(Figures, BirdsEyeDrawsShownObjectsInTheirClassColour) {
  const ExportScene scene = OneObjectScene();
  FigureOptions options = Size(300, 200);
  const cv::Mat image = RenderBirdsEye(scene, options);
  // 100 px per metre: the box is a disc of radius 50 px. Its centre carries
  // a marker and its label goes up and right, so look left of the centre.
  const cv::Point box = BirdsEyePixel(scene, options, 1.0, 0.5);
  EXPECT_EQ(box, cv::Point(150, 100));
  for (const cv::Point& inside : {box + cv::Point(-25, 0), box + cv::Point(-40, 10),
                                  box + cv::Point(-10, 30), box + cv::Point(0, 40)})
    EXPECT_EQ(image.at<cv::Vec3b>(inside), Bgr3(kGreen)) << inside;
  const cv::Point ball = BirdsEyePixel(scene, options, 0.3, 1.2);
  EXPECT_EQ(image.at<cv::Vec3b>(ball), kWhitePixel) << ball;
  EXPECT_EQ(image.at<cv::Vec3b>(box + cv::Point(-80, 0)), kWhitePixel);  // outside the disc
  EXPECT_EQ(image.at<cv::Vec3b>(box + cv::Point(-70, 30)), kWhitePixel);

  options.min_existence = 0.01;  // the ball is shown now (and the extent grows)
  const cv::Mat with_ball = RenderBirdsEye(scene, options);
  // Left of the ball's centre (and its marker).
  const cv::Vec3b ball_pixel = with_ball.at<cv::Vec3b>(BirdsEyePixel(scene, options, 0.2, 1.2));
  EXPECT_NE(ball_pixel, kWhitePixel);
  EXPECT_GT(ball_pixel[2], ball_pixel[1]);  // pink, faint (pi = 0.05): red above green
  EXPECT_EQ(with_ball.at<cv::Vec3b>(BirdsEyePixel(scene, options, 0.6, 0.5)), Bgr3(kGreen));
}

// The camera looks at the middle of the shown objects: a lone object is in
// the middle of the view, in a shade of its class colour, with background
// around it.
TEST(Figures, PerspectiveShowsTheObjectInTheMiddleOfTheView) {
  const ExportScene scene = OneObjectScene();
  const FigureOptions options = Size(240, 200);
  const cv::Mat image = RenderPerspective(scene, options);
  const cv::Vec3b middle = image.at<cv::Vec3b>(100, 120);
  EXPECT_LE(middle[0], 10) << middle;  // blue
  EXPECT_GE(middle[1], 90) << middle;  // green: Lambert shading keeps at least half
  EXPECT_LE(middle[2], 10) << middle;  // red
  for (const cv::Point& corner :
       {cv::Point(1, 1), cv::Point(238, 1), cv::Point(1, 198), cv::Point(238, 198)})
    EXPECT_EQ(image.at<cv::Vec3b>(corner), kWhitePixel) << corner;
  // Nothing pink: the ball is below the threshold.
  cv::Mat pink;
  cv::inRange(image, cv::Scalar(120, 60, 180), cv::Scalar(200, 140, 255), pink);
  EXPECT_EQ(cv::countNonZero(pink), 0);
}

// Odometry drifts away from the ground truth: its error line (red) rises
// from left to right; the estimate, on the ground truth, is no red.
TEST(Figures, TrajectoryPlotShowsTheErrorGrowing) {
  ExportScene scene;
  for (int i = 0; i < 30; ++i) {
    const Pose2 truth{0.1 * i, 0.0, 0.0};
    scene.ground_truth.push_back(truth);
    scene.map.trajectory.push_back(truth);
    scene.odometry.push_back({truth.x, 0.02 * i, 0.0});
  }
  const FigureOptions options = Size(400, 300);
  const cv::Mat image = PlotTrajectoryErrors(scene, options);
  cv::Mat red;  // odometry is drawn in (210, 40, 40)
  cv::inRange(image, cv::Scalar(0, 0, 150), cv::Scalar(110, 110, 255), red);
  ASSERT_GT(cv::countNonZero(red), 100);
  // Mean row of the red pixels in two column ranges of the plot (which spans
  // columns 52-388), the left one clear of the legend.
  auto mean_row = [&red](int from_col, int to_col) {
    double sum = 0;
    int count = 0;
    for (int r = 0; r < red.rows; ++r)
      for (int c = from_col; c < to_col; ++c)
        if (red.at<uchar>(r, c)) sum += r, ++count;
    EXPECT_GT(count, 0);
    return sum / std::max(count, 1);
  };
  EXPECT_LT(mean_row(300, 388), mean_row(100, 180) - 100);  // up by more than 100 px

  scene.odometry.clear();
  cv::inRange(PlotTrajectoryErrors(scene, options), cv::Scalar(0, 0, 150),
              cv::Scalar(110, 110, 255), red);
  EXPECT_EQ(cv::countNonZero(red), 0);
}

TEST(Figures, TrajectoryPlotNeedsGroundTruth) {
  ExportScene scene = testing::FixtureScene();
  scene.ground_truth.clear();
  EXPECT_THROW(PlotTrajectoryErrors(scene, Size(320, 240)), Error);
}

// A map 300 m across (the fixture scaled by 100): the grid and scale bar
// follow the extent, so the floor stays mostly background instead of a
// solid 1 m grid, and the many-object labels do not pile up.
TEST(Figures, BirdsEyeOfALargeMapKeepsTheGridSparse) {
  ExportScene scene = testing::FixtureScene();
  for (OMapObject& object : scene.map.objects) object.base_world *= 100.0;
  for (auto* trajectory : {&scene.map.trajectory, &scene.ground_truth, &scene.odometry})
    for (Pose2& pose : *trajectory) pose.x *= 100.0, pose.y *= 100.0;
  const cv::Mat image = RenderBirdsEye(scene, Size(320, 240));
  cv::Mat background;
  cv::inRange(image, cv::Scalar(250, 250, 250), cv::Scalar(255, 255, 255), background);
  const double background_fraction =
      static_cast<double>(cv::countNonZero(background)) / static_cast<double>(image.total());
  std::printf("large map: %.1f %% background\n", 100.0 * background_fraction);
  EXPECT_GT(background_fraction, 0.7);
}

// PNG is lossless: the file reads back as the image, missing folders are
// made; a file that cannot be written is an error naming it.
TEST(Figures, WritePngWritesTheImage) {
  testing::TempDir dir;
  const cv::Mat image = RenderBirdsEye(testing::FixtureScene(), Size(160, 120));
  const std::string path = dir.Path("new folder/birdseye.png");
  WritePng(image, path);
  const cv::Mat read = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_EQ(read.size(), image.size());
  EXPECT_EQ(cv::norm(read, image, cv::NORM_INF), 0.0);
  const std::string blocked = dir.Path("new folder/birdseye.png/figure.png");  // under a file
  try {
    WritePng(image, blocked);
    ADD_FAILURE() << "wrote below a file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(blocked), std::string::npos) << e.what();
  }
}

// The figure set: the two views at the size asked for, the error plot at
// half the height (at least 200 px) and only when there is ground truth.
TEST(Figures, WriteFiguresWritesEachFigure) {
  testing::TempDir dir;
  ExportScene scene = testing::FixtureScene();
  const FigureOptions options = Size(300, 500);
  EXPECT_EQ(WriteFigures(scene, options, dir.Path(), /*quiet=*/true),
            (std::vector<std::string>{"birdseye.png", "perspective.png", "trajectories.png"}));
  for (const auto& [name, size] : {std::pair{"birdseye.png", cv::Size(300, 500)},
                                   {"perspective.png", cv::Size(300, 500)},
                                   {"trajectories.png", cv::Size(300, 250)}})
    EXPECT_EQ(cv::imread(dir.Path(name)).size(), size) << name;

  testing::TempDir without;
  scene.ground_truth.clear();
  EXPECT_EQ(WriteFigures(scene, Size(300, 240), without.Path(), /*quiet=*/true),
            (std::vector<std::string>{"birdseye.png", "perspective.png"}));
  EXPECT_FALSE(std::filesystem::exists(without.Path("trajectories.png")));
}

}  // namespace
}  // namespace oslam

// The figures of an O-Map (figures.h) on small scenes: the size asked for,
// an object's colour where the plot's own axes put it and background where
// nothing is, faint objects faint, text that grows with the figure, the SVG
// and the CSV of what was drawn (re-read), the trajectory error plot, the
// files, and invalid options. The golden tests compare whole figures; these
// check what the figures mean.
#include "export/figures.h"

#include <algorithm>
#include <filesystem>
#include <limits>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/csv.h"
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
// threshold, and no trajectories.
ExportScene OneObjectScene() {
  ExportScene scene;
  scene.map.objects = {FixtureObject(1, "green box", {1.0, 0.5, 0.0}, 1.0, 0.6, 1.0),
                       FixtureObject(2, "pink ball", {0.3, 1.2, 0.0}, 0.4, 0.4, 0.05)};
  scene.classes = {FixtureClass("green box", kGreen), FixtureClass("pink ball", {240, 110, 170})};
  return scene;
}

cv::Vec3b At(const Figure& figure, double x, double y) {
  const cv::Point2d p = figure.PixelOf(x, y);
  return figure.image.at<cv::Vec3b>(cvRound(p.y), cvRound(p.x));
}

// Share of pixels that are not white.
double Ink(const cv::Mat& image) {
  cv::Mat white;
  cv::inRange(image, cv::Scalar(250, 250, 250), cv::Scalar(255, 255, 255), white);
  return 1.0 - static_cast<double>(cv::countNonZero(white)) / static_cast<double>(image.total());
}

TEST(Figures, OptionsValidationNamesTheBadValue) {
  std::string why;
  EXPECT_TRUE(FigureOptions().Validate(&why));
  EXPECT_TRUE(Size(64, 64).Validate(&why));
  for (const auto& [name, options] : std::vector<std::pair<std::string, FigureOptions>>{
           {"pixels", Size(63, 200)}, {"pixels", Size(200, 9000)}}) {
    EXPECT_FALSE(options.Validate(&why)) << name;
    EXPECT_NE(why.find(name), std::string::npos) << why;
  }
  FigureOptions bad = Size(200, 200);
  bad.min_existence = 1.5;
  EXPECT_FALSE(bad.Validate(&why));
  EXPECT_NE(why.find("min-existence"), std::string::npos) << why;
  bad = Size(200, 200);
  bad.cylinder_segments = 2;
  EXPECT_FALSE(bad.Validate(&why));
  EXPECT_NE(why.find("segments"), std::string::npos) << why;
}

TEST(Figures, ImagesHaveTheSizeAskedFor) {
  const ExportScene scene = testing::FixtureScene();
  for (const auto& [width, height] : {std::pair{320, 240}, {200, 300}}) {
    const FigureOptions options = Size(width, height);
    for (const cv::Mat& image :
         {BirdsEyeFigure(scene, options).image, RenderPerspective(scene, options),
          TrajectoryErrorFigure(scene, options).image}) {
      EXPECT_EQ(image.cols, width);
      EXPECT_EQ(image.rows, height);
      EXPECT_EQ(image.type(), CV_8UC3);
    }
  }
}

// The disc is where the plot's axes put the object, in its class colour
// at pi = 1, as wide as its diameter; around it is background; the pink
// ball below the threshold is not drawn. The plot keeps x and y to scale.
TEST(Figures, BirdsEyeDrawsShownObjectsInTheirClassColourToScale) {
  const ExportScene scene = OneObjectScene();
  const Figure figure = BirdsEyeFigure(scene, Size(500, 500));
  const double pixels_per_m_x = figure.viewport_px.width / (figure.window[1] - figure.window[0]);
  const double pixels_per_m_y = figure.viewport_px.height / (figure.window[3] - figure.window[2]);
  EXPECT_NEAR(pixels_per_m_x, pixels_per_m_y, 0.02 * pixels_per_m_x);
  for (const auto& [dx, dy] : {std::pair{0.0, -0.3}, {-0.3, 0.0}, {0.2, -0.35}}) {
    const cv::Vec3b pixel = At(figure, 1.0 + dx, 0.5 + dy);
    EXPECT_LE(std::abs(pixel[1] - 200), 3) << dx << "," << dy;  // green
    EXPECT_LE(pixel[0] + pixel[2], 6) << dx << "," << dy;
  }
  EXPECT_EQ(At(figure, 1.0 - 0.6, 0.5 - 0.3), kWhitePixel);  // beyond the 0.5 m radius
  // The pink ball (pi = 0.05) is below the default 0.1: nothing at its centre.
  const cv::Vec3b ball = At(figure, 0.3, 1.2);
  EXPECT_FALSE(ball[2] > ball[1] + 30) << "pink drawn";
}

// Opacity = pi: a faint object is pale, a certain one full colour.
TEST(Figures, BirdsEyeFadesObjectsByTheirExistenceProbability) {
  ExportScene scene = OneObjectScene();
  scene.map.objects[0].existence_probability = 0.2;
  const cv::Vec3b pale = At(BirdsEyeFigure(scene, Size(400, 400)), 1.0, 0.3);
  EXPECT_GT(pale[0], 150);  // blended with white: blue and red stay high
  EXPECT_GT(pale[2], 150);
  EXPECT_GT(pale[1], 200);
}

// Text grows with the figure: the title (the ink above the plot) is four
// times as tall at 1600 pixels as at 400.
TEST(Figures, TextScalesWithTheFigure) {
  const ExportScene scene = testing::FixtureScene();
  auto title_height = [&](int size) {
    const Figure figure = BirdsEyeFigure(scene, Size(size, size));
    const cv::Mat above = figure.image.rowRange(0, cvRound(figure.viewport_px.y) - 2);
    cv::Mat grey, dark;
    cv::cvtColor(above, grey, cv::COLOR_BGR2GRAY);
    dark = grey < 128;
    int first = -1, last = -1;
    for (int r = 0; r < dark.rows; ++r)
      if (cv::countNonZero(dark.row(r)) > 0) {
        if (first < 0) first = r;
        last = r;
      }
    return last - first + 1;
  };
  const int small = title_height(400), large = title_height(1600);
  EXPECT_GT(small, 4);
  EXPECT_NEAR(static_cast<double>(large) / small, 4.0, 0.8) << small << " vs " << large << " px";
}

// The SVG is the same drawing as vector graphics; the CSV lists every
// object and trajectory point drawn, and reads back.
TEST(Figures, BirdsEyeComesAsSvgAndCsvToo) {
  testing::TempDir dir;
  const ExportScene scene = testing::FixtureScene();
  const Figure figure = BirdsEyeFigure(scene, Size(400, 400));
  EXPECT_EQ(figure.svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(figure.svg.find("<svg"), std::string::npos);
  EXPECT_NE(figure.svg.find("</svg>"), std::string::npos);
  WriteTextFileAtomically(dir.Path("birdseye.csv"), figure.csv);
  const CsvTable table = CsvTable::Read(dir.Path("birdseye.csv"));
  size_t objects = 0, points = 0;
  for (size_t r = 0; r < table.num_rows(); ++r) {
    if (table.Text(r, table.ColumnIndex("mark")) == "object") {
      ++objects;
      EXPECT_GE(table.Double(r, table.ColumnIndex("existence_probability")), 0.1);
    } else {
      ++points;
    }
  }
  EXPECT_EQ(objects, 3u);  // the door (pi = 0.05) is left out
  EXPECT_EQ(points, 3 * scene.ground_truth.size());
}

// The odometry error (drift growing with time) rises from left to right;
// the CSV has the frame and one column per line.
TEST(Figures, TrajectoryPlotShowsTheErrorGrowing) {
  const ExportScene scene = testing::FixtureScene();
  const Figure figure = TrajectoryErrorFigure(scene, Size(400, 300));
  const std::string header = figure.csv.substr(0, figure.csv.find('\n'));
  EXPECT_EQ(header, "frame,estimated_error_m,odometry_error_m");
  const size_t n = scene.ground_truth.size();
  const double first = std::hypot(scene.odometry[1].x - scene.ground_truth[1].x,
                                  scene.odometry[1].y - scene.ground_truth[1].y);
  const double last = std::hypot(scene.odometry[n - 1].x - scene.ground_truth[n - 1].x,
                                 scene.odometry[n - 1].y - scene.ground_truth[n - 1].y);
  ASSERT_GT(last, first);
  // Red (odometry) near where the plot puts the last error, not the first.
  auto reddish_near = [&](double frame, double error) {
    const cv::Point2d p = figure.PixelOf(frame, error);
    for (int dy = -3; dy <= 3; ++dy)
      for (int dx = -3; dx <= 3; ++dx) {
        const cv::Vec3b c = figure.image.at<cv::Vec3b>(cvRound(p.y) + dy, cvRound(p.x) + dx);
        if (c[2] > 150 && c[1] < 120 && c[0] < 120) return true;
      }
    return false;
  };
  EXPECT_TRUE(reddish_near(n - 1, last));
  EXPECT_TRUE(reddish_near(1, first));
  EXPECT_FALSE(reddish_near(1, last));
}

TEST(Figures, TrajectoryPlotNeedsGroundTruth) {
  ExportScene scene = testing::FixtureScene();
  scene.ground_truth.clear();
  EXPECT_THROW(TrajectoryErrorFigure(scene, Size(320, 240)), Error);
}

// A map 300 m across (the fixture scaled by 100): the axes follow the
// extent, so the floor stays mostly background.
TEST(Figures, BirdsEyeOfALargeMapStaysReadable) {
  ExportScene scene = testing::FixtureScene();
  for (OMapObject& object : scene.map.objects) object.base_world *= 100.0;
  for (auto* trajectory : {&scene.map.trajectory, &scene.ground_truth, &scene.odometry})
    for (Pose2& pose : *trajectory) pose.x *= 100.0, pose.y *= 100.0;
  const double ink = Ink(BirdsEyeFigure(scene, Size(320, 240)).image);
  std::printf("large map: %.1f %% ink\n", 100.0 * ink);
  EXPECT_LT(ink, 0.3);
}

// PNG is lossless: the file reads back as the image, missing folders are
// made; a file that cannot be written is an error naming it.
TEST(Figures, WritePngWritesTheImage) {
  testing::TempDir dir;
  const cv::Mat image = BirdsEyeFigure(testing::FixtureScene(), Size(160, 120)).image;
  const std::string path = dir.Path("new folder/birdseye.png");
  WritePng(image, path);
  const cv::Mat read = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_EQ(read.size(), image.size());
  EXPECT_EQ(cv::norm(read, image, cv::NORM_INF), 0.0);
  const cv::Mat fast =
      cv::imdecode(cv::Mat(1, static_cast<int>(EncodePng(image, true).size()), CV_8U,
                           const_cast<char*>(EncodePng(image, true).data())),
                   cv::IMREAD_COLOR);
  EXPECT_EQ(cv::norm(fast, image, cv::NORM_INF), 0.0);
  const std::string blocked = dir.Path("new folder/birdseye.png/figure.png");  // under a file
  try {
    WritePng(image, blocked);
    ADD_FAILURE() << "wrote below a file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(blocked), std::string::npos) << e.what();
  }
}

// The figure set: each plot as PNG, SVG and CSV, the perspective view as
// PNG, the error plot at half the height (at least 200 px) and only when
// there is ground truth.
TEST(Figures, WriteFiguresWritesEachFigure) {
  testing::TempDir dir;
  ExportScene scene = testing::FixtureScene();
  const FigureOptions options = Size(300, 500);
  EXPECT_EQ(
      WriteFigures(scene, options, dir.Path(), /*quiet=*/true),
      (std::vector<std::string>{"birdseye.png", "birdseye.svg", "birdseye.csv", "perspective.png",
                                "trajectories.png", "trajectories.svg", "trajectories.csv"}));
  for (const auto& [name, size] : {std::pair{"birdseye.png", cv::Size(300, 500)},
                                   {"perspective.png", cv::Size(300, 500)},
                                   {"trajectories.png", cv::Size(300, 250)}})
    EXPECT_EQ(cv::imread(dir.Path(name)).size(), size) << name;

  testing::TempDir without;
  scene.ground_truth.clear();
  EXPECT_EQ(WriteFigures(scene, Size(300, 240), without.Path(), /*quiet=*/true),
            (std::vector<std::string>{"birdseye.png", "birdseye.svg", "birdseye.csv",
                                      "perspective.png"}));
  EXPECT_FALSE(std::filesystem::exists(without.Path("trajectories.png")));
}

}  // namespace
}  // namespace oslam

// The static mask found from a recording (detect/static_mask.h): frames whose
// world changes while a fixed "rig" (a bar and a disc sector) stays, under
// auto-exposure changes of ±25 % and sensor noise. Most of the rig must be
// masked and almost none of the world; the mask file round-trips.
#include "detect/static_mask.h"

#include <cmath>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "calib/hyperbolic_camera.h"
#include "core/error.h"
#include "core/image_file.h"
#include "core/run_folder.h"
#include "test_util.h"

namespace oslam {
namespace {

// 255 where the rig is: a radial bar 6 px wide to the right of the centre
// and a sector below it.
cv::Mat RigPixels(const CameraModel& camera) {
  cv::Mat rig = cv::Mat::zeros(camera.image_height(), camera.image_width(), CV_8UC1);
  const cv::Point centre(320, 240);
  cv::line(rig, centre + cv::Point(50, 0), centre + cv::Point(230, 0), cv::Scalar(255), 6);
  cv::ellipse(rig, centre, cv::Size(100, 100), 0, 60, 120, cv::Scalar(255), cv::FILLED);
  cv::Mat annulus(rig.size(), CV_8UC1);
  for (int y = 0; y < rig.rows; ++y)
    for (int x = 0; x < rig.cols; ++x)
      annulus.at<uint8_t>(y, x) = camera.IsInAnnulus(Eigen::Vector2d(x, y)) ? 255 : 0;
  return rig & annulus;
}

// Frame k: a coarse random world pattern drawn anew (the robot moved), the
// rig at grey 60, all times an exposure gain, plus noise of 2 grey levels.
cv::Mat Frame(const cv::Mat& rig, int k, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uniform(40.0, 200.0);
  std::normal_distribution<double> noise(0.0, 2.0);
  cv::Mat coarse(rig.rows / 8, rig.cols / 8, CV_32FC1);
  for (int y = 0; y < coarse.rows; ++y)
    for (int x = 0; x < coarse.cols; ++x) coarse.at<float>(y, x) = static_cast<float>(uniform(rng));
  cv::Mat world;
  cv::resize(coarse, world, rig.size(), 0, 0, cv::INTER_LINEAR);
  const double gain = 1.0 + 0.25 * std::sin(0.7 * k);
  cv::Mat frame(rig.size(), CV_8UC3);
  for (int y = 0; y < rig.rows; ++y)
    for (int x = 0; x < rig.cols; ++x) {
      const double value = (rig.at<uint8_t>(y, x) ? 60.0 : world.at<float>(y, x)) * gain;
      frame.at<cv::Vec3b>(y, x) = cv::Vec3b::all(cv::saturate_cast<uchar>(value + noise(rng)));
    }
  return frame;
}

TEST(StaticMask, FindsTheRigUnderChangingExposure) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const cv::Mat rig = RigPixels(camera);
  testing::TempDir dir;
  std::filesystem::create_directories(dir.Path("frames"));
  std::mt19937_64 rng(5);
  for (int k = 0; k < 30; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "frames/%06d.png", k);
    WriteImage(dir.Path(name), Frame(rig, k, rng));
  }
  const FrameSource frames(dir.Path());
  StaticMaskOptions options;
  options.margin_px = 0;  // compare pixel for pixel
  size_t progress = 0;
  const StaticMaskResult result =
      DetectStaticMask(frames, camera, options, [&](size_t done, size_t) { progress = done; });
  EXPECT_EQ(result.samples, 30);
  EXPECT_EQ(progress, 30u);
  const double rig_px = cv::countNonZero(rig);
  const double rig_masked = cv::countNonZero(rig & (result.mask == 0)) / rig_px;
  cv::Mat world = rig == 0;
  for (int y = 0; y < world.rows; ++y)
    for (int x = 0; x < world.cols; ++x)
      if (!camera.IsInAnnulus(Eigen::Vector2d(x, y))) world.at<uint8_t>(y, x) = 0;
  const double world_masked =
      cv::countNonZero(world & (result.mask == 0)) / static_cast<double>(cv::countNonZero(world));
  std::printf("rig masked %.3f, world masked %.4f, %.1f %% of the annulus\n", rig_masked,
              world_masked, 100 * result.masked_share_of_annulus);
  EXPECT_GT(rig_masked, 0.97);
  EXPECT_LT(world_masked, 0.01);

  // Written and read back: the same mask.
  WriteStaticMask(result.mask, dir.Path("mask.png"));
  const cv::Mat read = ReadStaticMask(dir.Path("mask.png"), 640, 480);
  EXPECT_EQ(cv::countNonZero(read != result.mask), 0);
  EXPECT_THROW(ReadStaticMask(dir.Path("mask.png"), 800, 600), Error);
  options.samples = 2;
  std::string why;
  EXPECT_FALSE(options.Validate(&why));
}

}  // namespace
}  // namespace oslam

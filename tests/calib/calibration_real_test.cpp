// Real catadioptric checkerboard sets (../shared/data/omni_calib, see its
// README): oslam's Mei calibration side by side with cv::omnidir on the same
// corners. Skips when the shared data is absent. Labelled slow.
#include <chrono>
#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "calib/calibration.h"
#include "calib/mei_camera.h"
#include "calib/rim_detection.h"
#include "test_util.h"

namespace oslam {
namespace {

struct RealSet {
  std::string folder;
  BoardPattern pattern;
  double expected_xi_max_error;  // README: parabolic set has xi close to 1 (< 0 disables)
};

class RealCalibrationSet : public ::testing::TestWithParam<RealSet> {};

TEST_P(RealCalibrationSet, OslamUsesEveryBoardAndMatchesOrBeatsOmnidir) {
  const std::string data = testing::SharedDataDir();
  if (data.empty()) GTEST_SKIP() << "../shared/data not found: real calibration sets skipped";
  const std::filesystem::path folder =
      std::filesystem::path(data) / "omni_calib" / GetParam().folder;
  if (!std::filesystem::is_directory(folder)) GTEST_SKIP() << folder << " not found";
  std::vector<std::filesystem::path> paths;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.path().extension() == ".jpg") paths.push_back(entry.path());
  std::sort(paths.begin(), paths.end());
  ASSERT_FALSE(paths.empty());

  const auto start = std::chrono::steady_clock::now();
  std::vector<CalibrationView> views;
  std::vector<cv::Mat> images;
  int found = 0;
  for (const auto& path : paths) {
    const cv::Mat image = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(image.empty()) << path;
    CalibrationView view;
    view.name = path.filename().string();
    view.board_found = DetectBoardCorners(image, GetParam().pattern, {}, &view.corners);
    found += view.board_found;
    views.push_back(view);
    images.push_back(image);
  }
  const double corner_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const int width = images[0].cols, height = images[0].rows;

  const RimDetectionResult rim = DetectMirrorRim(images);
  std::printf(
      "[%s] rim: %s centre (%.2f, %.2f) rim %.1f px (%d inliers, %.2f px rms), blind %s %.1f px\n",
      GetParam().folder.c_str(), rim.found ? "found" : rim.message.c_str(), rim.center_px.x(),
      rim.center_px.y(), rim.rim.radius, rim.rim_inliers, rim.rim_rms_px,
      rim.blind_found ? "found" : "not found", rim.blind.radius);

  CalibrationOptions options;
  const CalibrationResult oslam =
      CalibrateFromCorners(views, GetParam().pattern, width, height, options);
  const OpenCvOmnidirResult omnidir =
      CalibrateWithOpenCvOmnidir(views, GetParam().pattern, width, height, true);
  ASSERT_TRUE(omnidir.ok) << omnidir.error;
  const MeiParameters& p = dynamic_cast<const MeiCamera&>(*oslam.camera).parameters();
  const MeiParameters& q = omnidir.parameters;

  // oslam on exactly the views cv::omnidir kept, and cv::omnidir's intrinsics on every view.
  std::vector<CalibrationView> subset = views;
  for (size_t v = 0; v < subset.size(); ++v)
    subset[v].board_found = subset[v].board_found && std::count(omnidir.used_views.begin(),
                                                                omnidir.used_views.end(), int(v));
  const CalibrationResult same =
      CalibrateFromCorners(subset, GetParam().pattern, width, height, options);
  const double omnidir_all =
      MeiRmsWithFixedIntrinsics(MeiCamera(q, width, height, {0, 1}), views, GetParam().pattern);
  CalibrationOptions hyperbolic_options;
  hyperbolic_options.model = "hyperbolic";
  const CalibrationResult hyperbolic =
      CalibrateFromCorners(views, GetParam().pattern, width, height, hyperbolic_options);

  std::printf("[%s] boards found %d/%zu, corners %.2f s\n", GetParam().folder.c_str(), found,
              views.size(), corner_seconds);
  std::printf(
      "[%s] oslam mei     : %d views, RMS %.4f px, xi %.4f fx %.2f fy %.2f c (%.2f, %.2f) "
      "k1 %.4f k2 %.4f p1 %.5f p2 %.5f, %.2f s\n",
      GetParam().folder.c_str(), oslam.summary.views_used, oslam.summary.final_rms_px, p.xi,
      p.fx_px, p.fy_px, p.cx_px, p.cy_px, p.k1, p.k2, p.p1, p.p2, oslam.summary.seconds);
  std::printf(
      "[%s] cv::omnidir   : %zu views, RMS %.4f px, xi %.4f fx %.2f fy %.2f c (%.2f, %.2f) "
      "k1 %.4f k2 %.4f p1 %.5f p2 %.5f, %.2f s\n",
      GetParam().folder.c_str(), omnidir.used_views.size(), omnidir.rms_px, q.xi, q.fx_px, q.fy_px,
      q.cx_px, q.cy_px, q.k1, q.k2, q.p1, q.p2, omnidir.seconds);
  std::printf(
      "[%s] oslam on omnidir's %d views: RMS %.4f px; omnidir intrinsics on all %d views: "
      "RMS %.4f px; oslam hyperbolic: RMS %.4f px (f %.1f, b/a %.4f), %.2f s\n",
      GetParam().folder.c_str(), same.summary.views_used, same.summary.final_rms_px, found,
      omnidir_all, hyperbolic.summary.final_rms_px, hyperbolic.parameters[0],
      hyperbolic.camera->Intrinsics()[1] / hyperbolic.camera->Intrinsics()[0],
      hyperbolic.summary.seconds);
  for (const CalibrationView& view : oslam.views)
    std::printf("[%s]   %-16s %s RMS %.4f%s\n", GetParam().folder.c_str(), view.name.c_str(),
                view.board_found ? "used" : "NOT FOUND", view.rms_px,
                view.outlier ? " OUTLIER" : "");

  // No view silently dropped: every found board is in the fit.
  EXPECT_EQ(oslam.summary.views_used, found);
  EXPECT_GE(found, 8);
  EXPECT_LT(oslam.summary.final_rms_px, 1.0);
  // Same corners and views: oslam's minimum is at least as low as cv::omnidir's.
  EXPECT_LE(same.summary.final_rms_px, omnidir.rms_px + 1e-3);
  if (GetParam().expected_xi_max_error > 0) {
    EXPECT_NEAR(p.xi, 1.0, GetParam().expected_xi_max_error);
  }
}

INSTANTIATE_TEST_SUITE_P(OmniCalib, RealCalibrationSet,
                         ::testing::Values(RealSet{"vmr", {7, 6, 0.030}, -1.0},
                                           RealSet{"mei_parabolic", {8, 6, 0.042}, 0.05}),
                         [](const auto& info) { return info.param.folder; });

}  // namespace
}  // namespace oslam

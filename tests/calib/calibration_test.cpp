// Calibration on synthetic boards (known Mei camera and poses, 0.1 px noise,
// seeded).
#include "calib/calibration.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "calib/mei_camera.h"
#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

MeiParameters TrueMei() {
  MeiParameters p;
  p.xi = 0.95;
  p.fx_px = 302.0;
  p.fy_px = 298.5;
  p.cx_px = 512.3;
  p.cy_px = 383.7;
  p.k1 = -0.08;
  p.k2 = 0.015;
  p.p1 = 5e-4;
  p.p2 = -3e-4;
  return p;
}

// Boards 0.35..0.6 m from the viewpoint all around the mirror axis, facing it.
std::vector<CalibrationView> SyntheticViews(const MeiCamera& camera, const BoardPattern& pattern,
                                            int count, double noise_px, std::uint64_t seed) {
  std::mt19937_64 engine(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  const std::vector<Eigen::Vector3d> object = pattern.ObjectPoints();
  const Eigen::Vector3d half(0.5 * (pattern.cols - 1) * pattern.square_m,
                             0.5 * (pattern.rows - 1) * pattern.square_m, 0.0);
  std::vector<CalibrationView> views;
  for (int attempt = 0; static_cast<int>(views.size()) < count && attempt < 1000; ++attempt) {
    const double azimuth = 2.0 * M_PI * views.size() / count + 0.2 * uniform(engine);
    const double z = 0.35 * uniform(engine) + 0.1;  // mirror frame: +z towards the camera
    const Eigen::Vector3d direction =
        Eigen::Vector3d(std::cos(azimuth), std::sin(azimuth), z).normalized();
    const Eigen::Vector3d centre = (0.45 + 0.12 * uniform(engine)) * direction;
    // Board z axis towards the viewpoint, tilted a little, random roll.
    const Eigen::Vector3d normal =
        (-direction + 0.25 * Eigen::Vector3d(uniform(engine), uniform(engine), uniform(engine)))
            .normalized();
    Eigen::Vector3d x_axis = normal.unitOrthogonal();
    x_axis = Eigen::AngleAxisd(M_PI * uniform(engine), normal) * x_axis;
    Eigen::Matrix3d rotation;
    rotation.col(0) = x_axis;
    rotation.col(1) = normal.cross(x_axis);
    rotation.col(2) = normal;
    const Eigen::Vector3d translation = centre - rotation * half;
    CalibrationView view;
    view.name = "synthetic_" + std::to_string(views.size());
    view.board_found = true;
    bool visible = true;
    for (const Eigen::Vector3d& p : object) {
      Eigen::Vector2d pixel;
      if (!camera.ProjectMirrorPoint(rotation * p + translation, &pixel) ||
          !camera.IsInAnnulus(pixel)) {
        visible = false;
        break;
      }
      view.corners.push_back(pixel + Eigen::Vector2d(noise(engine), noise(engine)));
    }
    if (visible) views.push_back(view);
  }
  return views;
}

TEST(Calibration, RecoversAKnownMeiCameraFromNoisyBoards) {
  const MeiCamera truth(TrueMei(), 1024, 768, MirrorAnnulus{60.0, 380.0});
  const BoardPattern pattern{7, 6, 0.03};
  const std::vector<CalibrationView> views = SyntheticViews(truth, pattern, 12, 0.1, 42);
  ASSERT_EQ(views.size(), 12u);
  CalibrationOptions options;
  options.model = "mei";
  const CalibrationResult result = CalibrateFromCorners(views, pattern, 1024, 768, options);
  const auto* mei = dynamic_cast<const MeiCamera*>(result.camera.get());
  ASSERT_NE(mei, nullptr);
  const MeiParameters& p = mei->parameters();
  const MeiParameters t = TrueMei();
  EXPECT_EQ(result.summary.views_used, 12);
  EXPECT_LE(result.summary.final_rms_px, 0.3);
  // ξ and f are strongly correlated; the generalised focal length f (ξ + 1)
  // ... both are checked as the issue asks: f within 0.5 %.
  EXPECT_LT(std::abs(p.fx_px / t.fx_px - 1.0), 0.005) << p.fx_px;
  EXPECT_LT(std::abs(p.fy_px / t.fy_px - 1.0), 0.005) << p.fy_px;
  EXPECT_LT(std::hypot(p.cx_px - t.cx_px, p.cy_px - t.cy_px), 1.0);
  EXPECT_NEAR(p.xi, t.xi, 0.01);
  for (const CalibrationView& view : result.views) EXPECT_FALSE(view.outlier) << view.name;
  for (int i = 0; i < result.standard_deviations.size(); ++i)
    EXPECT_GT(result.standard_deviations[i], 0.0) << result.parameter_names[i];
  // A given mount yaw turns the camera about the vertical axis (as for the
  // hyperbolic model below).
  options.mount_yaw_rad = -0.7;
  const CalibrationResult turned = CalibrateFromCorners(views, pattern, 1024, 768, options);
  const Eigen::Vector3d point(1.2, 0.9, 0.1);
  Eigen::Vector2d straight_pixel, turned_pixel;
  ASSERT_TRUE(result.camera->ProjectToPixel(point, &straight_pixel));
  ASSERT_TRUE(turned.camera->ProjectToPixel(
      Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitZ()) * point, &turned_pixel));
  EXPECT_LT((straight_pixel - turned_pixel).norm(), 1e-6);
  std::printf(
      "synthetic Mei: RMS %.4f px, xi %.4f (%.4f), fx %.3f (%.3f), fy %.3f (%.3f), "
      "centre (%.3f, %.3f) (%.3f, %.3f), %.3f s\n",
      result.summary.final_rms_px, p.xi, t.xi, p.fx_px, t.fx_px, p.fy_px, t.fy_px, p.cx_px, p.cy_px,
      t.cx_px, t.cy_px, result.summary.seconds);
}

TEST(Calibration, OutlierViewIsReportedNotDropped) {
  const MeiCamera truth(TrueMei(), 1024, 768, MirrorAnnulus{60.0, 380.0});
  const BoardPattern pattern{7, 6, 0.03};
  std::vector<CalibrationView> views = SyntheticViews(truth, pattern, 10, 0.1, 7);
  ASSERT_EQ(views.size(), 10u);
  // Corrupt one view: two rows of corners shifted by several pixels.
  for (int i = 0; i < 14; ++i) views[3].corners[i] += Eigen::Vector2d(6.0, -5.0);
  const CalibrationResult result = CalibrateFromCorners(views, pattern, 1024, 768, {});
  EXPECT_EQ(result.summary.views_used, 10);
  EXPECT_TRUE(result.views[3].outlier);
  for (int v = 0; v < 10; ++v)
    if (v != 3) {
      EXPECT_FALSE(result.views[v].outlier) << v;
    }
}

TEST(Calibration, RecoversAKnownHyperbolicCamera) {
  // Boards imaged by the thesis' LPA hyperbolic camera: the hyperbolic model
  // must reproduce them (and its focal length) to noise level.
  HyperbolicCamera lpa = HyperbolicCamera::Preset("lpa");
  HyperbolicMirrorParameters hp = lpa.parameters();
  hp.flip_image_angle = true;
  lpa.set_parameters(hp);
  const BoardPattern pattern{7, 6, 0.03};
  std::mt19937_64 engine(3);
  std::normal_distribution<double> noise(0.0, 0.1);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<CalibrationView> views;
  const Eigen::Matrix3d robot_from_mirror = Eigen::Vector3d(1, -1, -1).asDiagonal();
  const Eigen::Vector3d focus(0, 0, hp.focus_height_m);
  for (int k = 0; k < 10; ++k) {
    const double azimuth = 2.0 * M_PI * k / 10;
    const Eigen::Vector3d direction =
        Eigen::Vector3d(std::cos(azimuth), std::sin(azimuth), 0.15 * uniform(engine)).normalized();
    const Eigen::Vector3d centre = (0.35 + 0.1 * uniform(engine)) * direction;
    const Eigen::Vector3d normal = (-direction).normalized();
    Eigen::Matrix3d rotation;
    rotation.col(0) = normal.unitOrthogonal();
    rotation.col(1) = normal.cross(rotation.col(0));
    rotation.col(2) = normal;
    const Eigen::Vector3d translation = centre - rotation * Eigen::Vector3d(0.09, 0.075, 0);
    CalibrationView view;
    view.name = "lpa_" + std::to_string(k);
    view.board_found = true;
    for (const Eigen::Vector3d& p : pattern.ObjectPoints()) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(
          lpa.ProjectToPixel(focus + robot_from_mirror * (rotation * p + translation), &pixel));
      view.corners.push_back(pixel + Eigen::Vector2d(noise(engine), noise(engine)));
    }
    views.push_back(view);
  }
  CalibrationOptions options;
  options.model = "hyperbolic";
  options.mirror_a_m = hp.mirror_a_m;
  options.focus_height_m = hp.focus_height_m;
  // b estimated: f and b are nearly interchangeable for a mirror this close
  // to parabolic (ξ ≈ 0.99), so only the fit itself is checked.
  const CalibrationResult free_b = CalibrateFromCorners(views, pattern, 640, 480, options);
  EXPECT_LE(free_b.summary.final_rms_px, 0.3);
  std::printf("hyperbolic, b estimated: RMS %.4f px, f %.2f (%.2f), b %.5f (%.5f)\n",
              free_b.summary.final_rms_px, free_b.camera->Intrinsics()[3], hp.focal_px,
              free_b.camera->Intrinsics()[1], hp.mirror_b_m);
  // b from the data sheet: f/c, centre to the tolerances.
  options.mirror_b_m = hp.mirror_b_m;
  const CalibrationResult result = CalibrateFromCorners(views, pattern, 640, 480, options);
  std::printf("%s\n", result.summary.BriefReport().c_str());
  const auto* hyperbolic = dynamic_cast<const HyperbolicCamera*>(result.camera.get());
  ASSERT_NE(hyperbolic, nullptr);
  EXPECT_LE(result.summary.final_rms_px, 0.3);
  EXPECT_LT(std::abs(hyperbolic->parameters().focal_px / hp.focal_px - 1.0), 0.005)
      << hyperbolic->parameters().focal_px;
  EXPECT_LT((hyperbolic->ImageCenter() - lpa.ImageCenter()).norm(), 1.0);
  // The calibrated camera is mounted like the original: same robot-frame projection.
  Eigen::Vector2d a, b;
  ASSERT_TRUE(lpa.ProjectToPixel({1.5, -0.7, 0.2}, &a));
  ASSERT_TRUE(hyperbolic->ProjectToPixel({1.5, -0.7, 0.2}, &b));
  EXPECT_LT((a - b).norm(), 1.0);

  // A given mount yaw turns the camera about the vertical axis: the turned
  // camera images a point turned with it where the unturned one did.
  options.mount_yaw_rad = 0.4;
  const CalibrationResult turned = CalibrateFromCorners(views, pattern, 640, 480, options);
  const Eigen::Vector3d point(1.5, -0.7, 0.2);
  Eigen::Vector2d straight_pixel, turned_pixel;
  ASSERT_TRUE(result.camera->ProjectToPixel(point, &straight_pixel));
  ASSERT_TRUE(turned.camera->ProjectToPixel(
      Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()) * point, &turned_pixel));
  EXPECT_LT((straight_pixel - turned_pixel).norm(), 1e-6);
}

TEST(Calibration, TooFewViewsIsAnError) {
  const MeiCamera truth(TrueMei(), 1024, 768, MirrorAnnulus{60.0, 380.0});
  const BoardPattern pattern{7, 6, 0.03};
  std::vector<CalibrationView> views = SyntheticViews(truth, pattern, 2, 0.1, 1);
  EXPECT_THROW(CalibrateFromCorners(views, pattern, 1024, 768, {}), Error);
  CalibrationOptions bad;
  bad.model = "fisheye";
  std::string why;
  EXPECT_FALSE(bad.Validate(&why));
  EXPECT_NE(why.find("model"), std::string::npos);
}

}  // namespace
}  // namespace oslam

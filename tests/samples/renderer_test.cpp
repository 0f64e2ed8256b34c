#include "samples/renderer.h"

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/calibration.h"
#include "core/bounding_slice.h"
#include "calib/observation_model.h"
#include "samples/simulator.h"
#include "test_util.h"

namespace oslam {
namespace {

// A flat-lit empty world (no walls, no lights, no noise) with the given
// objects, so every surface has exactly its colour in the image.
Scene FlatScene(const testing::TempDir& dir, const std::string& objects) {
  const std::string path = dir.Path("scene.yaml");
  std::ofstream(path) << "camera: {preset: lpa}\n"
                         "classes:\n"
                         "  - {name: can, display_rgb: [200, 30, 30], diameter_mean_m: 0.3, "
                         "diameter_std_m: 0.1, height_mean_m: 0.5, height_std_m: 0.1}\n"
                         "floor: {colour: [100, 100, 100]}\n"
                         "lighting: {ambient: 1.0}\n"
                         "sensor: {noise_std: 0}\n"
                         "objects:\n"
                      << objects << "path: {start_pose: [0.3, -0.2, 0.7], commands: F1}\n";
  return LoadScene(path);
}

// Bounding slice of the pixels of exactly colour (r, g, b).
BoundingSlice SliceOfColour(const CameraModel& camera, const cv::Mat& bgr, int r, int g, int b,
                            long* count) {
  std::vector<double> radii, angles;
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      const cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
      if (p[0] != b || p[1] != g || p[2] != r) continue;
      const PolarPoint polar = camera.PixelToPolar(Eigen::Vector2d(x, y));
      radii.push_back(polar.radius_px);
      angles.push_back(polar.angle_rad);
    }
  }
  *count = static_cast<long>(radii.size());
  return SliceOfPolarPoints(radii, angles);
}

double PolarRadius(const CameraModel& camera, const Pose2& pose, const Eigen::Vector3d& world) {
  PolarPoint polar;
  EXPECT_TRUE(camera.ProjectToPolar(pose.WorldToRobot(world), &polar));
  return polar.radius_px;
}

TEST(Renderer, CylinderFootprintAgreesWithTheCameraModelSlice) {
  testing::TempDir dir;
  const Scene scene = FlatScene(dir,
                                "  - {class: can, shape: cylinder, position_m: [1.8, 1.0], "
                                "diameter_m: 0.3, height_m: 0.5, colour: [200, 30, 30]}\n");
  const Pose2 pose = scene.path_spec.start;
  FrameRender render;
  Renderer(scene).Render(pose, {}, &render);
  long count = 0;
  const BoundingSlice measured = SliceOfColour(*scene.camera, render.image, 200, 30, 30, &count);
  ASSERT_GT(count, 100);
  EXPECT_EQ(count, render.visible_pixels[0]);

  BoundingSlice model;
  const Eigen::Vector3d base(1.8, 1.0, 0.0);
  ASSERT_TRUE(PredictSlice(*scene.camera, pose, {base, 0.3, 0.5}, &model));
  // Angular extent: the model's 2 atan(d / 2 rho) against the pixels, as arc
  // length at the base radius.
  const double arc_error = std::abs(measured.s_phi_rad - model.s_phi_rad) * model.u_r_px;
  const double centre_error =
      std::abs(WrapAngle(measured.u_phi_rad - model.u_phi_rad)) * model.u_r_px;
  // Radial extent: the silhouette's nearest base point and farthest top point
  // (the top is below the mirror focus, so its far edge is the outermost)
  // through the camera model.
  const Eigen::Vector2d toward = (base.head<2>() - Eigen::Vector2d(pose.x, pose.y)).normalized();
  const Eigen::Vector3d near_base(base.x() - 0.15 * toward.x(), base.y() - 0.15 * toward.y(), 0.0);
  const Eigen::Vector3d far_top(base.x() + 0.15 * toward.x(), base.y() + 0.15 * toward.y(), 0.5);
  const double inner_error =
      std::abs(measured.u_r_px - PolarRadius(*scene.camera, pose, near_base));
  const double outer_error =
      std::abs(measured.u_r_px + measured.s_r_px - PolarRadius(*scene.camera, pose, far_top));
  std::printf(
      "footprint vs camera model: arc width %.2f px, centre %.2f px, inner radius %.2f px, "
      "outer radius %.2f px (%ld pixels)\n",
      arc_error, centre_error, inner_error, outer_error, count);
  EXPECT_LT(arc_error, 2.0);
  EXPECT_LT(centre_error, 2.0);
  EXPECT_LT(inner_error, 2.0);
  EXPECT_LT(outer_error, 2.0);
}

TEST(Renderer, ThinPoleFootprintMatchesPredictSliceDirectly) {
  // For a thin pole the cylinder model's longitudinal section and the
  // silhouette coincide, so the slice itself must match the pixels.
  testing::TempDir dir;
  const Scene scene = FlatScene(dir,
                                "  - {class: can, shape: cylinder, position_m: [0.5, 1.2], "
                                "diameter_m: 0.04, height_m: 0.6, colour: [200, 30, 30]}\n");
  const Pose2 pose = scene.path_spec.start;
  FrameRender render;
  Renderer(scene).Render(pose, {}, &render);
  long count = 0;
  const BoundingSlice measured = SliceOfColour(*scene.camera, render.image, 200, 30, 30, &count);
  ASSERT_GT(count, 20);
  BoundingSlice model;
  ASSERT_TRUE(PredictSlice(*scene.camera, pose, {{0.5, 1.2, 0.0}, 0.04, 0.6}, &model));
  const double errors[4] = {
      std::abs(measured.u_r_px - model.u_r_px),
      std::abs(WrapAngle(measured.u_phi_rad - model.u_phi_rad)) * model.u_r_px,
      std::abs(measured.s_r_px - model.s_r_px),
      std::abs(measured.s_phi_rad - model.s_phi_rad) * model.u_r_px};
  std::printf("thin pole vs PredictSlice: u_r %.2f px, u_phi %.2f px, s_r %.2f px, s_phi %.2f px\n",
              errors[0], errors[1], errors[2], errors[3]);
  for (double error : errors) EXPECT_LT(error, 2.0);
}

TEST(Renderer, BearingBinsNeverDropASurface) {
  const Scene scene = LoadScene(std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/lab.yaml");
  const Renderer binned(scene);
  RendererOptions brute;
  brute.brute_force = true;
  const Renderer reference(scene, brute);
  for (const Pose2& pose : {Pose2{-1.8, -1.8, 0.0}, Pose2{0.1, 1.3, 2.9}, Pose2{1.7, -0.2, -1.2}}) {
    FrameRender a, b;
    binned.Render(pose, {1.0, 9}, &a);
    reference.Render(pose, {1.0, 9}, &b);
    EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::countNonZero(a.object_ids != b.object_ids), 0);
    EXPECT_EQ(a.visible_pixels, b.visible_pixels);
  }
}

TEST(Renderer, BlindDiscAndOutsideTheRimAreBlack) {
  const Scene scene = LoadScene(std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/lab.yaml");
  FrameRender render;
  Renderer(scene).Render(scene.path_spec.start, {1.0, 1}, &render);
  const Eigen::Vector2d centre = scene.camera->ImageCenter();
  EXPECT_EQ(render.image.at<cv::Vec3b>(static_cast<int>(centre.y()), static_cast<int>(centre.x())),
            cv::Vec3b(0, 0, 0));
  EXPECT_EQ(render.image.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
  // Inside the annulus everything is lit (the lab has no black surfaces).
  const int y = static_cast<int>(centre.y());
  const int x = static_cast<int>(centre.x() + 0.5 * (scene.camera->annulus().blind_radius_px +
                                                     scene.camera->annulus().rim_radius_px));
  const cv::Vec3b lit = render.image.at<cv::Vec3b>(y, x);
  EXPECT_GT(lit[0] + lit[1] + lit[2], 60);
}

TEST(Renderer, OccludedObjectGetsItsVisibleFraction) {
  testing::TempDir dir;
  // From (0.3, -0.2) a thin can taller than the camera stands in front of a
  // wide drum and hides its middle.
  Scene scene =
      FlatScene(dir,
                "  - {class: can, shape: cylinder, position_m: [1.8, -0.2], diameter_m: 0.3, "
                "height_m: 1.2, colour: [200, 30, 30]}\n"
                "  - {shape: cylinder, position_m: [3.3, -0.2], diameter_m: 0.8, height_m: 1.0, "
                "colour: [30, 30, 200]}\n");
  scene.path_spec.start.theta = 0.0;
  SimulationOptions options;
  options.max_frames = 1;
  Simulate(scene, dir.Path("run"), options);
  const std::optional<GroundTruth> truth = ReadGroundTruth(dir.Path("run"));
  ASSERT_TRUE(truth.has_value());
  ASSERT_EQ(truth->sightings.size(), 2u);
  EXPECT_EQ(truth->objects[1].class_name, "");  // a distractor
  EXPECT_DOUBLE_EQ(truth->sightings[0].visible_fraction, 1.0);
  EXPECT_GT(truth->sightings[1].visible_fraction, 0.2);
  EXPECT_LT(truth->sightings[1].visible_fraction, 0.9);
  BoundingSlice model;
  ASSERT_TRUE(PredictSlice(*scene.camera, truth->trajectory[0],
                           {truth->objects[0].base_world, 0.3, 1.2}, &model));
  EXPECT_NEAR(truth->sightings[0].u_r_px, model.u_r_px, 1e-9);
  EXPECT_NEAR(truth->sightings[0].s_phi_rad, model.s_phi_rad, 1e-12);
}

}  // namespace
}  // namespace oslam

namespace oslam {
namespace {

// Pixels of one channel whose ray goes down to the floor of a flat world.
std::vector<double> FloorValues(const CameraModel& camera, const FrameRender& render, int channel) {
  std::vector<double> values;
  for (int y = 0; y < render.image.rows; ++y) {
    for (int x = 0; x < render.image.cols; ++x) {
      Ray ray;
      const Eigen::Vector2d pixel(x, y);
      if (!camera.IsInAnnulus(pixel) || !camera.BackProjectPixel(pixel, &ray)) continue;
      if (ray.direction_robot.z() < -0.05)
        values.push_back(render.image.at<cv::Vec3b>(y, x)[channel]);
    }
  }
  return values;
}

TEST(Renderer, SensorNoiseAndExposureHaveTheirStatedSize) {
  testing::TempDir dir;
  Scene scene = FlatScene(dir, "  []\n");
  scene.sensor.noise_std = 4.0;
  const Renderer renderer(scene);
  FrameRender render;
  renderer.Render({0, 0, 0}, {1.0, 77}, &render);
  const std::vector<double> values = FloorValues(*scene.camera, render, 1);
  ASSERT_GT(values.size(), 10000u);
  double mean = 0, variance = 0;
  for (double v : values) mean += v;
  mean /= values.size();
  for (double v : values) variance += (v - mean) * (v - mean);
  variance /= values.size();
  EXPECT_NEAR(mean, 100.0, 0.1);
  // Quantisation adds 1/12 grey level^2 to the noise variance.
  EXPECT_NEAR(std::sqrt(variance - 1.0 / 12.0), 4.0, 0.1);

  scene.sensor.noise_std = 0.0;
  const Renderer quiet(scene);
  quiet.Render({0, 0, 0}, {0.5, 77}, &render);  // half exposure
  for (double v : FloorValues(*scene.camera, render, 1)) ASSERT_EQ(v, 50.0);
}

TEST(Renderer, ImageTextureIsMappedOntoTheSurface) {
  testing::TempDir dir;
  // A 2 x 1 image: left half red, right half blue, tiled on a 1 x 1 m wall
  // texture; the wall faces the robot at x = 1.5.
  cv::Mat image(1, 2, CV_8UC3);
  image.at<cv::Vec3b>(0, 0) = {0, 0, 255};
  image.at<cv::Vec3b>(0, 1) = {255, 0, 0};
  ASSERT_TRUE(cv::imwrite(dir.Path("halves.png"), image));
  Scene scene = FlatScene(dir,
                          "  []\nwalls:\n  - {points_m: [[1.5, 2], [1.5, -2]], colour: [0, 0, 0], "
                          "texture: {pattern: image, file: halves.png, size_m: [1, 1]}}\n");
  scene.path_spec.start = {0, 0, 0};
  FrameRender render;
  Renderer(scene).Render(scene.path_spec.start, {}, &render);
  // Along the wall (u from (1.5, 2) towards (1.5, -2)): u in [0, 0.5) red,
  // [0.5, 1) blue, repeating. Look at wall points at height 0.3 m.
  auto colour_at = [&](double y) {
    Eigen::Vector2d pixel;
    EXPECT_TRUE(scene.camera->ProjectToPixel(Eigen::Vector3d(1.5, y, 0.3), &pixel));
    return render.image.at<cv::Vec3b>(static_cast<int>(std::lround(pixel.y())),
                                      static_cast<int>(std::lround(pixel.x())));
  };
  EXPECT_EQ(colour_at(1.75), cv::Vec3b(0, 0, 255));  // u = 0.25: red (BGR)
  EXPECT_EQ(colour_at(1.25), cv::Vec3b(255, 0, 0));  // u = 0.75: blue
  EXPECT_EQ(colour_at(0.75), cv::Vec3b(0, 0, 255));  // u = 1.25: red again
}

}  // namespace
}  // namespace oslam

namespace oslam {
namespace {

TEST(Renderer, SiftFindsFeaturesOnNoiseTexturedObjects) {
  // The lab's green box carries a noise texture; from the start pose SIFT
  // must find keypoints on it (untextured balls give next to none).
  const Scene scene = LoadScene(std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/lab.yaml");
  FrameRender render;
  Renderer(scene).Render(scene.path_spec.start, {1.0, 3}, &render);
  cv::Mat grey;
  cv::cvtColor(render.image, grey, cv::COLOR_BGR2GRAY);
  std::vector<cv::KeyPoint> keypoints;
  cv::SIFT::create()->detect(grey, keypoints);
  int on_green_box = 0;
  for (const cv::KeyPoint& k : keypoints)
    if (render.object_ids.at<int>(cvRound(k.pt.y), cvRound(k.pt.x)) == 0) ++on_green_box;
  EXPECT_GE(on_green_box, 5) << keypoints.size() << " keypoints in the frame";
}

}  // namespace
}  // namespace oslam

namespace oslam {
namespace {

TEST(Renderer, CheckerboardCornersLandWhereTheCameraModelProjectsThem) {
  // A tilted, rolled 8 x 7 board seen by the LPA camera from a robot away
  // from the origin: the corners cv::findChessboardCornersSB finds in the
  // rendered image must be the camera model's projections of the board's
  // inner corners, to sub-pixel accuracy (the board is box-filtered over each
  // pixel, so edges are not quantised to whole pixels).
  testing::TempDir dir;
  const Pose2 pose{0.3, -0.2, 0.7};
  // Board centre 0.38 m from the robot's axis, bearing 0.5 rad in the robot
  // frame, 0.17 m below the mirror focus (z_m = 0.76 m).
  const double bearing = 0.5, distance = 0.38;
  const Eigen::Vector3d centre = pose.RobotToWorld(
      Eigen::Vector3d(distance * std::cos(bearing), distance * std::sin(bearing), 0.59));
  std::ofstream(dir.Path("scene.yaml"))
      << "camera: {preset: lpa}\n"
         "classes:\n"
         "  - {name: can, display_rgb: [200, 30, 30], diameter_mean_m: 0.3, "
         "diameter_std_m: 0.1, height_mean_m: 0.5, height_std_m: 0.1}\n"
         "floor: {colour: [100, 100, 100]}\n"
         "lighting: {ambient: 1.0}\n"
         "sensor: {noise_std: 0}\n"
         "objects:\n"
         "  - {shape: checkerboard, position_m: ["
      << centre.x() << ", " << centre.y() << ", " << centre.z()
      << "], cols: 8, rows: 7, square_m: 0.03, yaw_rad: " << pose.theta + bearing + M_PI / 2
      << ", pitch_rad: 0.55, roll_rad: 0.3, colour: [230, 230, 230], colour2: [20, 20, 20]}\n"
         "path: {start_pose: [0, 0, 0], commands: F1}\n";
  const Scene scene = LoadScene(dir.Path("scene.yaml"));
  FrameRender render;
  Renderer(scene).Render(pose, {}, &render);
  // Bearing bins never drop the board.
  FrameRender brute;
  Renderer(scene, {true}).Render(pose, {}, &brute);
  EXPECT_EQ(cv::norm(render.image, brute.image, cv::NORM_INF), 0.0);

  std::vector<Eigen::Vector2d> projected;
  for (const Eigen::Vector3d& corner : CheckerboardInnerCorners(scene.objects[0])) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(scene.camera->ProjectToPixel(pose.WorldToRobot(corner), &pixel));
    ASSERT_TRUE(scene.camera->IsInAnnulus(pixel));
    projected.push_back(pixel);
  }
  Corners detected;
  ASSERT_TRUE(DetectBoardCorners(render.image, {7, 6, 0.03}, {}, &detected));
  ASSERT_EQ(detected.size(), projected.size());
  double max_error = 0.0, sum_squares = 0.0;
  for (const Eigen::Vector2d& d : detected) {
    double nearest = 1e9;
    for (const Eigen::Vector2d& p : projected) nearest = std::min(nearest, (d - p).norm());
    max_error = std::max(max_error, nearest);
    sum_squares += nearest * nearest;
  }
  const double rms = std::sqrt(sum_squares / detected.size());
  std::printf("rendered board corners vs camera model: RMS %.3f px, max %.3f px\n", rms, max_error);
  EXPECT_LT(rms, 0.2);
  EXPECT_LT(max_error, 0.5);
}

}  // namespace
}  // namespace oslam

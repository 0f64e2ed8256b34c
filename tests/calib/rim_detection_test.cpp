// Mirror-rim detection (rim_detection.h): centre and radii of drawn annuli
// (with scene texture and noise, rim cut by the border), of frames rendered
// by the simulator through a decentred camera whose annulus is known, the
// circle fit itself, and what happens without a rim or with bad input.
#include "calib/rim_detection.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "calib/camera_io.h"
#include "calib/mei_camera.h"
#include "core/error.h"
#include "samples/renderer.h"
#include "samples/scene.h"
#include "test_util.h"

namespace oslam {
namespace {

// A bright annulus (rim, blind disc) on a dark background with random blobs
// inside the mirror (different per seed) and Gaussian noise.
cv::Mat AnnulusImage(const Eigen::Vector2d& centre, double blind, double rim, std::uint64_t seed) {
  cv::Mat image(600, 800, CV_8U, cv::Scalar(15));
  cv::circle(image, cv::Point(std::lround(centre.x() * 16), std::lround(centre.y() * 16)),
             std::lround(rim * 16), cv::Scalar(190), cv::FILLED, cv::LINE_AA, 4);
  if (blind > 0)
    cv::circle(image, cv::Point(std::lround(centre.x() * 16), std::lround(centre.y() * 16)),
               std::lround(blind * 16), cv::Scalar(40), cv::FILLED, cv::LINE_AA, 4);
  std::mt19937_64 engine(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int i = 0; i < 40; ++i) {
    const double angle = 2 * M_PI * uniform(engine);
    const double radius = blind + 10 + (rim - blind - 30) * uniform(engine);
    cv::circle(image,
               cv::Point(static_cast<int>(centre.x() + radius * std::cos(angle)),
                         static_cast<int>(centre.y() + radius * std::sin(angle))),
               static_cast<int>(3 + 12 * uniform(engine)), cv::Scalar(60 + 120 * uniform(engine)),
               cv::FILLED);
  }
  cv::Mat noise(image.size(), CV_16S);
  cv::randn(noise, 0, 12);
  cv::Mat noisy;
  image.convertTo(noisy, CV_16S);
  noisy += noise;
  noisy.convertTo(image, CV_8U);
  return image;
}

TEST(RimDetection, FindsCentreAndRadiiOfASyntheticAnnulus) {
  cv::theRNG().state = 12345;
  const Eigen::Vector2d centre(407.3, 291.8);
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 5; ++i) frames.push_back(AnnulusImage(centre, 48.0, 262.5, 100 + i));
  const RimDetectionResult result = DetectMirrorRim(frames);
  ASSERT_TRUE(result.found) << result.message;
  EXPECT_LT((result.center_px - centre).norm(), 1.0) << result.center_px.transpose();
  EXPECT_NEAR(result.rim.radius, 262.5, 1.0);
  ASSERT_TRUE(result.blind_found);
  EXPECT_NEAR(result.blind.radius, 48.0, 1.0);
  EXPECT_LT((result.blind.center - centre).norm(), 1.0);
  EXPECT_GT(result.annulus.blind_radius_px, 48.0);
  EXPECT_LT(result.annulus.rim_radius_px, 262.5);
  // Most rays found the rim, on the circle to a fraction of a pixel.
  EXPECT_GT(result.rim_inliers, 0.9 * RimDetectionOptions().num_rays);
  EXPECT_LT(result.rim_rms_px, 0.5);
}

TEST(RimDetection, RimCutByTheImageBorderStillFits) {
  cv::theRNG().state = 777;
  const Eigen::Vector2d centre(398.6, 300.4);
  const std::vector<cv::Mat> frames = {AnnulusImage(centre, 40.0, 340.0, 5)};  // cut top/bottom
  const RimDetectionResult result = DetectMirrorRim(frames);
  ASSERT_TRUE(result.found) << result.message;
  EXPECT_LT((result.center_px - centre).norm(), 1.0) << result.center_px.transpose();
  EXPECT_NEAR(result.rim.radius, 340.0, 1.0);
}

TEST(RimDetection, WithoutABlindDiscTheAnnulusStartsAtTheCentre) {
  cv::theRNG().state = 99;
  const Eigen::Vector2d centre(401.0, 298.5);
  const RimDetectionResult result = DetectMirrorRim({AnnulusImage(centre, 0.0, 250.0, 3)});
  ASSERT_TRUE(result.found) << result.message;
  EXPECT_NEAR(result.rim.radius, 250.0, 1.0);
  EXPECT_FALSE(result.blind_found);
  EXPECT_EQ(result.annulus.blind_radius_px, 0.0);
  EXPECT_NEAR(result.annulus.rim_radius_px, result.rim.radius - 2.0, 1e-12);
}

TEST(RimDetection, TheMarginShrinksTheAnnulusOnBothSides) {
  cv::theRNG().state = 4242;
  const std::vector<cv::Mat> frames = {AnnulusImage({400.0, 300.0}, 50.0, 240.0, 8)};
  RimDetectionOptions options;
  options.margin_px = 0.0;
  const RimDetectionResult exact = DetectMirrorRim(frames, options);
  options.margin_px = 5.0;
  const RimDetectionResult shrunk = DetectMirrorRim(frames, options);
  ASSERT_TRUE(exact.found && exact.blind_found);
  ASSERT_TRUE(shrunk.found && shrunk.blind_found);
  // Without a margin: the rim circle, and the blind circle grown by its
  // offset from the rim's centre (the blind disc must lie inside it).
  EXPECT_DOUBLE_EQ(exact.annulus.rim_radius_px, exact.rim.radius);
  EXPECT_DOUBLE_EQ(exact.annulus.blind_radius_px,
                   exact.blind.radius + (exact.blind.center - exact.center_px).norm());
  EXPECT_DOUBLE_EQ(shrunk.annulus.rim_radius_px, exact.annulus.rim_radius_px - 5.0);
  EXPECT_DOUBLE_EQ(shrunk.annulus.blind_radius_px, exact.annulus.blind_radius_px + 5.0);
}

TEST(RimDetection, UniformImageHasNoRim) {
  const std::vector<cv::Mat> frames = {cv::Mat(300, 400, CV_8U, cv::Scalar(128))};
  const RimDetectionResult result = DetectMirrorRim(frames);
  EXPECT_FALSE(result.found);
  EXPECT_NE(result.message.find("no circular bright-to-dark mirror rim"), std::string::npos)
      << result.message;
}

TEST(RimDetection, BadInputIsRefusedOrReported) {
  const RimDetectionResult none = DetectMirrorRim({});
  EXPECT_FALSE(none.found);
  EXPECT_EQ(none.message, "no images");
  EXPECT_THROW(DetectMirrorRim({cv::Mat(300, 400, CV_8U, cv::Scalar(0)),
                                cv::Mat(300, 401, CV_8U, cv::Scalar(0))}),
               Error);
  auto why_invalid = [](RimDetectionOptions options) {
    std::string why;
    EXPECT_FALSE(options.Validate(&why));
    EXPECT_THROW(DetectMirrorRim({cv::Mat(30, 40, CV_8U, cv::Scalar(0))}, options), Error);
    return why;
  };
  RimDetectionOptions options;
  std::string why;
  EXPECT_TRUE(options.Validate(&why)) << why;
  options.num_rays = 15;
  EXPECT_EQ(why_invalid(options), "num_rays must be >= 16");
  options = {};
  options.ransac_iterations = 0;
  EXPECT_EQ(why_invalid(options), "ransac_iterations must be >= 1");
  options = {};
  options.inlier_threshold_px = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(why_invalid(options), "inlier_threshold_px must be positive");
  options = {};
  options.blur_sigma_px = -1.0;
  EXPECT_EQ(why_invalid(options), "blur_sigma_px must be >= 0");
  options = {};
  options.min_inlier_fraction = 1.5;
  EXPECT_EQ(why_invalid(options), "min_inlier_fraction must be in (0, 1]");
  options = {};
  options.margin_px = -0.5;
  EXPECT_EQ(why_invalid(options), "margin_px must be >= 0");
}

// ---- frames rendered by the simulator ----

// A Mei camera whose centre is off the image centre, with its annulus.
MeiCamera DecentredCamera() {
  MeiParameters p;
  p.xi = 0.95;
  p.fx_px = p.fy_px = 150.0;
  p.cx_px = 331.4;
  p.cy_px = 236.2;
  p.focus_height_m = 0.8;
  return MeiCamera(p, 640, 480, MirrorAnnulus{45.0, 200.0});
}

// A lit, closed, textured room seen through `camera`: every annulus pixel is
// lit, everything outside it black (the renderer's rule).
Scene RoomThrough(const testing::TempDir& dir, const CameraModel& camera) {
  SaveCamera(camera, dir.Path("camera.yaml"));
  const std::string path = dir.Path("scene.yaml");
  std::ofstream(path)
      << "camera: {file: camera.yaml}\n"
         "classes:\n"
         "  - {name: can, display_rgb: [200, 30, 30], diameter_mean_m: 0.3, "
         "diameter_std_m: 0.1, height_mean_m: 0.5, height_std_m: 0.1}\n"
         "walls:\n"
         "  - {points_m: [[-3, -3], [3, -3], [3, 3], [-3, 3]], closed: 1, height_m: 2.5, "
         "colour: [190, 185, 170], texture: {pattern: noise, colour2: [120, 110, 100], "
         "scale_m: 0.3, seed: 2}}\n"
         "floor: {colour: [150, 140, 120], texture: {pattern: checker, colour2: [90, 85, 80], "
         "scale_m: 0.4}}\n"
         "ceiling: {height_m: 2.5, colour: [220, 220, 215]}\n"
         "lighting: {ambient: 0.7}\n"
         "sensor: {noise_std: 2}\n"
         "objects:\n"
         "  - {class: can, shape: cylinder, position_m: [1.2, 0.5], diameter_m: 0.3, "
         "height_m: 0.5, colour: [200, 30, 30]}\n"
         "path: {start_pose: [0, 0, 0], commands: F1}\n";
  return LoadScene(path);
}

TEST(RimDetection, FindsTheKnownAnnulusOfRenderedFrames) {
  const MeiCamera camera = DecentredCamera();
  testing::TempDir dir;
  const Scene scene = RoomThrough(dir, camera);
  const Renderer renderer(scene);
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 3; ++i) {
    FrameRender render;
    renderer.Render(Pose2{-0.8 + 0.7 * i, 0.3 * i - 0.4, 1.1 * i},
                    {1.0, static_cast<std::uint64_t>(i + 1)}, &render);
    frames.push_back(render.image);  // BGR, as the calibrate command reads them
  }
  const RimDetectionResult result = DetectMirrorRim(frames);
  ASSERT_TRUE(result.found) << result.message;
  ASSERT_TRUE(result.blind_found);
  const Eigen::Vector2d centre = camera.ImageCenter();
  std::printf("rendered: centre off by %.3f px, rim %.3f px (200), blind %.3f px (45)\n",
              (result.center_px - centre).norm(), result.rim.radius, result.blind.radius);
  // The rendered rim is the set of pixel centres within 200 px: its edge is
  // accurate to the pixel grid.
  EXPECT_LT((result.center_px - centre).norm(), 0.25) << result.center_px.transpose();
  EXPECT_NEAR(result.rim.radius, 200.0, 0.25);
  EXPECT_LT((result.blind.center - centre).norm(), 0.25) << result.blind.center.transpose();
  EXPECT_NEAR(result.blind.radius, 45.0, 0.25);
  // Every pixel of the detected annulus is a pixel the camera images.
  MeiCamera detected = camera;
  MeiParameters p = detected.parameters();
  p.cx_px = result.center_px.x();
  p.cy_px = result.center_px.y();
  detected.set_parameters(p);
  detected.set_annulus(result.annulus);
  long inside = 0;
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x)
      if (detected.IsInAnnulus({x, y})) {
        ++inside;
        ASSERT_TRUE(camera.IsInAnnulus({x, y})) << x << " " << y;
      }
  // ...and it leaves out only the margins' rings.
  const double true_area = M_PI * (200.0 * 200.0 - 45.0 * 45.0);
  EXPECT_GT(inside, 0.95 * true_area);
}

// ---- the circle fit ----

TEST(CircleFit, ExactPointsGiveTheCircle) {
  std::vector<Eigen::Vector2d> points;
  for (int k = 0; k < 7; ++k)
    points.push_back(Eigen::Vector2d(3.0, -2.0) + 5.0 * Eigen::Vector2d(std::cos(k), std::sin(k)));
  const Circle circle = FitCircle(points);
  EXPECT_LT((circle.center - Eigen::Vector2d(3.0, -2.0)).norm(), 1e-9);
  EXPECT_NEAR(circle.radius, 5.0, 1e-9);
  // Three points are enough, also on a short arc.
  const Eigen::Vector2d centre(400.0, 300.0);
  const std::vector<Eigen::Vector2d> arc = {
      centre + 250.0 * Eigen::Vector2d(1.0, 0.0),
      centre + 250.0 * Eigen::Vector2d(std::cos(0.2), std::sin(0.2)),
      centre + 250.0 * Eigen::Vector2d(std::cos(0.4), std::sin(0.4))};
  const Circle from_arc = FitCircle(arc);
  EXPECT_LT((from_arc.center - centre).norm(), 1e-6);
  EXPECT_NEAR(from_arc.radius, 250.0, 1e-6);
}

double SumOfSquaredDistances(const std::vector<Eigen::Vector2d>& points, const Circle& circle) {
  double sum = 0;
  for (const Eigen::Vector2d& p : points)
    sum += std::pow((p - circle.center).norm() - circle.radius, 2);
  return sum;
}

TEST(CircleFit, MinimisesTheGeometricDistanceOnANoisyArc) {
  // A quarter circle with +-0.8 px radial noise: the algebraic fit alone is
  // biased on a short arc; the result must be the geometric least-squares
  // circle (no small change of centre or radius lowers the sum of squares).
  std::mt19937_64 engine(17);
  std::normal_distribution<double> noise(0.0, 0.8);
  const Eigen::Vector2d centre(310.0, 245.0);
  std::vector<Eigen::Vector2d> points;
  for (int k = 0; k < 90; ++k) {
    const double angle = 0.3 + k * M_PI / 2 / 90;
    points.push_back(centre +
                     (180.0 + noise(engine)) * Eigen::Vector2d(std::cos(angle), std::sin(angle)));
  }
  const Circle fit = FitCircle(points);
  EXPECT_LT((fit.center - centre).norm(), 2.0);
  EXPECT_NEAR(fit.radius, 180.0, 2.0);
  const double best = SumOfSquaredDistances(points, fit);
  for (const Eigen::Vector3d& step :
       {Eigen::Vector3d(0.05, 0, 0), Eigen::Vector3d(-0.05, 0, 0), Eigen::Vector3d(0, 0.05, 0),
        Eigen::Vector3d(0, -0.05, 0), Eigen::Vector3d(0, 0, 0.05), Eigen::Vector3d(0, 0, -0.05),
        Eigen::Vector3d(0.05, 0.05, 0.05)}) {
    Circle moved = fit;
    moved.center += step.head<2>();
    moved.radius += step.z();
    EXPECT_GT(SumOfSquaredDistances(points, moved), best) << step.transpose();
  }
  EXPECT_LT(best, SumOfSquaredDistances(points, Circle{centre, 180.0}));
}

TEST(CircleFit, FewerThanThreePointsGiveNoCircle) {
  const Circle none = FitCircle({{1.0, 2.0}, {3.0, 4.0}});
  EXPECT_EQ(none.radius, 0.0);
  EXPECT_EQ(none.center, Eigen::Vector2d::Zero());
  EXPECT_EQ(FitCircle({}).radius, 0.0);
}

}  // namespace
}  // namespace oslam

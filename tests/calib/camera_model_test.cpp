// Properties every CameraModel must have, run for every model and rig: the
// pixel -> ray -> point -> pixel round trip, analytic vs numeric Jacobians,
// and camera.yaml save/load. A new model is added to Cameras() below.
#include "calib/camera_model.h"

#include <cmath>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>

#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "calib/mei_camera.h"
#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

struct CameraCase {
  std::string name;
  std::function<std::unique_ptr<CameraModel>()> make;
};

std::vector<CameraCase> Cameras() {
  return {
      {"lpa", [] { return HyperbolicCamera::Preset("lpa").Clone(); }},
      {"cogniron", [] { return HyperbolicCamera::Preset("cogniron").Clone(); }},
      {"lpa_flipped_offset_decentred",
       [] {
         HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
         HyperbolicMirrorParameters p = camera.parameters();
         p.flip_image_angle = true;
         p.angle_offset_rad = 2.0;
         p.center_x_px += 3.7;
         p.center_y_px -= 5.2;
         camera.set_parameters(p);
         return camera.Clone();
       }},
      {"mei_parabolic",
       [] {
         MeiParameters p;
         p.xi = 1.0;
         p.fx_px = p.fy_px = 200.0;
         p.cx_px = 321.3;
         p.cy_px = 238.7;
         p.focus_height_m = 0.76;
         return MeiCamera(p, 640, 480, MirrorAnnulus{40.0, 236.0}).Clone();
       }},
      {"mei_hyperbolic_distorted_tilted",
       [] {
         MeiParameters p;
         p.xi = 0.9;
         p.fx_px = 260.0;
         p.fy_px = 258.0;
         p.skew = 0.3;
         p.cx_px = 402.0;
         p.cy_px = 297.0;
         p.k1 = -0.05;
         p.k2 = 0.01;
         p.p1 = 1e-3;
         p.p2 = -5e-4;
         p.focus_height_m = 1.06;
         p.mount_roll_rad = 0.02;
         p.mount_pitch_rad = -0.03;
         p.mount_yaw_rad = 0.5;
         return MeiCamera(p, 800, 600, MirrorAnnulus{45.0, 290.0}).Clone();
       }},
  };
}

class EveryCamera : public ::testing::TestWithParam<CameraCase> {
 protected:
  void SetUp() override { camera_ = GetParam().make(); }
  // Pixels on a 2 px grid over the whole mirror annulus.
  std::vector<Eigen::Vector2d> AnnulusPixels() const {
    std::vector<Eigen::Vector2d> pixels;
    for (int y = 0; y < camera_->image_height(); y += 2)
      for (int x = 0; x < camera_->image_width(); x += 2) {
        const Eigen::Vector2d pixel(x + 0.25, y + 0.75);
        if (camera_->IsInAnnulus(pixel)) pixels.push_back(pixel);
      }
    return pixels;
  }
  std::unique_ptr<CameraModel> camera_;
};

TEST_P(EveryCamera, PixelRayPointPixelRoundTripIsBelowMicroPixel) {
  const std::vector<Eigen::Vector2d> pixels = AnnulusPixels();
  ASSERT_GT(pixels.size(), 10000u);
  double worst = 0;
  for (const Eigen::Vector2d& pixel : pixels) {
    Ray ray;
    ASSERT_TRUE(camera_->BackProjectPixel(pixel, &ray));
    EXPECT_NEAR(ray.direction_robot.norm(), 1.0, 1e-12);
    for (double distance : {0.3, 2.0, 25.0}) {
      const Eigen::Vector3d point = ray.origin_robot + distance * ray.direction_robot;
      Eigen::Vector2d reprojected;
      ASSERT_TRUE(camera_->ProjectToPixel(point, &reprojected)) << pixel.transpose();
      worst = std::max(worst, (reprojected - pixel).norm());
    }
  }
  EXPECT_LT(worst, 1e-6);
}

TEST_P(EveryCamera, BackProjectionPointsAtTheProjectedPoint) {
  for (const Eigen::Vector3d& point :
       {Eigen::Vector3d(2, 1, 0), Eigen::Vector3d(-3, 0.5, 1.2), Eigen::Vector3d(0.4, -0.9, 0.1),
        Eigen::Vector3d(-1, -6, 2.0)}) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera_->ProjectToPixel(point, &pixel));
    Ray ray;
    ASSERT_TRUE(camera_->BackProjectPixel(pixel, &ray));
    const Eigen::Vector3d expected = (point - ray.origin_robot).normalized();
    EXPECT_LT((ray.direction_robot - expected).norm(), 1e-10);
  }
}

TEST_P(EveryCamera, ProjectionJacobiansMatchCentralDifferences) {
  for (const Eigen::Vector3d& point :
       {Eigen::Vector3d(2, 1, 0), Eigen::Vector3d(-3, 0.5, 1.2), Eigen::Vector3d(0.4, -0.9, 0.1),
        Eigen::Vector3d(-1, -6, 2.0), Eigen::Vector3d(0.05, 0.3, 0.7)}) {
    Eigen::Vector2d pixel;
    Eigen::Matrix<double, 2, 3> pixel_jacobian;
    ASSERT_TRUE(camera_->ProjectToPixel(point, &pixel, &pixel_jacobian));
    auto project = [&](const Eigen::VectorXd& p) {
      Eigen::Vector2d out;
      camera_->ProjectToPixel(p, &out);
      return Eigen::VectorXd(out);
    };
    const Eigen::MatrixXd numeric = testing::NumericJacobian(project, point);
    EXPECT_LT((pixel_jacobian - numeric).norm(), 1e-5 * (1.0 + numeric.norm())) << point.transpose();

    PolarPoint polar;
    Eigen::Matrix<double, 2, 3> polar_jacobian;
    ASSERT_TRUE(camera_->ProjectToPolar(point, &polar, &polar_jacobian));
    auto to_polar = [&](const Eigen::VectorXd& p) {
      PolarPoint out;
      camera_->ProjectToPolar(p, &out);
      return Eigen::VectorXd(Eigen::Vector2d(out.radius_px, out.angle_rad));
    };
    const Eigen::MatrixXd numeric_polar = testing::NumericJacobian(to_polar, point);
    EXPECT_LT((polar_jacobian - numeric_polar).norm(), 1e-5 * (1.0 + numeric_polar.norm()));

    // The radius alone is the polar projection's first row.
    double radius = 0.0;
    Eigen::RowVector3d radius_jacobian;
    ASSERT_TRUE(camera_->ProjectRadius(point, &radius, &radius_jacobian));
    EXPECT_NEAR(radius, polar.radius_px, 1e-9);
    EXPECT_LT((radius_jacobian - polar_jacobian.row(0)).norm(),
              1e-9 * (1.0 + numeric_polar.norm()));
  }
}

TEST_P(EveryCamera, PolarAndPixelCoordinatesRoundTrip) {
  const Eigen::Vector2d pixel(123.25, 201.5);
  const PolarPoint polar = camera_->PixelToPolar(pixel);
  EXPECT_LT((camera_->PolarToPixel(polar) - pixel).norm(), 1e-12);
}

TEST_P(EveryCamera, SaveThenLoadGivesTheSameCamera) {
  testing::TempDir dir;
  const std::string path = dir.Path("camera.yaml");
  SaveCamera(*camera_, path);
  const std::unique_ptr<CameraModel> loaded = LoadCamera(path);
  EXPECT_EQ(loaded->ModelName(), camera_->ModelName());
  EXPECT_EQ(loaded->image_width(), camera_->image_width());
  EXPECT_EQ(loaded->image_height(), camera_->image_height());
  EXPECT_DOUBLE_EQ(loaded->annulus().rim_radius_px, camera_->annulus().rim_radius_px);
  EXPECT_DOUBLE_EQ(loaded->annulus().blind_radius_px, camera_->annulus().blind_radius_px);
  EXPECT_EQ((loaded->Intrinsics() - camera_->Intrinsics()).norm(), 0.0);
  // Same projection, including the flip flag that is not an intrinsic.
  Eigen::Vector2d a, b;
  ASSERT_TRUE(camera_->ProjectToPixel({1.0, 2.0, 0.3}, &a));
  ASSERT_TRUE(loaded->ProjectToPixel({1.0, 2.0, 0.3}, &b));
  EXPECT_EQ((a - b).norm(), 0.0);
}

INSTANTIATE_TEST_SUITE_P(AllModels, EveryCamera, ::testing::ValuesIn(Cameras()),
                         [](const auto& info) { return info.param.name; });

// ---- camera.yaml errors: one line naming the file and the field ----

std::string LoadError(const std::string& text) {
  testing::TempDir dir;
  const std::string path = dir.Path("camera.yaml");
  std::ofstream(path) << text;
  try {
    LoadCamera(path);
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path, 0), 0u) << "message must start with the file: " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos);
    return message;
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return "";
}

const char* kGoodCamera =
    "model: hyperbolic\nimage_width: 640\nimage_height: 480\nblind_radius_px: 40\n"
    "rim_radius_px: 236\nintrinsics:\n  mirror_a_m: 0.03929\n  mirror_b_m: 0.01965\n"
    "  focus_height_m: 0.76\n  focal_px: 1800\n  center_x_px: 320\n  center_y_px: 240\n"
    "  angle_offset_rad: 0\n";

TEST(CameraYaml, HandWrittenFileWithoutYamlDirectiveLoads) {
  testing::TempDir dir;
  std::ofstream(dir.Path("camera.yaml")) << kGoodCamera;
  const std::unique_ptr<CameraModel> camera = LoadCamera(dir.Path("camera.yaml"));
  EXPECT_EQ(camera->ModelName(), "hyperbolic");
  EXPECT_DOUBLE_EQ(camera->Intrinsics()[3], 1800.0);
}

TEST(CameraYaml, BadFilesGiveOneLineErrorsNamingTheProblem) {
  auto replace = [](std::string text, const std::string& from, const std::string& to) {
    text.replace(text.find(from), from.size(), to);
    return text;
  };
  const std::string good = kGoodCamera;
  EXPECT_NE(LoadError(replace(good, "model: hyperbolic", "model: fisheye")).find("unknown camera model"),
            std::string::npos);
  EXPECT_NE(LoadError(replace(good, "  focal_px: 1800\n", "")).find("intrinsics.focal_px: missing"),
            std::string::npos);
  EXPECT_NE(LoadError(replace(good, "focal_px: 1800", "focal_px: .nan")).find("NaN"),
            std::string::npos);
  EXPECT_NE(LoadError(replace(good, "focal_px: 1800", "focal_px: abc")).find("must be a number"),
            std::string::npos);
  EXPECT_NE(LoadError(good + "colour: red\n").find("colour: unknown key"), std::string::npos);
  EXPECT_NE(LoadError(replace(good, "mirror_a_m: 0.03929", "mirror_a_m: -1")).find("mirror_a_m"),
            std::string::npos);
  EXPECT_NE(LoadError(replace(good, "rim_radius_px: 236", "rim_radius_px: 10")).find("annulus"),
            std::string::npos);
  EXPECT_NE(LoadError("model: [oops\n").find("line 1"), std::string::npos);
  EXPECT_NE(LoadError("").find("mapping"), std::string::npos);
}

TEST(CameraYaml, MissingFileIsReported) {
  try {
    LoadCamera("/nonexistent/camera.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/camera.yaml: file not found");
  }
}

}  // namespace
}  // namespace oslam

// Properties every CameraModel must have, run for every model and rig: the
// pixel -> ray -> point -> pixel round trip and analytic vs numeric
// Jacobians. A new model is added to Cameras() in camera_cases.h (its
// camera.yaml round trip is in camera_io_test.cpp).
#include "calib/camera_model.h"

#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "calib/camera_cases.h"
#include "test_util.h"

namespace oslam {
namespace {

using testing::CameraCase;

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
    EXPECT_LT((pixel_jacobian - numeric).norm(), 1e-5 * (1.0 + numeric.norm()))
        << point.transpose();

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

INSTANTIATE_TEST_SUITE_P(AllModels, EveryCamera, ::testing::ValuesIn(testing::Cameras()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
}  // namespace oslam

// Mei's unified model (mei_camera.h): the mirror-frame projection against
// OpenCV's cv::omnidir (the parameters are meant to be interchangeable) and
// against closed forms; its Jacobian; back-projection through the Newton
// undistortion, and where it must fail; the field of view limit of ξ; the
// robot mount; the parameter vector and its checks.
#include "calib/mei_camera.h"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/ccalib/omnidir.hpp>
#include <opencv2/core.hpp>

#include "core/angles.h"
#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

MeiParameters Distorted(double xi) {
  MeiParameters p;
  p.xi = xi;
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
  return p;
}

MeiCamera MakeCamera(const MeiParameters& p) {
  return MeiCamera(p, 800, 600, MirrorAnnulus{45.0, 290.0});
}

// Unit directions over the part of the sphere a mirror with this ξ images.
std::vector<Eigen::Vector3d> VisibleDirections(double xi) {
  const double limit = xi > 1.0 ? 1.0 / xi : xi;
  std::vector<Eigen::Vector3d> directions;
  for (double z = 0.99; z > -limit + 0.02; z -= 0.07)
    for (double azimuth = -3.1; azimuth < 3.1; azimuth += 0.37) {
      const double r = std::sqrt(1.0 - z * z);
      directions.emplace_back(r * std::cos(azimuth), r * std::sin(azimuth), z);
    }
  return directions;
}

TEST(MeiCamera, MirrorProjectionMatchesOpenCvOmnidir) {
  for (double xi : {0.0, 0.6, 0.95, 1.0, 1.3}) {
    const MeiParameters p = Distorted(xi);
    const MeiCamera camera = MakeCamera(p);
    std::vector<cv::Vec3d> points;
    // Directions with their image inside the mild-distortion zone (|m| < 1.2).
    for (const Eigen::Vector3d& d : VisibleDirections(xi))
      if (std::hypot(d.x(), d.y()) / (d.z() + xi) < 1.2)
        points.emplace_back(2.0 * d.x(), 2.0 * d.y(), 2.0 * d.z());
    ASSERT_GT(points.size(), 50u) << xi;
    const cv::Matx33d k(p.fx_px, p.skew, p.cx_px, 0.0, p.fy_px, p.cy_px, 0.0, 0.0, 1.0);
    const cv::Vec4d distortion(p.k1, p.k2, p.p1, p.p2);
    std::vector<cv::Vec2d> expected;
    cv::omnidir::projectPoints(points, expected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, xi,
                               distortion);
    for (size_t i = 0; i < points.size(); ++i) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.ProjectMirrorPoint({points[i][0], points[i][1], points[i][2]}, &pixel));
      EXPECT_NEAR(pixel.x(), expected[i][0], 1e-9) << "xi " << xi << " point " << i;
      EXPECT_NEAR(pixel.y(), expected[i][1], 1e-9) << "xi " << xi << " point " << i;
    }
  }
}

TEST(MeiCamera, WithXiZeroAndNoDistortionItIsAPinhole) {
  MeiParameters p;
  p.xi = 0.0;
  p.fx_px = 500.0;
  p.fy_px = 480.0;
  p.cx_px = 320.0;
  p.cy_px = 240.0;
  const MeiCamera camera = MakeCamera(p);
  for (const Eigen::Vector3d& point : {Eigen::Vector3d(0.1, -0.2, 1.0),
                                       Eigen::Vector3d(-1.5, 0.7, 2.5), Eigen::Vector3d(0, 0, 3)}) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera.ProjectMirrorPoint(point, &pixel));
    EXPECT_NEAR(pixel.x(), 500.0 * point.x() / point.z() + 320.0, 1e-9);
    EXPECT_NEAR(pixel.y(), 480.0 * point.y() / point.z() + 240.0, 1e-9);
  }
  // Nothing behind the pinhole, nor in its plane.
  Eigen::Vector2d pixel;
  EXPECT_FALSE(camera.ProjectMirrorPoint({0.3, 0.1, -1.0}, &pixel));
  EXPECT_FALSE(camera.ProjectMirrorPoint({1.0, 0.0, 0.0}, &pixel));
}

TEST(MeiCamera, MirrorProjectionJacobianMatchesCentralDifferences) {
  for (double xi : {0.0, 0.9, 1.0, 1.4}) {
    const MeiCamera camera = MakeCamera(Distorted(xi));
    for (const Eigen::Vector3d& d : VisibleDirections(xi)) {
      if (std::hypot(d.x(), d.y()) / (d.z() + xi) > 1.2) continue;
      const Eigen::Vector3d point = 1.7 * d;
      Eigen::Vector2d pixel;
      Eigen::Matrix<double, 2, 3> jacobian;
      ASSERT_TRUE(camera.ProjectMirrorPoint(point, &pixel, &jacobian));
      const Eigen::MatrixXd numeric = testing::NumericJacobian(
          [&](const Eigen::VectorXd& x) {
            Eigen::Vector2d out;
            camera.ProjectMirrorPoint(x, &out);
            return Eigen::VectorXd(out);
          },
          point);
      EXPECT_LT((jacobian - numeric).norm(), 1e-5 * (1.0 + numeric.norm()))
          << "xi " << xi << " direction " << d.transpose();
    }
  }
}

TEST(MeiCamera, BackProjectionInvertsTheMirrorProjection) {
  for (double xi : {0.0, 0.6, 1.0, 1.3}) {
    const MeiCamera camera = MakeCamera(Distorted(xi));
    for (const Eigen::Vector3d& d : VisibleDirections(xi)) {
      if (std::hypot(d.x(), d.y()) / (d.z() + xi) > 1.2) continue;
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.ProjectMirrorPoint(3.0 * d, &pixel));
      Eigen::Vector3d direction;
      ASSERT_TRUE(camera.BackProjectToMirror(pixel, &direction)) << pixel.transpose();
      EXPECT_NEAR(direction.norm(), 1.0, 1e-12);
      EXPECT_LT((direction - d).norm(), 1e-9) << "xi " << xi << " direction " << d.transpose();
    }
  }
}

// Under a distortion far stronger than a mirror's (k1 = -1: the radial map
// m (1 - |m|^2) folds over at |m| = 1 / sqrt 3) the Newton inversion may
// fail, but a ray it returns always images back at its pixel, and inside
// the fold it is the ray of the unfolded branch.
TEST(MeiCamera, BackProjectionUnderStrongDistortionIsRightOrRefused) {
  MeiParameters p = Distorted(1.0);
  p.k1 = -1.0;
  p.k2 = 0.0;
  const MeiCamera camera = MakeCamera(p);
  int refused = 0, returned = 0;
  for (int y = 0; y < 600; y += 7)
    for (int x = 0; x < 800; x += 7) {
      const Eigen::Vector2d pixel(x + 0.5, y + 0.25);
      Eigen::Vector3d direction;
      if (!camera.BackProjectToMirror(pixel, &direction)) {
        ++refused;
        continue;
      }
      ++returned;
      Eigen::Vector2d reprojected;
      ASSERT_TRUE(camera.ProjectMirrorPoint(direction, &reprojected)) << pixel.transpose();
      ASSERT_LT((reprojected - pixel).norm(), 1e-6) << pixel.transpose();
    }
  EXPECT_GT(refused, 0);
  EXPECT_GT(returned, 0);
  // Along the x axis without tangential terms: 0.3 = m (1 - m^2) has its
  // unfolded root at m = 0.33894.
  p.skew = p.p1 = p.p2 = 0.0;
  const MeiCamera radial = MakeCamera(p);
  Eigen::Vector3d direction;
  ASSERT_TRUE(radial.BackProjectToMirror({p.cx_px + 0.3 * p.fx_px, p.cy_px}, &direction));
  const double m = direction.x() / (direction.z() + p.xi);
  EXPECT_NEAR(m - m * m * m, 0.3, 1e-12);
  EXPECT_LT(m, 1.0 / std::sqrt(3.0));
  EXPECT_NEAR(direction.y(), 0.0, 1e-12);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(radial.BackProjectToMirror({nan, 100.0}, &direction));
  Ray ray;
  EXPECT_FALSE(radial.BackProjectPixel({nan, nan}, &ray));
}

TEST(MeiCamera, XiSetsTheFieldOfViewBeyondTheEquator) {
  // A point is imaged while its sphere point has z > -min(xi, 1/xi).
  auto imaged = [](double xi, double z) {
    const MeiCamera camera = MakeCamera(Distorted(xi));
    const Eigen::Vector3d point(std::sqrt(1.0 - z * z), 0.0, z);
    Eigen::Vector2d pixel;
    return camera.ProjectMirrorPoint(point, &pixel);
  };
  EXPECT_TRUE(imaged(0.8, -0.79));
  EXPECT_FALSE(imaged(0.8, -0.81));
  EXPECT_TRUE(imaged(1.25, -0.79));  // 1 / 1.25 = 0.8
  EXPECT_FALSE(imaged(1.25, -0.81));
  EXPECT_TRUE(imaged(1.0, -0.99));
  // No image for the viewpoint itself or a non-finite point.
  const MeiCamera camera = MakeCamera(Distorted(1.0));
  Eigen::Vector2d pixel;
  EXPECT_FALSE(camera.ProjectMirrorPoint(Eigen::Vector3d::Zero(), &pixel));
  EXPECT_FALSE(camera.ProjectMirrorPoint({std::numeric_limits<double>::infinity(), 0, 1}, &pixel));
}

// With no mount angles and square pixels, the image is the robot's
// surroundings seen from below: forward is the image's +x, the image angle
// is minus the bearing, and a ring of points at one height images on a circle.
TEST(MeiCamera, UntiltedMountImagesForwardAlongXMirrored) {
  MeiParameters p;
  p.xi = 0.95;
  p.fx_px = p.fy_px = 200.0;
  p.cx_px = 321.0;
  p.cy_px = 239.0;
  p.focus_height_m = 0.8;
  const MeiCamera camera = MakeCamera(p);
  EXPECT_EQ(camera.ImageCenter(), Eigen::Vector2d(321.0, 239.0));
  EXPECT_EQ(camera.ViewpointInRobot(), Eigen::Vector3d(0.0, 0.0, 0.8));
  EXPECT_LT(
      (camera.RobotFromMirrorRotation() - Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix())
          .norm(),
      1e-15);
  // A point level with the viewpoint, 1 m ahead: on the sphere's equator, m = 1 / xi.
  Eigen::Vector2d pixel;
  ASSERT_TRUE(camera.ProjectToPixel({1.0, 0.0, 0.8}, &pixel));
  EXPECT_NEAR(pixel.x(), 321.0 + 200.0 / 0.95, 1e-9);
  EXPECT_NEAR(pixel.y(), 239.0, 1e-9);
  double radius = -1;
  for (double bearing = -3.0; bearing < 3.1; bearing += 0.5) {
    const Eigen::Vector3d point(2.0 * std::cos(bearing), 2.0 * std::sin(bearing), 0.1);
    ASSERT_TRUE(camera.ProjectToPixel(point, &pixel));
    const PolarPoint polar = camera.PixelToPolar(pixel);
    EXPECT_NEAR(WrapAngle(polar.angle_rad + bearing), 0.0, 1e-12) << bearing;
    if (radius < 0) radius = polar.radius_px;
    EXPECT_NEAR(polar.radius_px, radius, 1e-9) << bearing;
  }
  // The image centre looks straight down the mirror axis, at the camera.
  Ray ray;
  ASSERT_TRUE(camera.BackProjectPixel(camera.ImageCenter(), &ray));
  EXPECT_LT((ray.direction_robot - Eigen::Vector3d(0, 0, -1)).norm(), 1e-12);
  EXPECT_EQ(ray.origin_robot, camera.ViewpointInRobot());
}

TEST(MeiCamera, MountYawTurnsTheImageAndPitchTiltsTheAxis) {
  MeiParameters p = Distorted(0.95);
  p.k1 = p.k2 = p.p1 = p.p2 = p.skew = 0.0;
  p.fy_px = p.fx_px;
  p.mount_yaw_rad = 0.7;
  const MeiCamera turned = MakeCamera(p);
  for (double bearing = -3.0; bearing < 3.1; bearing += 0.5) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(turned.ProjectToPixel({std::cos(bearing), std::sin(bearing), 0.3}, &pixel));
    EXPECT_NEAR(WrapAngle(turned.PixelToPolar(pixel).angle_rad - (0.7 - bearing)), 0.0, 1e-12);
  }
  p.mount_yaw_rad = 0.0;
  p.mount_pitch_rad = 0.1;
  const MeiCamera pitched = MakeCamera(p);
  Ray ray;
  ASSERT_TRUE(pitched.BackProjectPixel(pitched.ImageCenter(), &ray));
  EXPECT_LT((ray.direction_robot - Eigen::Vector3d(-std::sin(0.1), 0.0, -std::cos(0.1))).norm(),
            1e-12);
  // Roll, pitch and yaw compose as Rz Ry Rx, applied after the flip.
  p.mount_roll_rad = -0.05;
  p.mount_yaw_rad = 0.4;
  const MeiCamera tilted = MakeCamera(p);
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(-0.05, Eigen::Vector3d::UnitX()))
                                       .toRotationMatrix() *
                                   Eigen::Vector3d(1, -1, -1).asDiagonal();
  EXPECT_LT((tilted.RobotFromMirrorRotation() - expected).norm(), 1e-15);
  EXPECT_NEAR(tilted.RobotFromMirrorRotation().determinant(), 1.0, 1e-12);
}

TEST(MeiCamera, IntrinsicsRoundTripInTheirNamedOrder) {
  MeiParameters p = Distorted(0.9);
  p.mount_roll_rad = 0.01;
  p.mount_pitch_rad = 0.02;
  p.mount_yaw_rad = 0.03;
  const MeiCamera camera = MakeCamera(p);
  const std::vector<std::string> names = camera.IntrinsicNames();
  const Eigen::VectorXd values = camera.Intrinsics();
  ASSERT_EQ(names.size(), static_cast<size_t>(MeiCamera::kNumIntrinsics));
  ASSERT_EQ(values.size(), MeiCamera::kNumIntrinsics);
  const std::vector<std::pair<std::string, double>> expected = {{"xi", 0.9},
                                                                {"fx_px", 260.0},
                                                                {"fy_px", 258.0},
                                                                {"skew_px", 0.3},
                                                                {"cx_px", 402.0},
                                                                {"cy_px", 297.0},
                                                                {"k1", -0.05},
                                                                {"k2", 0.01},
                                                                {"p1", 1e-3},
                                                                {"p2", -5e-4},
                                                                {"focus_height_m", 1.06},
                                                                {"mount_roll_rad", 0.01},
                                                                {"mount_pitch_rad", 0.02},
                                                                {"mount_yaw_rad", 0.03}};
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(names[i], expected[i].first);
    EXPECT_EQ(values[i], expected[i].second) << names[i];
  }
  MeiCamera other;
  other.SetIntrinsics(values);
  EXPECT_EQ(other.Intrinsics(), values);
  // Clones are independent copies.
  std::unique_ptr<CameraModel> clone = camera.Clone();
  EXPECT_EQ(clone->Intrinsics(), values);
  EXPECT_EQ(clone->image_width(), 800);
  clone->SetIntrinsics(Eigen::VectorXd::Ones(MeiCamera::kNumIntrinsics));
  EXPECT_EQ(camera.Intrinsics(), values);
  try {
    other.SetIntrinsics(Eigen::VectorXd::Zero(7));
    FAIL() << "a vector of the wrong size was taken";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "mei camera: expected 14 intrinsics, got 7");
  }
}

TEST(MeiCamera, ValidationNamesTheBadParameter) {
  auto why_invalid = [](const MeiParameters& p, MirrorAnnulus annulus = {45.0, 290.0}) {
    const MeiCamera camera(p, 800, 600, annulus);
    std::string why;
    EXPECT_FALSE(camera.Validate(&why));
    return why;
  };
  std::string why;
  EXPECT_TRUE(MakeCamera(Distorted(0.9)).Validate(&why)) << why;
  MeiParameters p = Distorted(0.9);
  p.xi = -0.01;
  EXPECT_EQ(why_invalid(p), "xi must be >= 0");
  p = Distorted(0.9);
  p.fy_px = 0.0;
  EXPECT_EQ(why_invalid(p), "fx_px and fy_px must be positive");
  p = Distorted(0.9);
  p.focus_height_m = 0.0;
  EXPECT_EQ(why_invalid(p), "focus_height_m must be above the floor (> 0)");
  p = Distorted(0.9);
  p.k1 = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(why_invalid(p), "intrinsics contain NaN or infinity");
  EXPECT_EQ(why_invalid(Distorted(0.9), {300.0, 290.0}),
            "mirror annulus needs 0 <= blind_radius_px < rim_radius_px");
}

}  // namespace
}  // namespace oslam

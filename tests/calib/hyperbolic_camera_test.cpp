// The hyperbolic-mirror model against the docs/method.md §4.3 test vectors and against
// the mirror geometry it is derived from.
#include "calib/hyperbolic_camera.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/angles.h"
#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

struct RadiusVector {
  const char* preset;
  double range_m, height_m, radius_px;
};

// docs/method.md §4.3 "Test vectors" (given to 2 decimals, so compared to 5e-3 px).
class ImageRadiusVectors : public ::testing::TestWithParam<RadiusVector> {};

TEST_P(ImageRadiusVectors, MatchSpecToTwoDecimals) {
  const RadiusVector v = GetParam();
  const HyperbolicCamera camera = HyperbolicCamera::Preset(v.preset);
  double radius = 0;
  ASSERT_TRUE(camera.ImageRadius(v.range_m, v.height_m, &radius));
  EXPECT_NEAR(radius, v.radius_px, 5e-3);
}

INSTANTIATE_TEST_SUITE_P(Spec, ImageRadiusVectors,
                         ::testing::Values(RadiusVector{"cogniron", 0.5, 0.0, 58.24},
                                           RadiusVector{"cogniron", 1.0, 0.0, 103.36},
                                           RadiusVector{"cogniron", 2.0, 0.0, 156.82},
                                           RadiusVector{"cogniron", 3.0, 0.3, 203.13},
                                           RadiusVector{"cogniron", 5.0, 1.0, 258.49},
                                           RadiusVector{"lpa", 0.5, 0.0, 60.12},
                                           RadiusVector{"lpa", 1.0, 0.0, 99.63},
                                           RadiusVector{"lpa", 2.0, 0.0, 138.65},
                                           RadiusVector{"lpa", 3.0, 0.3, 172.68},
                                           RadiusVector{"lpa", 5.0, 1.0, 211.30}),
    [](const auto& info) { return std::string(info.param.preset) + "_" + std::to_string(info.index); });

TEST(HyperbolicCamera, EccentricityAndHorizonMatchSpecTable) {
  const HyperbolicCamera cogniron = HyperbolicCamera::Preset("cogniron");
  const HyperbolicCamera lpa = HyperbolicCamera::Preset("lpa");
  EXPECT_NEAR(cogniron.Eccentricity(), 0.04900, 5e-6);
  EXPECT_NEAR(lpa.Eccentricity(), 0.04393, 5e-6);
  EXPECT_NEAR(cogniron.HorizonRadius(), 261.7, 0.05);
  EXPECT_NEAR(lpa.HorizonRadius(), 201.3, 0.05);
  // The horizon is the limit of T(r, z_m) for r -> infinity.
  double far = 0;
  ASSERT_TRUE(lpa.ImageRadius(1e7, lpa.parameters().focus_height_m, &far));
  EXPECT_NEAR(far, lpa.HorizonRadius(), 1e-6);
}

// The closed form must equal the construction it comes from: intersect the
// ray from the mirror focus with the mirror, then image that point through
// the lens centre at the second focus.
TEST(HyperbolicCamera, ClosedFormAgreesWithMirrorConstruction) {
  for (const std::string& preset : HyperbolicCamera::PresetNames()) {
    const HyperbolicCamera camera = HyperbolicCamera::Preset(preset);
    const HyperbolicMirrorParameters& p = camera.parameters();
    const double a = p.mirror_a_m, b = p.mirror_b_m, e = camera.Eccentricity();
    for (double range : {0.2, 0.7, 1.5, 4.0, 12.0}) {
      for (double height : {0.0, 0.3, 0.9, 1.8}) {
        const double w = height - p.focus_height_m;
        const double s = std::hypot(range, w);
        if (!(a * s > e * w)) continue;
        const double lambda = b * b / (a * s - e * w);
        const double mirror_r = lambda * range;
        const double mirror_z = p.focus_height_m + lambda * w;
        // On the mirror: ((z - z_m + e)/a)^2 - (r/b)^2 = 1.
        const double on_mirror = std::pow((mirror_z - p.focus_height_m + e) / a, 2) -
                                 std::pow(mirror_r / b, 2);
        EXPECT_NEAR(on_mirror, 1.0, 1e-9) << preset << " r=" << range << " z=" << height;
        const double lens_z = p.focus_height_m - 2.0 * e;
        const double expected = p.focal_px * mirror_r / (mirror_z - lens_z);
        double radius = 0;
        ASSERT_TRUE(camera.ImageRadius(range, height, &radius));
        EXPECT_NEAR(radius, expected, 1e-9);
      }
    }
  }
}

TEST(HyperbolicCamera, ImageRadiusPartialsMatchCentralDifferences) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("cogniron");
  for (double range : {0.3, 1.0, 3.0, 8.0}) {
    for (double height : {0.0, 0.5, 1.2, 2.0}) {
      double radius, d_range, d_height;
      if (!camera.ImageRadius(range, height, &radius, &d_range, &d_height)) continue;
      auto f = [&](const Eigen::VectorXd& x) {
        double t = 0;
        camera.ImageRadius(x[0], x[1], &t);
        return Eigen::VectorXd::Constant(1, t);
      };
      const Eigen::MatrixXd numeric = testing::NumericJacobian(f, Eigen::Vector2d(range, height));
      EXPECT_NEAR(d_range, numeric(0, 0), 1e-6 * std::max(1.0, std::abs(d_range)));
      EXPECT_NEAR(d_height, numeric(0, 1), 1e-6 * std::max(1.0, std::abs(d_height)));
    }
  }
}

TEST(HyperbolicCamera, ElevationOfRadiusInvertsImageRadius) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const double focus = camera.parameters().focus_height_m;
  for (double elevation_deg = -85; elevation_deg <= 25; elevation_deg += 2.5) {
    const double elevation = DegToRad(elevation_deg);
    double radius = 0;
    ASSERT_TRUE(camera.ImageRadius(std::cos(elevation), focus + std::sin(elevation), &radius));
    double derivative = 0;
    EXPECT_NEAR(camera.ElevationOfRadius(radius, &derivative), elevation, 1e-12);
    const double step = 1e-5;
    const double numeric =
        (camera.ElevationOfRadius(radius + step) - camera.ElevationOfRadius(radius - step)) /
        (2 * step);
    EXPECT_NEAR(derivative, numeric, 1e-7);
  }
  EXPECT_NEAR(camera.ElevationOfRadius(0.0), -kPi / 2, 1e-12);
  EXPECT_NEAR(camera.ElevationOfRadius(camera.HorizonRadius()), 0.0, 1e-12);
}

TEST(HyperbolicCamera, PointsAboveTheMirrorLimitHaveNoImage) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const HyperbolicMirrorParameters& p = camera.parameters();
  const double limit = std::asin(p.mirror_a_m / camera.Eccentricity());  // elevation limit
  Eigen::Vector2d pixel;
  const double above = limit + 0.01, below = limit - 0.01;
  EXPECT_FALSE(camera.ProjectToPixel(
      {std::cos(above), 0.0, p.focus_height_m + std::sin(above)}, &pixel));
  EXPECT_TRUE(camera.ProjectToPixel(
      {std::cos(below), 0.0, p.focus_height_m + std::sin(below)}, &pixel));
  EXPECT_FALSE(camera.ProjectToPixel({0.0, 0.0, 0.0}, &pixel));  // on the axis
}

TEST(HyperbolicCamera, ImageAngleFollowsOffsetAndFlip) {
  HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  HyperbolicMirrorParameters p = camera.parameters();
  const Eigen::Vector3d left_point(0.0, 2.0, 0.0);  // bearing +90 deg
  PolarPoint polar;
  ASSERT_TRUE(camera.ProjectToPolar(left_point, &polar));
  EXPECT_NEAR(polar.angle_rad, kPi / 2, 1e-12);
  p.angle_offset_rad = 0.3;
  p.flip_image_angle = true;
  camera.set_parameters(p);
  ASSERT_TRUE(camera.ProjectToPolar(left_point, &polar));
  EXPECT_NEAR(polar.angle_rad, WrapAngle(0.3 - kPi / 2), 1e-12);
}

// The direct polar projection (the factor's inner loop) equals the generic
// one through pixels, values and Jacobian, also flipped, offset and decentred.
TEST(HyperbolicCamera, DirectPolarProjectionEqualsTheOneThroughPixels) {
  for (int variant = 0; variant < 3; ++variant) {
    HyperbolicCamera camera = HyperbolicCamera::Preset(variant == 1 ? "cogniron" : "lpa");
    HyperbolicMirrorParameters p = camera.parameters();
    if (variant == 2) {
      p.angle_offset_rad = 2.9;
      p.flip_image_angle = true;
      p.center_x_px += 7.5;
      p.center_y_px -= 4.0;
      camera.set_parameters(p);
    }
    for (double bearing = -3.1; bearing < 3.2; bearing += 0.37)
      for (double range : {0.4, 1.3, 6.0})
        for (double z : {-0.2, 0.0, 0.9}) {
          const Eigen::Vector3d point(range * std::cos(bearing), range * std::sin(bearing), z);
          PolarPoint direct, generic;
          Eigen::Matrix<double, 2, 3> direct_jacobian, generic_jacobian;
          const bool ok = camera.ProjectToPolar(point, &direct, &direct_jacobian);
          ASSERT_EQ(ok, camera.CameraModel::ProjectToPolar(point, &generic, &generic_jacobian));
          double radius = 0.0;
          Eigen::RowVector3d radius_jacobian;
          ASSERT_EQ(ok, camera.ProjectRadius(point, &radius, &radius_jacobian));
          if (!ok) continue;
          EXPECT_EQ(radius, direct.radius_px);
          EXPECT_EQ(radius_jacobian, direct_jacobian.row(0));
          EXPECT_NEAR(direct.radius_px, generic.radius_px, 1e-9);
          EXPECT_NEAR(WrapAngle(direct.angle_rad - generic.angle_rad), 0.0, 1e-12);
          EXPECT_LE((direct_jacobian - generic_jacobian).cwiseAbs().maxCoeff(), 1e-8)
              << "variant " << variant << " point " << point.transpose();
        }
  }
}

TEST(HyperbolicCamera, ValidationRejectsImpossibleParameters) {
  HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  std::string why;
  EXPECT_TRUE(camera.Validate(&why)) << why;
  HyperbolicMirrorParameters p = camera.parameters();
  p.mirror_b_m = -0.01;
  camera.set_parameters(p);
  EXPECT_FALSE(camera.Validate(&why));
  EXPECT_NE(why.find("mirror_b_m"), std::string::npos);
  p = HyperbolicCamera::Preset("lpa").parameters();
  p.focal_px = std::nan("");
  camera.set_parameters(p);
  EXPECT_FALSE(camera.Validate(&why));
  EXPECT_THROW(HyperbolicCamera::Preset("nonexistent"), Error);
}

}  // namespace
}  // namespace oslam

// Range-bearing, point-sighting and relative-pose factors: analytic
// Jacobians against central differences, zero error on the model, whitening,
// bearing wrap-around.
#include "slam/landmark_factors.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/LU>

#include "core/angles.h"
#include "core/error.h"
#include "tests/solver/factor_check.h"
#include "tests/test_util.h"

namespace oslam {
namespace {

using testing::ExpectJacobianMatchesNumeric;

TEST(RangeBearingFactorTest, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const Eigen::Vector2d& mount : {Eigen::Vector2d(0, 0), Eigen::Vector2d(3.78, 0.5)}) {
    for (int trial = 0; trial < 30; ++trial) {
      Values values;
      const int pose = values.AddPose(5 * u(rng), 5 * u(rng), 3.0 * u(rng));
      const int landmark = values.Add(Eigen::Vector2d(20 * u(rng), 20 * u(rng)));
      RangeBearingFactor factor(pose, landmark, 10 + 5 * u(rng), 3.0 * u(rng), 0.3, 0.05, mount);
      ExpectJacobianMatchesNumeric(factor, values, 1e-5);
    }
  }
}

TEST(RangeBearingFactorTest, ZeroOnTheModelWhitenedAndNormaliser) {
  const Eigen::Vector2d mount(3.78, 0.5);
  const Pose2 pose{2.0, -1.0, 0.7};
  const double range = 12.0, bearing = -0.4;
  const Eigen::Vector2d landmark = LandmarkFromRangeBearing(pose, range, bearing, mount);
  // The sensor sits at pose + Rot(theta) mount: check by hand.
  const Eigen::Vector2d sensor(2.0 + std::cos(0.7) * 3.78 - std::sin(0.7) * 0.5,
                               -1.0 + std::sin(0.7) * 3.78 + std::cos(0.7) * 0.5);
  EXPECT_NEAR((landmark - sensor).norm(), range, 1e-12);
  EXPECT_NEAR(WrapAngle(std::atan2(landmark.y() - sensor.y(), landmark.x() - sensor.x()) - 0.7),
              bearing, 1e-12);
  Values values;
  const int p = values.AddPose(pose.x, pose.y, pose.theta);
  const int l = values.Add(landmark);
  Eigen::VectorXd error(2);
  RangeBearingFactor exact(p, l, range, bearing, 0.5, 0.02, mount);
  ASSERT_TRUE(exact.Linearize(values, error, nullptr));
  EXPECT_LT(error.norm(), 1e-10);
  // 0.1 m too far and 0.01 rad to the left: whitened by (0.5 m, 0.02 rad).
  RangeBearingFactor off(p, l, range - 0.1, bearing - 0.01, 0.5, 0.02, mount);
  ASSERT_TRUE(off.Linearize(values, error, nullptr));
  EXPECT_NEAR(error[0], 0.1 / 0.5, 1e-9);
  EXPECT_NEAR(error[1], 0.01 / 0.02, 1e-9);
  EXPECT_NEAR(off.LogDetCovariance(), std::log(0.5 * 0.5 * 0.02 * 0.02), 1e-12);
}

TEST(RangeBearingFactorTest, BearingResidualWrapsAcrossPi) {
  // Landmark just behind-left of the robot (bearing +179 deg) measured at
  // -179 deg: the residual is 2 deg, not 358.
  Values values;
  const int p = values.AddPose(0, 0, 0);
  const int l =
      values.Add(Eigen::Vector2d(10 * std::cos(DegToRad(179)), 10 * std::sin(DegToRad(179))));
  RangeBearingFactor factor(p, l, 10.0, DegToRad(-179), 1.0, DegToRad(1));
  Eigen::VectorXd error(2);
  Eigen::MatrixXd jacobian(2, 5);
  ASSERT_TRUE(factor.Linearize(values, error, &jacobian));
  EXPECT_NEAR(error[1], -2.0, 1e-9);  // predicted 179 - measured -179 = -2 deg
  EXPECT_NEAR(error[0], 0.0, 1e-9);
}

TEST(RangeBearingFactorTest, LandmarkOnTheSensorCannotBeEvaluatedAndBadInputThrows) {
  Values values;
  const int p = values.AddPose(1, 1, 0.3);
  const int l = values.Add(Eigen::Vector2d(1, 1));
  RangeBearingFactor factor(p, l, 5.0, 0.0, 0.1, 0.01);
  Eigen::VectorXd error(2);
  EXPECT_FALSE(factor.Linearize(values, error, nullptr));
  EXPECT_THROW(RangeBearingFactor(p, l, -1.0, 0.0, 0.1, 0.01), Error);
  EXPECT_THROW(RangeBearingFactor(p, l, 1.0, NAN, 0.1, 0.01), Error);
  EXPECT_THROW(RangeBearingFactor(p, l, 1.0, 0.0, 0.0, 0.01), Error);
  EXPECT_THROW(RangeBearingFactor(p, l, 1.0, 0.0, 0.1, -0.01), Error);
}

TEST(PointSightingFactorTest, JacobiansMatchAndZeroOnTheModel) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix2d covariance;
  covariance << 0.04, 0.01, 0.01, 0.09;
  for (const Eigen::Vector2d& mount : {Eigen::Vector2d(0, 0), Eigen::Vector2d(3.78, 0.5)}) {
    for (int trial = 0; trial < 30; ++trial) {
      Values values;
      const int pose = values.AddPose(5 * u(rng), 5 * u(rng), 3.0 * u(rng));
      const int landmark = values.Add(Eigen::Vector2d(20 * u(rng), 20 * u(rng)));
      PointSightingFactor factor(pose, landmark, Eigen::Vector2d(10 * u(rng), 10 * u(rng)),
                                 covariance, mount);
      ExpectJacobianMatchesNumeric(factor, values, 1e-5);
    }
    // On the model the error is zero, and a sighting's squared error is the
    // factor's.
    const Pose2 pose{1.0, 2.0, 0.6};
    LandmarkSighting s;
    s.cartesian = true;
    s.xy_covariance = covariance;
    s.range_m = 9.0;
    s.bearing_rad = 0.3;
    const Eigen::Vector2d landmark = LandmarkFromRangeBearing(pose, 9.0, 0.3, mount);
    Values values;
    const int p = values.AddPose(pose.x, pose.y, pose.theta);
    const int l = values.Add(landmark);
    FactorGraph graph;
    graph.AddPose(pose.x, pose.y, pose.theta);
    graph.AddVariable(landmark + Eigen::Vector2d(0.3, -0.2));
    AddSightingFactor(&graph, 0, 1, s, mount);
    Eigen::VectorXd error(2);
    ASSERT_TRUE(graph.factors()[0]->Linearize(values, error, nullptr));
    EXPECT_LT(error.norm(), 1e-10);
    ASSERT_TRUE(graph.factors()[0]->Linearize(graph.values(), error, nullptr));
    EXPECT_NEAR(error.squaredNorm(),
                SightingSquaredError(s, pose, landmark + Eigen::Vector2d(0.3, -0.2), mount), 1e-9);
    EXPECT_NEAR(graph.factors()[0]->LogDetCovariance(), std::log(covariance.determinant()), 1e-12);
    (void)p;
    (void)l;
  }
  EXPECT_THROW(PointSightingFactor(0, 1, Eigen::Vector2d(1, 1), Eigen::Matrix2d::Zero()), Error);
}

// A sighting's information about its landmark, the pose held, is the
// Hessian of half its squared error where the error is zero (J^T J exactly
// there): compared with central second differences, range-bearing and
// Cartesian, with and without a mount offset.
TEST(SightingInformationTest, IsTheHessianOfHalfTheSquaredErrorOnTheModel) {
  Eigen::Matrix2d covariance;
  covariance << 0.04, 0.01, 0.01, 0.09;
  const Pose2 pose{1.0, 2.0, 0.6};
  for (const Eigen::Vector2d& mount : {Eigen::Vector2d(0, 0), Eigen::Vector2d(3.78, 0.5)})
    for (const bool cartesian : {false, true}) {
      LandmarkSighting s;
      s.cartesian = cartesian;
      s.xy_covariance = covariance;
      s.range_m = 9.0;
      s.bearing_rad = 0.3;
      s.range_std_m = 0.05;
      s.bearing_std_rad = 0.01;
      const Eigen::Vector2d landmark = LandmarkFromRangeBearing(pose, 9.0, 0.3, mount);
      const Eigen::Matrix2d info = SightingInformation(s, pose, landmark, mount);
      const double h = 1e-4;
      Eigen::Matrix2d numeric;
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
          const auto f = [&](double di, double dj) {
            Eigen::Vector2d at = landmark;
            at(i) += di;
            at(j) += dj;
            return 0.5 * SightingSquaredError(s, pose, at, mount);
          };
          numeric(i, j) = (f(h, h) - f(h, -h) - f(-h, h) + f(-h, -h)) / (4 * h * h);
        }
      EXPECT_LT((info - numeric).norm(), 1e-4 * info.norm()) << "cartesian " << cartesian;
      EXPECT_LT((info - info.transpose()).norm(), 1e-12);
    }
  LandmarkSighting on_sensor;
  EXPECT_EQ(SightingInformation(on_sensor, pose, Eigen::Vector2d(1.0, 2.0), Eigen::Vector2d(0, 0)),
            Eigen::Matrix2d::Zero());
}

TEST(RelativePoseFactorTest, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3d covariance;
  covariance << 0.04, 0.01, 0.002, 0.01, 0.03, -0.001, 0.002, -0.001, 0.01;
  for (int trial = 0; trial < 30; ++trial) {
    Values values;
    const int a = values.AddPose(3 * u(rng), 3 * u(rng), 3.0 * u(rng));
    const int b = values.AddPose(3 * u(rng), 3 * u(rng), 3.0 * u(rng));
    RelativePoseFactor factor(a, b, {u(rng), 0.2 * u(rng), 0.5 * u(rng)}, covariance);
    ExpectJacobianMatchesNumeric(factor, values, 1e-6);
  }
}

TEST(RelativePoseFactorTest, ZeroOnComposedPoseWhitenedByFullCovariance) {
  const Pose2 a{1.0, 2.0, 3.0};
  const Pose2 z{0.5, -0.1, 0.4};
  const Pose2 b = ComposePose(a, z);
  EXPECT_NEAR(b.theta, WrapAngle(3.4), 1e-12);  // crosses pi
  Values values;
  const int ka = values.AddPose(a.x, a.y, a.theta);
  const int kb = values.AddPose(b.x, b.y, b.theta);
  Eigen::Matrix3d covariance;
  covariance << 0.04, 0.01, 0.0, 0.01, 0.09, 0.0, 0.0, 0.0, 0.01;
  Eigen::VectorXd error(3);
  RelativePoseFactor exact(ka, kb, z, covariance);
  ASSERT_TRUE(exact.Linearize(values, error, nullptr));
  EXPECT_LT(error.norm(), 1e-12);
  // Residual r = h - z = (0.1, -0.2, 0.05): |e|^2 = r^T P^-1 r.
  const Eigen::Vector3d r(0.1, -0.2, 0.05);
  RelativePoseFactor off(ka, kb, {z.x - r.x(), z.y - r.y(), z.theta - r.z()}, covariance);
  ASSERT_TRUE(off.Linearize(values, error, nullptr));
  EXPECT_NEAR(error.squaredNorm(), r.dot(covariance.inverse() * r), 1e-9);
  EXPECT_NEAR(off.LogDetCovariance(), std::log(covariance.determinant()), 1e-12);
  EXPECT_THROW(RelativePoseFactor(ka, kb, z, Eigen::Matrix3d::Zero()), Error);
  EXPECT_THROW(RelativePoseFactor(ka, kb, {NAN, 0, 0}, covariance), Error);
}

}  // namespace
}  // namespace oslam

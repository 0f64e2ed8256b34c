// Motion model of docs/method.md §4.1.
#include "core/motion_model.h"

#include <gtest/gtest.h>

#include "test_util.h"

namespace oslam {
namespace {

TEST(MotionModel, MidpointStepMatchesFormula) {
  const Pose2 previous{1.0, 2.0, 0.5};
  const OdometryIncrement step{0.2, DegToRad(10)};
  const Pose2 next = ApplyIncrement(previous, step);
  const double alpha = 0.5 + DegToRad(5);
  EXPECT_NEAR(next.x, 1.0 + 0.2 * std::cos(alpha), 1e-15);
  EXPECT_NEAR(next.y, 2.0 + 0.2 * std::sin(alpha), 1e-15);
  EXPECT_NEAR(next.theta, 0.5 + DegToRad(10), 1e-15);
}

TEST(MotionModel, MidpointIsCloseToTheExactArcOnAnLpaStep) {
  // docs/method.md §4.3 review note: about 0.2 mm on a 20 cm / 10 deg step.
  const double v = 0.2, w = DegToRad(10), theta = 0.3;
  const Pose2 midpoint = ApplyIncrement({0, 0, theta}, {v, w});
  const double arc_x = v / w * (std::sin(theta + w) - std::sin(theta));
  const double arc_y = v / w * (-std::cos(theta + w) + std::cos(theta));
  const double difference = std::hypot(midpoint.x - arc_x, midpoint.y - arc_y);
  EXPECT_GT(difference, 0.1e-3);
  EXPECT_LT(difference, 0.3e-3);
}

TEST(MotionModel, IncrementBetweenInvertsApplyIncrement) {
  for (const OdometryIncrement step : {OdometryIncrement{0.2, 0.0}, OdometryIncrement{-0.2, 0.0},
                                       OdometryIncrement{0.0, DegToRad(-10)},
                                       OdometryIncrement{0.35, 0.4}}) {
    const Pose2 previous{-1.0, 0.5, 3.0};
    const OdometryIncrement recovered = IncrementBetween(previous, ApplyIncrement(previous, step));
    EXPECT_NEAR(recovered.distance_m, step.distance_m, 1e-12);
    EXPECT_NEAR(recovered.turn_rad, step.turn_rad, 1e-12);
  }
}

TEST(MotionModel, JacobianMatchesCentralDifferences) {
  const OdometryIncrement step{0.3, -0.2};
  const Eigen::Vector3d previous(0.4, -1.2, 2.9);
  Eigen::Matrix3d analytic;
  ApplyIncrement(Pose2::FromVector(previous), step, &analytic);
  const Eigen::MatrixXd numeric = testing::NumericJacobian(
      [&](const Eigen::VectorXd& x) {
        const Pose2 next = ApplyIncrement({x[0], x[1], x[2]}, step);
        // Unwrapped heading so the difference quotient is smooth.
        return Eigen::VectorXd(Eigen::Vector3d(next.x, next.y, x[2] + step.turn_rad));
      },
      previous);
  EXPECT_LT((analytic - numeric).norm(), 1e-8);
}

TEST(MotionModel, CovarianceFollowsSpecReading) {
  const MotionNoiseOptions options;
  std::string why;
  ASSERT_TRUE(options.Validate(&why)) << why;
  // 20 cm straight ahead along x: sigma_fwd = 5 mm + 0.1 * 0.2 m = 2.5 cm.
  const Eigen::Matrix3d forward = MotionCovariance(0.0, {0.2, 0.0}, options);
  EXPECT_NEAR(std::sqrt(forward(0, 0)), 0.025, 1e-12);
  EXPECT_NEAR(std::sqrt(forward(1, 1)), 0.005 + 0.01 * 0.2, 1e-12);
  EXPECT_NEAR(std::sqrt(forward(2, 2)), DegToRad(1), 1e-12);
  // A 10 deg turn: sigma_theta = 1 deg + 0.15 * 10 deg = 2.5 deg.
  const Eigen::Matrix3d turn = MotionCovariance(0.0, {0.0, DegToRad(10)}, options);
  EXPECT_NEAR(std::sqrt(turn(2, 2)), DegToRad(2.5), 1e-12);
  // Heading pi/2 (no turn): forward is world y.
  const Eigen::Matrix3d rotated = MotionCovariance(kPi / 2, {0.2, 0.0}, options);
  EXPECT_NEAR(rotated(1, 1), forward(0, 0), 1e-15);
  EXPECT_NEAR(rotated(0, 0), forward(1, 1), 1e-15);
  // Alternatives are switchable.
  MotionNoiseOptions variances = options;
  variances.entries_are_variances = true;
  EXPECT_NEAR(MotionCovariance(0.0, {0.2, 0.0}, variances)(0, 0), 0.025, 1e-12);
  MotionNoiseOptions bad = options;
  bad.additive_std[0] = -1;
  EXPECT_FALSE(bad.Validate(&why));
}

}  // namespace
}  // namespace oslam

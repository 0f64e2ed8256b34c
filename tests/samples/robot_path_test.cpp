#include "samples/robot_path.h"

#include <cmath>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

namespace oslam {
namespace {

// Residuals e_i = x_i - f(x_{i-1}, v_i), heading wrapped.
std::vector<Eigen::Vector3d> MotionResiduals(const DrivenPath& path) {
  std::vector<Eigen::Vector3d> residuals;
  for (size_t i = 1; i < path.true_poses.size(); ++i) {
    Eigen::Vector3d e = path.true_poses[i].Vector() -
                        ApplyIncrement(path.true_poses[i - 1], path.increments[i]).Vector();
    e.z() = WrapAngle(e.z());
    residuals.push_back(e);
  }
  return residuals;
}

PathSpec MixedCommands() {
  PathSpec spec;
  spec.commands = "F400 L300 F300 R300 B300 L200 R200";  // 2000 steps
  return spec;
}

// Sum of e^T Q^-1 e over the path, with Q from the unscaled noise options.
double Nees(const DrivenPath& path, const MotionNoiseOptions& options, long* dof) {
  const std::vector<Eigen::Vector3d> residuals = MotionResiduals(path);
  double sum = 0.0;
  for (size_t i = 0; i < residuals.size(); ++i) {
    const Eigen::Matrix3d q =
        MotionCovariance(path.true_poses[i].theta, path.increments[i + 1], options);
    sum += residuals[i].dot(q.ldlt().solve(residuals[i]));
  }
  *dof = 3 * static_cast<long>(residuals.size());
  return sum;
}

TEST(RobotPath, OdometryErrorFollowsTheSpecMotionNoise) {
  // Chi-square check: with e_i ~ N(0, Q_i), sum e^T Q^-1 e ~ chi2(3N), mean
  // 3N and std sqrt(6N). Tolerance 4 std (the seed is fixed, so this is a
  // check of the noise model, not a flaky statistical test).
  OdometryNoise noise;
  std::mt19937_64 rng(42);
  const DrivenPath path = DrivePath(MixedCommands(), noise, -1, rng);
  ASSERT_EQ(path.true_poses.size(), 2001u);
  long dof = 0;
  const double nees = Nees(path, noise.model, &dof);
  const double sigma = std::sqrt(2.0 * dof);
  std::printf("odometry chi-square: %.1f for %ld dof (expected %ld +- %.1f), z = %.2f\n", nees, dof,
              dof, sigma, (nees - dof) / sigma);
  EXPECT_NEAR(nees, dof, 4.0 * sigma);

  // Each robot-frame component separately: variance ratio within 10 %.
  Eigen::Vector3d ratio = Eigen::Vector3d::Zero();
  const std::vector<Eigen::Vector3d> residuals = MotionResiduals(path);
  for (size_t i = 0; i < residuals.size(); ++i) {
    const OdometryIncrement& v = path.increments[i + 1];
    const double alpha = path.true_poses[i].theta + 0.5 * v.turn_rad;
    const Eigen::Vector3d robot(
        std::cos(alpha) * residuals[i].x() + std::sin(alpha) * residuals[i].y(),
        -std::sin(alpha) * residuals[i].x() + std::cos(alpha) * residuals[i].y(), residuals[i].z());
    const Eigen::Vector3d scale(std::abs(v.distance_m), std::abs(v.distance_m),
                                std::abs(v.turn_rad));
    const Eigen::Vector3d sigma_i =
        noise.model.additive_std + noise.model.multiplicative.cwiseProduct(scale);
    ratio += robot.cwiseQuotient(sigma_i).cwiseAbs2();
  }
  ratio /= static_cast<double>(residuals.size());
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(ratio[k], 1.0, 0.1) << "component " << k;
}

TEST(RobotPath, NoiseScaleScalesTheStandardDeviations) {
  OdometryNoise noise;
  noise.scale = 2.0;
  std::mt19937_64 rng(7);
  const DrivenPath path = DrivePath(MixedCommands(), noise, -1, rng);
  long dof = 0;
  // Against the unscaled Q the errors are twice as large: NEES ~ 4 x dof.
  EXPECT_NEAR(Nees(path, noise.model, &dof) / dof, 4.0, 0.4);
  EXPECT_NEAR(Nees(path, ScaledNoise(noise), &dof) / dof, 1.0, 0.1);
}

TEST(RobotPath, ZeroNoiseScaleGivesPerfectOdometry) {
  OdometryNoise noise;
  noise.scale = 0.0;
  std::mt19937_64 rng(1);
  PathSpec spec;
  spec.commands = "F5 L9 F3 R2 B1";
  spec.step_jitter_m = spec.turn_jitter_rad = 0.0;
  const DrivenPath path = DrivePath(spec, noise, -1, rng);
  ASSERT_EQ(path.true_poses.size(), 21u);
  for (size_t i = 0; i < path.true_poses.size(); ++i)
    EXPECT_LT((path.true_poses[i].Vector() - path.odometry_poses[i].Vector()).norm(), 1e-12);
  EXPECT_NEAR(path.true_poses.back().theta, DegToRad(70.0), 1e-12);
}

TEST(RobotPath, WaypointsAreReachedDespiteNoiseAndStepsAreStopAndGo) {
  OdometryNoise noise;
  std::mt19937_64 rng(3);
  PathSpec spec;
  spec.start = {0, 0, 0};
  spec.waypoints = {{2, 0}, {2, 2}, {0, 2}, {0, 0}};
  const DrivenPath path = DrivePath(spec, noise, -1, rng);
  const Pose2& end = path.true_poses.back();
  EXPECT_LT(std::hypot(end.x, end.y), 0.75 * spec.step_m);
  for (size_t i = 1; i < path.increments.size(); ++i) {
    const OdometryIncrement& v = path.increments[i];
    // One command per frame: a 20 cm step or a 10 degree turn, up to the jitter.
    const bool step = std::abs(v.distance_m - 0.2) < 5 * spec.step_jitter_m && v.turn_rad == 0.0;
    const bool turn = v.distance_m == 0.0 && std::abs(std::abs(v.turn_rad) - spec.turn_step_rad) <
                                                 5 * spec.turn_jitter_rad;
    EXPECT_TRUE(step || turn) << i;
  }
  std::mt19937_64 capped_rng(3);
  EXPECT_EQ(DrivePath(spec, noise, 10, capped_rng).true_poses.size(), 10u);
}

// Filmed at n frames per step: the stops are the same poses at every n-th
// frame, the frames between move steadily from one stop to the next (a step
// forward in equal parts, a turn in equal angles), and the odometry's
// increments add up to the step's.
TEST(RobotPath, FilmedAtFramesPerStepKeepsTheStopsAndMovesBetweenThem) {
  OdometryNoise noise;
  std::mt19937_64 rng(5);
  PathSpec spec;
  spec.start = {0, 0, 0};
  spec.waypoints = {{1, 0}, {1, 1}};
  const DrivenPath stops = DrivePath(spec, noise, -1, rng);
  const int n = 4;
  const DrivenPath filmed = FilmedAtFramesPerStep(stops, n);
  ASSERT_EQ(filmed.true_poses.size(), (stops.true_poses.size() - 1) * n + 1);
  ASSERT_EQ(filmed.odometry_poses.size(), filmed.true_poses.size());
  ASSERT_EQ(filmed.increments.size(), filmed.true_poses.size());
  for (size_t i = 0; i < stops.true_poses.size(); ++i) {
    EXPECT_EQ(filmed.true_poses[i * n].Vector(), stops.true_poses[i].Vector()) << i;
    EXPECT_EQ(filmed.odometry_poses[i * n].Vector(), stops.odometry_poses[i].Vector()) << i;
  }
  for (size_t i = 1; i < stops.true_poses.size(); ++i) {
    const Pose2 &from = stops.true_poses[i - 1], &to = stops.true_poses[i];
    const double step_m = std::hypot(to.x - from.x, to.y - from.y);
    const double turn_rad = WrapAngle(to.theta - from.theta);
    double distance_sum = 0, turn_sum = 0;
    for (int k = 1; k <= n; ++k) {
      const Pose2 &a = filmed.true_poses[(i - 1) * n + k - 1],
                  &b = filmed.true_poses[(i - 1) * n + k];
      // Equal parts of the motion (a line or an arc: chords of equal length).
      EXPECT_NEAR(std::hypot(b.x - a.x, b.y - a.y), step_m / n, 1e-3 * step_m + 1e-12) << i;
      EXPECT_NEAR(WrapAngle(b.theta - a.theta), turn_rad / n, 1e-9) << i;
      distance_sum += filmed.increments[(i - 1) * n + k].distance_m;
      turn_sum += filmed.increments[(i - 1) * n + k].turn_rad;
    }
    EXPECT_NEAR(distance_sum, stops.increments[i].distance_m, 1e-12) << i;
    EXPECT_NEAR(turn_sum, stops.increments[i].turn_rad, 1e-12) << i;
  }
  EXPECT_EQ(FilmedAtFramesPerStep(stops, 1).true_poses.size(), stops.true_poses.size());
}

}  // namespace
}  // namespace oslam

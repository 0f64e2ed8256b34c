#include "solver/levenberg_marquardt.h"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>

namespace oslam {
namespace {

SolverOptions Options() {
  SolverOptions options;
  options.initial_damping = 1e-3;
  options.max_damping = 1.0;
  return options;
}

TEST(LevenbergMarquardtTest, DampingRisesEverFasterOnRejectedStepsUpToTheLimit) {
  const SolverOptions options = Options();
  LevenbergMarquardtStrategy lm(options);
  EXPECT_EQ(lm.damping(), 1e-3);
  // lambda *= nu, nu doubling: x2, x4, x8, ...
  std::vector<double> seen;
  while (lm.StepRejected()) seen.push_back(lm.damping());
  ASSERT_GE(seen.size(), 3u);
  EXPECT_DOUBLE_EQ(seen[0], 2e-3);
  EXPECT_DOUBLE_EQ(seen[1], 8e-3);
  EXPECT_DOUBLE_EQ(seen[2], 64e-3);
  EXPECT_LE(seen.back(), options.max_damping);
  EXPECT_GT(lm.damping(), options.max_damping);  // the rejection that gave up
}

TEST(LevenbergMarquardtTest, DampingFallsOnAGoodStepAndRisesOnAPoorOne) {
  const SolverOptions options = Options();
  LevenbergMarquardtStrategy good(options), neutral(options), poor(options);
  good.StepAccepted(1.0);  // the model predicted the decrease exactly: / 3
  EXPECT_DOUBLE_EQ(good.damping(), 1e-3 / 3.0);
  neutral.StepAccepted(0.5);  // 1 - 0^3: unchanged
  EXPECT_DOUBLE_EQ(neutral.damping(), 1e-3);
  poor.StepAccepted(0.01);  // 1 - (-0.98)^3 = 1.941...
  EXPECT_DOUBLE_EQ(poor.damping(), 1e-3 * (1.0 + std::pow(0.98, 3)));
  // A gain ratio far above 1 lowers it by at most 3.
  LevenbergMarquardtStrategy surprising(options);
  surprising.StepAccepted(5.0);
  EXPECT_DOUBLE_EQ(surprising.damping(), 1e-3 / 3.0);
}

TEST(LevenbergMarquardtTest, AnAcceptedStepResetsTheRejectionGrowthAndDampingStaysPositive) {
  SolverOptions options = Options();
  options.initial_damping = 1e-14;
  LevenbergMarquardtStrategy lm(options);
  ASSERT_TRUE(lm.StepRejected());  // 2e-14, nu 4
  ASSERT_TRUE(lm.StepRejected());  // 8e-14, nu 8
  lm.StepAccepted(0.5);            // unchanged, nu back to 2
  EXPECT_DOUBLE_EQ(lm.damping(), 8e-14);
  ASSERT_TRUE(lm.StepRejected());
  EXPECT_DOUBLE_EQ(lm.damping(), 16e-14);
  for (int i = 0; i < 10; ++i) lm.StepAccepted(1.0);
  EXPECT_EQ(lm.damping(), LevenbergMarquardtStrategy::kMinDamping);
}

TEST(LevenbergMarquardtTest, AcceptsStepsByGainRatioAndStretchesOnlySurprisinglyGoodOnes) {
  SolverOptions options = Options();
  options.min_relative_decrease = 0.1;
  const LevenbergMarquardtStrategy lm(options);
  EXPECT_TRUE(lm.Accepts(0.5));
  EXPECT_FALSE(lm.Accepts(0.1));
  EXPECT_FALSE(lm.Accepts(-2.0));
  EXPECT_FALSE(lm.Extrapolates(2.0));  // max_step_extrapolation 0: off

  SolverOptions stretching = options;
  stretching.max_step_extrapolation = 16.0;
  const LevenbergMarquardtStrategy stretches(stretching);
  EXPECT_TRUE(stretches.Extrapolates(1.3));
  EXPECT_FALSE(stretches.Extrapolates(1.0));

  SolverOptions one = options;
  one.max_step_extrapolation = 1.0;  // a multiple of at most 1 stretches nothing
  EXPECT_FALSE(LevenbergMarquardtStrategy(one).Extrapolates(2.0));
}

TEST(LevenbergMarquardtTest, PredictedDecreaseIsTheModelsForTheDampedStep) {
  // A 2-variable model: H, g; delta solves (H + lambda D) delta = -g with
  // D = diag(H) clamped (the second entry to min_diagonal).
  SolverOptions options = Options();
  options.min_diagonal = 0.5;
  LevenbergMarquardtStrategy lm(options);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(lm.StepRejected());  // lambda 0.064
  Eigen::Matrix2d h;
  h << 4.0, 0.3, 0.3, 0.1;
  const Eigen::Vector2d g(1.0, -2.0);
  const Eigen::Vector2d d(h(0, 0), options.min_diagonal);
  const Eigen::Matrix2d damped = h + lm.damping() * Eigen::Matrix2d(d.asDiagonal());
  const Eigen::Vector2d delta = damped.ldlt().solve(-g);
  // m(0) - m(delta) with m(x) = g'x + 1/2 x'Hx.
  const double expected = -(g.dot(delta) + 0.5 * delta.dot(h * delta));
  EXPECT_NEAR(lm.PredictedDecrease(g, h.diagonal(), delta), expected, 1e-12 * expected);
  EXPECT_GT(expected, 0.0);
  EXPECT_EQ(DampingScale(0.1, options), 0.5);
  EXPECT_EQ(DampingScale(3.0, options), 3.0);
  options.max_diagonal = 2.0;
  EXPECT_EQ(DampingScale(3.0, options), 2.0);
}

TEST(LevenbergMarquardtTest, ConvergenceTests) {
  SolverOptions options;
  options.gradient_tolerance = 1e-6;
  options.step_tolerance = 1e-4;
  options.function_tolerance = 1e-3;
  options.absolute_function_tolerance = 0.01;
  const LevenbergMarquardtStrategy lm(options);
  EXPECT_TRUE(lm.GradientConverged(Eigen::Vector2d(1e-7, -1e-6)));
  EXPECT_FALSE(lm.GradientConverged(Eigen::Vector2d(1e-7, -2e-6)));
  EXPECT_TRUE(lm.StepConverged(Eigen::Vector3d(0.0, -1e-4, 5e-5)));
  EXPECT_FALSE(lm.StepConverged(Eigen::Vector3d(0.0, -1e-4, 2e-4)));
  // Relative: 1e-3 of 100 = 0.1 > the absolute 0.01.
  EXPECT_TRUE(lm.CostConverged(100.0, 99.95));
  EXPECT_FALSE(lm.CostConverged(100.0, 99.8));
  // Absolute: 0.01 nats > 1e-3 of 1.
  EXPECT_TRUE(lm.CostConverged(1.0, 0.995));
  EXPECT_FALSE(lm.CostConverged(1.0, 0.98));
  // A rise counts as no decrease.
  EXPECT_TRUE(lm.CostConverged(1.0, 1.5));
}

// The cost along t delta is f(t) = 10 - 2 t + b t^2. With b = 0.5 (f(1) =
// 8.5), the parabola through f(0), f'(0) = -2 and f(1) has its minimum at
// t = 2, where the search goes, and then stops (the refit gives 2 again).
TEST(StepExtrapolationTest, StretchesToTheParabolasMinimum) {
  auto f = [](double t) { return 10.0 - 2.0 * t + 0.5 * t * t; };
  StepExtrapolation search(10.0, -2.0, f(1.0), 16.0);
  double t = 0.0;
  ASSERT_TRUE(search.Next(&t));
  EXPECT_DOUBLE_EQ(t, 2.0);
  EXPECT_TRUE(search.Report(true, f(t)));
  EXPECT_FALSE(search.Next(&t));
  EXPECT_EQ(search.multiple(), 2.0);
  EXPECT_EQ(search.cost(), 8.0);
  EXPECT_EQ(search.stretches(), 1);
}

TEST(StepExtrapolationTest, StopsAtTheLargestMultipleAndDoublesWhereTheCostBendsDown) {
  // f(1) below the tangent line: no finite minimum, so twice as far, and
  // never beyond the largest multiple.
  StepExtrapolation search(10.0, -2.0, 7.0, 3.5);
  double t = 0.0;
  ASSERT_TRUE(search.Next(&t));
  EXPECT_EQ(t, 2.0);
  EXPECT_TRUE(search.Report(true, 3.0));
  ASSERT_TRUE(search.Next(&t));
  EXPECT_EQ(t, 3.5);  // 4, clamped
  EXPECT_TRUE(search.Report(true, 1.0));
  EXPECT_FALSE(search.Next(&t));  // 3.5 again: not 1.5 times beyond 3.5
  EXPECT_EQ(search.multiple(), 3.5);
  EXPECT_EQ(search.cost(), 1.0);
  EXPECT_EQ(search.stretches(), 2);
}

TEST(StepExtrapolationTest, BacksOffAThirdOfTheWayAfterAWorseCandidate) {
  // f(1) = 8.2 with f(0) = 10, f'(0) = -2: the parabola's minimum at t = 5.
  StepExtrapolation search(10.0, -2.0, 8.2, 16.0);
  double first = 0.0, second = 0.0, third = 0.0;
  ASSERT_TRUE(search.Next(&first));
  EXPECT_NEAR(first, 5.0, 1e-12);
  EXPECT_FALSE(search.Report(true, 8.5));  // worse than f(1)
  ASSERT_TRUE(search.Next(&second));
  EXPECT_DOUBLE_EQ(second, 1.0 + (first - 1.0) / 3.0);
  EXPECT_FALSE(search.Report(false, 0.0));  // could not be evaluated
  // 1 + (second - 1) / 3 < 1.5: over.
  EXPECT_FALSE(search.Next(&third));
  EXPECT_EQ(search.multiple(), 1.0);
  EXPECT_EQ(search.cost(), 8.2);
  EXPECT_EQ(search.stretches(), 0);
}

TEST(StepExtrapolationTest, EvaluatesAtMostThreeCandidates) {
  // The cost keeps falling linearly: every candidate doubles t.
  StepExtrapolation search(10.0, -1.0, 9.0, 1000.0);
  double t = 0.0;
  int candidates = 0;
  while (search.Next(&t)) {
    ++candidates;
    EXPECT_TRUE(search.Report(true, 10.0 - 1.0 * t - 0.01));
  }
  EXPECT_EQ(candidates, StepExtrapolation::kMaxEvaluations);
  EXPECT_EQ(search.multiple(), 8.0);
}

TEST(StepExtrapolationTest, NoSearchUpAnAscentOrAFlatDirection) {
  double t = 0.0;
  StepExtrapolation up(10.0, 0.5, 9.0, 16.0);
  EXPECT_FALSE(up.Next(&t));
  StepExtrapolation flat(10.0, 0.0, 9.0, 16.0);
  EXPECT_FALSE(flat.Next(&t));
  StepExtrapolation nan(10.0, std::numeric_limits<double>::quiet_NaN(), 9.0, 16.0);
  EXPECT_FALSE(nan.Next(&t));
  EXPECT_EQ(nan.multiple(), 1.0);
  EXPECT_EQ(nan.stretches(), 0);
}

}  // namespace
}  // namespace oslam

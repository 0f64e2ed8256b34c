// The 10,000-pose benchmark scene (bench/solver_bench.cpp, 10 laps of a
// 60 m x 40 m loop, 200 objects, ~67,000 detections at E = 30 px) solved
// from raw odometry through the keyframe start, seeds 1-5: every solve
// converges, and to a cost no higher than the solve started at the truth
// reaches. (Before the keyframe start none converged in 50 iterations.)
// Labelled slow: ~5 s per seed on one core.
#include <gtest/gtest.h>

#include "calib/hyperbolic_camera.h"
#include "slam/geometric_slam.h"
#include "tests/slam/synthetic_scene.h"

namespace oslam {
namespace {

class LargeScene : public ::testing::TestWithParam<unsigned> {};

TEST_P(LargeScene, ConvergesFromOdometryNoHigherThanFromTheTruth) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const testing::SyntheticScene scene =
      testing::MakeSyntheticScene(camera, testing::LargeLoop(GetParam()));
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  const GeometricSlamResult started = GeometricSlam(camera, options).Solve(scene.problem);
  ASSERT_TRUE(started.keyframe_start.used);
  EXPECT_EQ(started.summary.termination, TerminationType::kConverged) << started.summary.message;

  const GeometricSlamResult truth = testing::TruthAsResult(scene);
  options.solver.max_step_extrapolation = 16.0;  // from the truth it crawls without
  const GeometricSlamResult from_truth =
      GeometricSlam(camera, options).Solve(scene.problem, &truth);
  ASSERT_EQ(from_truth.summary.termination, TerminationType::kConverged);
  EXPECT_LE(started.summary.final_cost, from_truth.summary.final_cost + 0.05)
      << "from the truth: " << from_truth.summary.final_cost;
  RecordProperty("final_cost", std::to_string(started.summary.final_cost));
  RecordProperty("from_truth_cost", std::to_string(from_truth.summary.final_cost));
}

INSTANTIATE_TEST_SUITE_P(Seeds, LargeScene, ::testing::Values(1u, 2u, 3u, 4u, 5u));

}  // namespace
}  // namespace oslam

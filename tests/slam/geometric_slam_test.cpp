// Geometric SLAM on simulated data: recovery of the truth, accuracy under
// thesis-level noise, an object seen once, and warm-started re-solves.
#include "slam/geometric_slam.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/LU>

#include "calib/hyperbolic_camera.h"
#include "core/angles.h"
#include "core/error.h"
#include "slam/factors.h"
#include "solver/sparse_solver.h"
#include "tests/slam/synthetic_scene.h"

namespace oslam {
namespace {

double TrajectoryRmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i)
    sum += std::pow(a[i].x - b[i].x, 2) + std::pow(a[i].y - b[i].y, 2);
  return std::sqrt(sum / a.size());
}

struct ObjectErrors {
  double median_position = 0, max_position = 0, mean_diameter = 0, mean_height = 0;
};

ObjectErrors Compare(const GeometricSlamResult& result, const testing::SyntheticScene& scene) {
  std::vector<double> position;
  ObjectErrors errors;
  for (const MappedObject& object : result.objects) {
    const CylinderGeometry& truth = scene.true_objects[object.id];
    position.push_back((object.geometry.base_world - truth.base_world).norm());
    errors.mean_diameter += std::abs(object.geometry.diameter_m - truth.diameter_m);
    errors.mean_height += std::abs(object.geometry.height_m - truth.height_m);
  }
  std::sort(position.begin(), position.end());
  errors.median_position = position[position.size() / 2];
  errors.max_position = position.back();
  errors.mean_diameter /= position.size();
  errors.mean_height /= position.size();
  return errors;
}

TEST(GeometricSlamTest, NoiseFreeDataRecoversTheTruthFromFirstDetectionInitialisation) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  testing::SyntheticSceneOptions scene_options;
  scene_options.num_poses = 200;
  const testing::SyntheticScene scene = testing::MakeSyntheticScene(camera, scene_options);
  ASSERT_GT(scene.problem.observations.size(), 500u);

  GeometricSlamOptions options;
  options.pixel_std_px = 0.01;  // exact detections: the priors must not pull
  options.solver.step_tolerance = 1e-9;
  options.solver.function_tolerance = 1e-14;
  options.initial_refinement_detections = 0;  // objects from their first detection only
  GeometricSlam slam(camera, options);
  const GeometricSlamResult result = slam.Solve(scene.problem);
  ASSERT_EQ(result.summary.termination, TerminationType::kConverged) << result.summary.message;
  EXPECT_GT(result.summary.initial_cost, 1e3 * result.summary.final_cost);
  // Millimetres: what is left is the (proper) size priors' pull.
  EXPECT_LT(TrajectoryRmse(result.trajectory, scene.true_trajectory), 3e-3);
  const ObjectErrors errors = Compare(result, scene);
  EXPECT_LT(errors.max_position, 3e-3);
  EXPECT_LT(errors.mean_diameter, 3e-3);
  EXPECT_LT(errors.mean_height, 3e-3);
  for (size_t i = 0; i < result.trajectory.size(); ++i)
    EXPECT_NEAR(WrapAngle(result.trajectory[i].theta - scene.true_trajectory[i].theta), 0, 1e-4);
}

TEST(GeometricSlamTest, ThesisNoiseGivesObjectsWithinTolerance) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  double median_sum = 0;
  for (unsigned seed : {1u, 2u, 3u}) {
    testing::SyntheticSceneOptions scene_options;
    scene_options.pixel_std_px = 30.0;
    scene_options.odometry_noise = true;
    scene_options.seed = seed;
    const testing::SyntheticScene scene = testing::MakeSyntheticScene(camera, scene_options);
    GeometricSlamOptions options;
    options.compute_pose_covariances = true;
    GeometricSlam slam(camera, options);
    const GeometricSlamResult result = slam.Solve(scene.problem);
    ASSERT_TRUE(result.summary.IsUsable()) << result.summary.message;
    ASSERT_TRUE(result.evidence.valid);
    const ObjectErrors errors = Compare(result, scene);
    const double odometry_rmse = TrajectoryRmse(
        ComposeOdometry(scene.problem.first_pose, scene.problem.increments), scene.true_trajectory);
    const double rmse = TrajectoryRmse(result.trajectory, scene.true_trajectory);
    std::printf(
        "seed %u: ATE %.3f m (odometry %.3f m), object median %.3f m max %.3f m, "
        "|d| %.3f m |h| %.3f m, %d iterations, %.1f ms\n",
        seed, rmse, odometry_rmse, errors.median_position, errors.max_position,
        errors.mean_diameter, errors.mean_height, result.summary.iterations,
        1e3 * result.summary.total_time_s);
    // E = 30 px is coarse for the LPA mirror (a 200 px image radius): these
    // are the estimator's errors, not the optimiser's - started from the
    // truth it reaches the same minimum.
    EXPECT_LT(errors.median_position, 0.5);
    EXPECT_LT(errors.max_position, 1.0);
    const GeometricSlamResult truth = testing::TruthAsResult(scene);
    const GeometricSlamResult from_truth = slam.Solve(scene.problem, &truth);
    EXPECT_NEAR(result.summary.final_cost, from_truth.summary.final_cost,
                1e-4 * from_truth.summary.final_cost);
    EXPECT_LT(rmse, odometry_rmse);
    median_sum += errors.median_position;
    // Reported covariances are consistent with the errors (3-sigma, position).
    int inside = 0;
    for (const MappedObject& object : result.objects) {
      const Eigen::Vector3d d =
          object.geometry.base_world - scene.true_objects[object.id].base_world;
      const Eigen::Matrix3d c = object.covariance.topLeftCorner<3, 3>();
      ASSERT_GT(c.determinant(), 0);
      if (d.dot(c.inverse() * d) < 14.16) ++inside;  // chi2(3) 99.7 %
    }
    EXPECT_GE(inside, static_cast<int>(result.objects.size()) - 2);
    ASSERT_EQ(result.pose_covariances.size(), result.trajectory.size());
    EXPECT_GT(result.pose_covariances.back().determinant(), 0);
  }
  EXPECT_LT(median_sum / 3, 0.3);
}

TEST(GeometricSlamTest, AnObjectSeenOnceIsSolvedWithItsPriors) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  testing::SyntheticSceneOptions scene_options;
  scene_options.num_poses = 60;
  scene_options.pixel_std_px = 30.0;
  scene_options.seed = 4;
  testing::SyntheticScene scene = testing::MakeSyntheticScene(camera, scene_options);
  // Keep a single detection of object 0.
  auto& observations = scene.problem.observations;
  bool kept = false;
  observations.erase(std::remove_if(observations.begin(), observations.end(),
                                    [&](const SliceObservation& o) {
                                      if (o.object_id != 0) return false;
                                      if (!kept) return !(kept = true);
                                      return true;
                                    }),
                     observations.end());
  ASSERT_TRUE(kept);
  GeometricSlam slam(camera, GeometricSlamOptions());
  const GeometricSlamResult result = slam.Solve(scene.problem);
  ASSERT_TRUE(result.summary.IsUsable()) << result.summary.message;
  ASSERT_TRUE(result.evidence.valid);
  const MappedObject& once = result.objects.front();
  ASSERT_EQ(once.id, 0);
  EXPECT_EQ(once.num_observations, 1);
  // Range is weakly known: the covariance is large but proper.
  EXPECT_GT(once.covariance.determinant(), 0);
  const Eigen::Matrix3d position_covariance = once.covariance.topLeftCorner<3, 3>();
  EXPECT_GT(position_covariance.trace(), 1e-3);
}

// The LPA synthetic scene at the thesis's noise, its dead-reckoned poses and
// its detections per object (shared by the object-alone tests).
struct NoisyScene {
  HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  testing::SyntheticScene scene;
  std::vector<Pose2> poses;
  std::map<int, std::vector<const SliceObservation*>> by_object;

  NoisyScene() {
    testing::SyntheticSceneOptions options;
    options.pixel_std_px = 30.0;
    options.odometry_noise = true;
    scene = testing::MakeSyntheticScene(camera, options);
    poses = ComposeOdometry(scene.problem.first_pose, scene.problem.increments);
    for (const auto& observation : scene.problem.observations)
      by_object[observation.object_id].push_back(&observation);
  }
  NoisyScene(const NoisyScene&) = delete;  // by_object points into scene
  NoisyScene& operator=(const NoisyScene&) = delete;
};

// The initial refinement (poses held at odometry) moves objects from their
// single-detection start towards the truth, and the cold solve then needs
// few iterations.
TEST(GeometricSlamTest, RefinementFromFirstDetectionsImprovesTheObjectStart) {
  const NoisyScene noisy;
  const HyperbolicCamera& camera = noisy.camera;
  const testing::SyntheticScene& scene = noisy.scene;
  const std::vector<Pose2>& poses = noisy.poses;
  const auto& by_object = noisy.by_object;
  double before = 0.0, after = 0.0;
  for (const auto& [id, list] : by_object) {
    const ClassPrior& prior = scene.problem.classes[scene.problem.object_class.at(id)];
    CylinderGeometry object;
    ASSERT_TRUE(InitialObjectFromDetection(camera, poses[list.front()->frame], list.front()->slice,
                                           prior, &object));
    const Eigen::Vector3d truth = scene.true_objects[id].base_world;
    before += (object.base_world - truth).head<2>().norm();
    const std::vector<const SliceObservation*> first(
        list.begin(), list.begin() + std::min<size_t>(20, list.size()));
    RefineObjectFromDetections(camera, poses, first, prior, 30.0, &object);
    after += (object.base_world - truth).head<2>().norm();
  }
  EXPECT_LT(after, 0.5 * before);
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  GeometricSlam slam(camera, options);
  const GeometricSlamResult result = slam.Solve(scene.problem);
  EXPECT_EQ(result.summary.termination, TerminationType::kConverged);
  EXPECT_LE(result.summary.iterations, 10);
}

// The object-alone evidence (delayed acceptance's screen) is the sparse
// solver's Laplace evidence of the same factors with every pose fixed.
TEST(GeometricSlamTest, ObjectEvidenceWithPosesHeldEqualsTheSolversOnFixedPoses) {
  const NoisyScene noisy;
  const HyperbolicCamera& camera = noisy.camera;
  const testing::SyntheticScene& scene = noisy.scene;
  const std::vector<Pose2>& poses = noisy.poses;
  const auto& by_object = noisy.by_object;
  int checked = 0;
  for (const auto& [id, list] : by_object) {
    const ClassPrior& prior = scene.problem.classes[scene.problem.object_class.at(id)];
    CylinderGeometry object = scene.true_objects[id];
    object.base_world += Eigen::Vector3d(0.2, -0.1, 0.05);  // a start off the optimum
    double log_evidence = 0, detections_r2 = 0;
    ASSERT_TRUE(ObjectLogEvidenceWithPosesHeld(camera, poses, list, prior, 30.0, &object,
                                               &log_evidence, &detections_r2));

    FactorGraph graph;
    std::vector<int> pose_keys;
    for (const Pose2& pose : poses)
      pose_keys.push_back(graph.AddPose(pose.x, pose.y, pose.theta, true));
    const int base = graph.AddVariable(scene.true_objects[id].base_world);
    const int size = graph.AddVariable(
        Eigen::Vector2d(scene.true_objects[id].diameter_m, scene.true_objects[id].height_m));
    graph.Add(MakeLocationPrior(base, prior.location_mean_m, prior.location_std_m));
    graph.Add(MakeSizePrior(size, prior.size_mean_m, prior.size_std_m));
    for (const SliceObservation* observation : list)
      graph.Emplace<BoundingSliceFactor>(&camera, pose_keys[observation->frame], base, size,
                                         observation->slice, 30.0);
    SolverOptions tight;  // converged well past the 1e-3 compared here
    tight.absolute_function_tolerance = 0.0;
    tight.function_tolerance = 1e-12;
    SparseSolver solver(tight);
    const SolveResult solved = solver.Solve(&graph);
    ASSERT_TRUE(solved.evidence.valid);
    EXPECT_NEAR(log_evidence, solved.evidence.log_evidence, 1e-3) << "object " << id;
    EXPECT_LT((object.base_world - graph.values().Get(base)).norm(), 1e-3) << "object " << id;
    double solver_r2 = 0;
    for (size_t f = 2; f < solved.squared_errors.size(); ++f) solver_r2 += solved.squared_errors[f];
    EXPECT_NEAR(detections_r2, solver_r2, 1e-3 * (1 + solver_r2)) << "object " << id;
    ++checked;
  }
  EXPECT_GE(checked, 5);
}

// The default synthetic loop with the thesis's pixel noise and noisy odometry.
testing::SyntheticScene NoisyLoop(const CameraModel& camera, unsigned seed) {
  testing::SyntheticSceneOptions options;
  options.pixel_std_px = 30.0;
  options.odometry_noise = true;
  options.seed = seed;
  return testing::MakeSyntheticScene(camera, options);
}

TEST(GeometricSlamTest, WarmStartAfterAnAssociationChangeConvergesFasterToTheSameAnswer) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const testing::SyntheticScene scene = NoisyLoop(camera, 9);
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  GeometricSlam slam(camera, options);
  const GeometricSlamResult first = slam.Solve(scene.problem);
  ASSERT_TRUE(first.summary.IsUsable());

  // Same association again: the solver reuses its analysis.
  const GeometricSlamResult same = slam.Solve(scene.problem, &first);
  EXPECT_TRUE(same.summary.reused_symbolic_analysis);
  EXPECT_LE(same.summary.iterations, 2);

  // A "split": the last detection of object 3 becomes object 99 (same class).
  const GeometricSlamProblem changed = testing::SplitLastDetection(scene.problem, 3, 99);
  const GeometricSlamResult warm = slam.Solve(changed, &first);
  GeometricSlam cold_slam(camera, options);
  const GeometricSlamResult cold = cold_slam.Solve(changed);
  ASSERT_TRUE(warm.summary.IsUsable());
  ASSERT_TRUE(cold.summary.IsUsable());
  EXPECT_LT(warm.summary.iterations, cold.summary.iterations);
  EXPECT_NEAR(warm.evidence.log_evidence, cold.evidence.log_evidence, 1e-3);
  EXPECT_LT(TrajectoryRmse(warm.trajectory, cold.trajectory), 1e-4);
  // One more object costs an Occam factor unless it explains the data better.
  EXPECT_LT(warm.evidence.log_evidence, first.evidence.log_evidence);
}

void ExpectSameBits(const GeometricSlamResult& a, const GeometricSlamResult& b) {
  EXPECT_EQ(a.evidence.log_evidence, b.evidence.log_evidence);
  EXPECT_EQ(a.summary.final_cost, b.summary.final_cost);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    EXPECT_EQ(a.trajectory[i].x, b.trajectory[i].x);
    EXPECT_EQ(a.trajectory[i].theta, b.trajectory[i].theta);
  }
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (size_t j = 0; j < a.objects.size(); ++j) {
    EXPECT_EQ(a.objects[j].geometry.base_world, b.objects[j].geometry.base_world);
    EXPECT_EQ(a.objects[j].squared_residual, b.objects[j].squared_residual);
  }
}

// docs/method.md §9.6: proposals linearised at one state's solution share most
// Jacobians. Kept linearisations must change nothing but the time: every
// proposal equals a solve without them bit for bit, and only the factors
// whose variables moved (a merge's absorbed detections; priors have no slot)
// are linearised again. A problem that changes a detection's measurement
// under the same id drops them.
TEST(GeometricSlamTest, ReusedLinearizationsGiveTheSameProposalsBitForBit) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const testing::SyntheticScene scene = NoisyLoop(camera, 9);
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  const GeometricSlamResult state = GeometricSlam(camera, options).Solve(scene.problem);
  ASSERT_TRUE(state.summary.IsUsable());
  const int num_objects = static_cast<int>(state.objects.size());
  ASSERT_GE(num_objects, 4);

  // Split: the last detection of object 1 becomes object 99 at 1's point.
  const GeometricSlamProblem split = testing::SplitLastDetection(scene.problem, 1, 99);
  GeometricSlamResult split_start = state;
  MappedObject half = state.objects[1];
  half.id = 99;
  split_start.objects.push_back(half);
  // Merge: object 3's detections join object 2 (at 2's point).
  GeometricSlamProblem merge = scene.problem;
  int absorbed = 0;
  for (SliceObservation& observation : merge.observations)
    if (observation.object_id == 3) observation.object_id = 2, ++absorbed;
  merge.object_class.erase(3);
  const int prior_factors = 2 * num_objects;  // location and size prior per object

  options.solver.max_iterations = 0;
  options.solver.independent_of_history = true;
  GeometricSlam fresh(camera, options);
  options.solver.reuse_linearizations = true;
  GeometricSlam reusing(camera, options);
  const GeometricSlamResult first = reusing.Solve(split, &split_start);
  ExpectSameBits(first, fresh.Solve(split, &split_start));
  EXPECT_EQ(first.summary.reused_linearizations, 0);
  const GeometricSlamResult merged = reusing.Solve(merge, &state);
  ExpectSameBits(merged, fresh.Solve(merge, &state));
  EXPECT_EQ(merged.summary.computed_linearizations, absorbed + prior_factors - 2);
  EXPECT_EQ(merged.summary.reused_linearizations,
            merged.summary.num_factors - merged.summary.computed_linearizations);
  // The absorbed detections were linearised as object 2's class, in other
  // slots than as object 3's: the split reuses its own.
  ASSERT_NE(scene.problem.object_class.at(2), scene.problem.object_class.at(3));
  const GeometricSlamResult again = reusing.Solve(split, &split_start);
  ExpectSameBits(again, first);
  EXPECT_EQ(again.summary.computed_linearizations, prior_factors + 2);
  const GeometricSlamResult third = reusing.Solve(split, &split_start);
  ExpectSameBits(third, first);
  EXPECT_EQ(third.summary.computed_linearizations, prior_factors + 2);

  // A class switch to a class of another footprint (two box classes of
  // other aspects): the same variables and Jacobian shape, another function.
  // Its detections get their own slots, so nothing the old class left behind
  // is reused, and switching back reuses the old ones.
  GeometricSlamProblem switched = scene.problem;
  ClassPrior wider = switched.classes[switched.object_class.at(2)];
  wider.name = "wider";
  wider.slice_model.silhouette.enabled = true;
  wider.slice_model.silhouette.depth_half_extent = 0.7;
  wider.slice_model.silhouette.width_half_extent = 0.8;
  switched.classes.push_back(wider);
  switched.object_class[2] = static_cast<int>(switched.classes.size()) - 1;
  GeometricSlamProblem unswitched = scene.problem;
  unswitched.classes = switched.classes;  // the same class list, object 2 as before
  GeometricSlam reusing_switch(camera, options);
  ExpectSameBits(reusing_switch.Solve(unswitched, &state), fresh.Solve(unswitched, &state));
  const GeometricSlamResult wider_view = reusing_switch.Solve(switched, &state);
  ExpectSameBits(wider_view, fresh.Solve(switched, &state));
  EXPECT_GT(wider_view.summary.computed_linearizations, prior_factors);
  const GeometricSlamResult back = reusing_switch.Solve(unswitched, &state);
  ExpectSameBits(back, fresh.Solve(unswitched, &state));
  EXPECT_EQ(back.summary.computed_linearizations, prior_factors);

  // Detection 0 measured differently under the same id: nothing stale.
  GeometricSlamProblem remeasured = split;
  remeasured.observations[0].slice.u_r_px += 1.0;
  const GeometricSlamResult changed = reusing.Solve(remeasured, &split_start);
  ExpectSameBits(changed, fresh.Solve(remeasured, &split_start));
  EXPECT_EQ(changed.summary.reused_linearizations, 0);
  // One id for two measurements in one problem: no reuse at all.
  GeometricSlamProblem clash = remeasured;
  clash.observations[1].detection_id = clash.observations[0].detection_id;
  reusing.Solve(clash, &split_start);
  const GeometricSlamResult clashed = reusing.Solve(clash, &split_start);
  ExpectSameBits(clashed, fresh.Solve(clash, &split_start));
  EXPECT_EQ(clashed.summary.reused_linearizations, 0);
}

// A loop of 1,800 poses with 60 objects, some seen only from far off: from
// odometry, Gauss-Newton crawls along those objects' viewing rays (gain
// ratio ~1.5-1.9); the line search beyond such steps reaches the same
// minimum (no higher) in fewer iterations.
TEST(GeometricSlamTest, StepExtrapolationReachesTheSameMinimumInFewerIterations) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const testing::SyntheticScene scene =
      testing::MakeSyntheticScene(camera, testing::GrownLpaLoop(6));
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  GeometricSlam plain(camera, options);
  const GeometricSlamResult without = plain.Solve(scene.problem);
  options.solver.max_step_extrapolation = 16.0;
  GeometricSlam stretching(camera, options);
  const GeometricSlamResult with = stretching.Solve(scene.problem);
  ASSERT_EQ(without.summary.termination, TerminationType::kConverged);
  ASSERT_EQ(with.summary.termination, TerminationType::kConverged);
  EXPECT_EQ(without.summary.step_extrapolations, 0);
  EXPECT_GT(with.summary.step_extrapolations, 0);
  EXPECT_LT(with.summary.iterations, without.summary.iterations);
  EXPECT_LE(with.summary.final_cost, without.summary.final_cost * (1.0 + 1e-9));
  EXPECT_NEAR(with.evidence.log_evidence, without.evidence.log_evidence, 1e-2);
  // The plain solve stops in the flat valley short of the minimum (its
  // function tolerance): the two differ by ~2 cm, odometry by metres.
  EXPECT_LT(TrajectoryRmse(with.trajectory, without.trajectory), 0.05);

  SolverOptions bad;
  std::string why;
  bad.max_step_extrapolation = -1.0;
  EXPECT_FALSE(bad.Validate(&why));
  EXPECT_NE(why.find("max_step_extrapolation"), std::string::npos);
  bad.max_step_extrapolation = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(bad.Validate(&why));
}

// O-SLAM's chains solve on two threads at once. The results must be those
// of one thread, bit for bit: the single-threaded OpenBLAS build broke this
// (supernodal factorisations of this size run on the BLAS), the threaded
// build that SparseSolver limits to one thread keeps it.
TEST(GeometricSlamTest, SolvesOnTwoThreadsAtOnceEqualOneThreadBitForBit) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  testing::SyntheticSceneOptions scene_options = testing::GrownLpaLoop(1);
  const testing::SyntheticScene scene = testing::MakeSyntheticScene(camera, scene_options);
  GeometricSlamOptions options;
  options.compute_object_covariances = true;
  const GeometricSlamResult alone = GeometricSlam(camera, options).Solve(scene.problem);
  ASSERT_TRUE(alone.evidence.valid);
  constexpr int kThreads = 2, kSolves = 4;
  std::vector<std::vector<GeometricSlamResult>> results(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      GeometricSlam slam(camera, options);
      for (int k = 0; k < kSolves; ++k) results[t].push_back(slam.Solve(scene.problem));
    });
  for (auto& thread : threads) thread.join();
  // From inside a user's OpenMP region too: there CHOLMOD's own regions must
  // go through libgomp (a nested team of one), not run as members of the
  // user's team (SparseSolver's GOMP_parallel interposition).
  std::vector<GeometricSlamResult> from_openmp(kThreads);
#pragma omp parallel for num_threads(kThreads)
  for (int t = 0; t < kThreads; ++t)
    from_openmp[t] = GeometricSlam(camera, options).Solve(scene.problem);
  results.push_back(from_openmp);
  for (const auto& list : results)
    for (const GeometricSlamResult& result : list) {
      ExpectSameBits(result, alone);
      ASSERT_EQ(result.objects.size(), alone.objects.size());
      for (size_t j = 0; j < alone.objects.size(); ++j)
        EXPECT_EQ(result.objects[j].covariance, alone.objects[j].covariance);
    }
}

// A door on a wall, seen from one side only as the robot drives past it
// (docs/method.md §4.2, "Panels"): exact odometry and detections from the
// panel model at its true orientation.
struct DoorPass {
  HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  CylinderGeometry door{Eigen::Vector3d(0.4, 2.5, 0.0), 1.04, 2.17};
  std::vector<Pose2> poses;
  GeometricSlamProblem problem;

  explicit DoorPass(bool panel_model) {
    door.yaw_rad = 0.2;  // the wall a little askew to the path
    ClassPrior prior;
    prior.size_mean_m = {1.0, 2.2};
    prior.size_std_m = {0.3, 0.5};
    prior.location_std_m = {10.0, 10.0, 0.03};  // on the floor
    prior.slice_model.silhouette = SilhouetteOf(camera, ObjectShape::kPanel);
    prior.slice_model.censor_at_image_limits = true;
    const SilhouetteModel truth = prior.slice_model.silhouette;
    prior.slice_model.silhouette.panel = panel_model;
    problem.classes.push_back(prior);
    problem.object_class[0] = 0;
    problem.increments.resize(1);
    poses.push_back({-2.0, 0.0, 0.0});
    problem.first_pose = poses[0];
    for (int i = 1; i < 40; ++i) {
      const OdometryIncrement step{0.1, 0.05 * std::sin(0.5 * i)};
      problem.increments.push_back(step);
      poses.push_back(ApplyIncrement(poses.back(), step));
    }
    for (size_t i = 0; i < poses.size(); ++i) {
      BoundingSlice slice;
      bool beyond = false;
      if (!PredictSlice(camera, poses[i], door, &slice, nullptr, truth, &beyond)) continue;
      // A top beyond the rim is measured at the rim (a censored end).
      if (beyond) slice.s_r_px = camera.annulus().rim_radius_px - slice.u_r_px;
      problem.observations.push_back({static_cast<long>(i), 0, slice});
    }
  }
};

TEST(GeometricSlamTest, PanelWidthAndYawFromOneSidedViews) {
  GeometricSlamOptions options;
  options.pixel_std_px = 0.1;  // exact detections: the priors must not pull
  const DoorPass pass(/*panel_model=*/true);
  ASSERT_GT(pass.problem.observations.size(), 30u);
  const GeometricSlamResult result = GeometricSlam(pass.camera, options).Solve(pass.problem);
  ASSERT_TRUE(result.summary.IsUsable()) << result.summary.message;
  ASSERT_EQ(result.objects.size(), 1u);
  const CylinderGeometry& door = result.objects[0].geometry;
  EXPECT_NEAR(door.diameter_m, pass.door.diameter_m, 0.01);
  EXPECT_LT((door.base_world - pass.door.base_world).norm(), 0.01);
  // The yaw modulo pi.
  EXPECT_NEAR(0.5 * WrapAngle(2 * (door.yaw_rad - pass.door.yaw_rad)), 0.0, 0.01);

  // The mean extent over the half space (1/pi) reads the same views as a
  // door a quarter too wide: the bias the orientation removes.
  const DoorPass mean_model(/*panel_model=*/false);
  const GeometricSlamResult biased = GeometricSlam(pass.camera, options).Solve(mean_model.problem);
  ASSERT_EQ(biased.objects.size(), 1u);
  EXPECT_GT(biased.objects[0].geometry.diameter_m - pass.door.diameter_m, 0.15);
}

// The per-object Laplace evidence (6 parameters for a panel, its flat yaw
// prior included) equals the solver's on a graph with the poses held.
TEST(GeometricSlamTest, PanelEvidenceWithPosesHeldEqualsTheSolvers) {
  const DoorPass pass(/*panel_model=*/true);
  const ClassPrior& prior = pass.problem.classes[0];
  std::vector<const SliceObservation*> list;
  for (const SliceObservation& observation : pass.problem.observations)
    list.push_back(&observation);
  CylinderGeometry object = pass.door;
  object.base_world += Eigen::Vector3d(0.1, -0.1, 0.0);
  object.yaw_rad += 0.1;
  double log_evidence = 0;
  ASSERT_TRUE(ObjectLogEvidenceWithPosesHeld(pass.camera, pass.poses, list, prior, 30.0, &object,
                                             &log_evidence));

  FactorGraph graph;
  std::vector<int> pose_keys;
  for (const Pose2& pose : pass.poses)
    pose_keys.push_back(graph.AddPose(pose.x, pose.y, pose.theta, true));
  const int base = graph.AddVariable(pass.door.base_world);
  const int size = graph.AddVariable(Eigen::Vector2d(pass.door.diameter_m, pass.door.height_m));
  const int yaw = graph.AddVariable(Eigen::Matrix<double, 1, 1>(pass.door.yaw_rad), 0);
  graph.Add(MakeLocationPrior(base, prior.location_mean_m, prior.location_std_m));
  graph.Add(MakeSizePrior(size, prior.size_mean_m, prior.size_std_m));
  graph.Emplace<PanelYawPrior>(yaw);
  for (const SliceObservation* observation : list)
    graph.Emplace<BoundingSliceFactor>(&pass.camera, pose_keys[observation->frame], base, size,
                                       observation->slice, 30.0, prior.slice_model, yaw);
  SolverOptions tight;
  tight.absolute_function_tolerance = 0.0;
  tight.function_tolerance = 1e-12;
  SparseSolver solver(tight);
  const SolveResult solved = solver.Solve(&graph);
  ASSERT_TRUE(solved.evidence.valid);
  EXPECT_NEAR(log_evidence, solved.evidence.log_evidence, 1e-3);
  EXPECT_NEAR(0.5 * WrapAngle(2 * (object.yaw_rad - graph.values().Data(yaw)[0])), 0.0, 1e-3);
}

TEST(GeometricSlamTest, InvalidInputThrowsNamingTheProblem) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamProblem problem;
  GeometricSlam slam(camera, GeometricSlamOptions());
  EXPECT_THROW(slam.Solve(problem), Error);
  problem.increments.resize(3);
  problem.classes.push_back(ClassPrior());
  problem.object_class[1] = 0;
  problem.observations.push_back({5, 1, {100, 0, 10, 0.1}});
  try {
    slam.Solve(problem);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 5"), std::string::npos);
  }
  GeometricSlamOptions bad;
  bad.pixel_std_px = 0;
  std::string why;
  EXPECT_FALSE(bad.Validate(&why));
}

}  // namespace
}  // namespace oslam

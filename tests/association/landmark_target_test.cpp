// Landmark O-SLAM with unknown association on a small simulated drive: the
// tracks are pure, the local (poses held) evaluation ranks merge / no-merge
// proposals as the exact one does, and hill climbing from separate tracks
// recovers the true association; after a drifting excursion, the joint
// re-entry merge closes the loop the single merges leave open. Also the
// pairwise comparison and the option checks.
#include "association/landmark_target.h"

#include <cmath>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "core/angles.h"
#include "core/error.h"
#include "slam/landmark_factors.h"

namespace oslam {
namespace {

// Two laps (2 m steps) around a 36 m x 24 m block with 14 trees at least
// 5 m apart; trees seen within 14 m ahead of the sensor (|bearing| < 80 deg),
// so each lap sees each tree as a separate stretch of scans.
LandmarkDataset SimulateDrive(unsigned seed, std::vector<Pose2>* true_poses) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Eigen::Vector2d> trees;
  while (trees.size() < 14) {
    const Eigen::Vector2d t(-4 + 44 * uniform(rng), -4 + 32 * uniform(rng));
    if (t.x() > 2 && t.x() < 34 && t.y() > 2 && t.y() < 22) continue;  // inside the path
    bool far = true;
    for (const auto& o : trees) far = far && (o - t).norm() > 5.0;
    if (far) trees.push_back(t);
  }
  LandmarkDataset data;
  data.path = "simulated";
  data.format = "simulated";
  data.has_landmark_ids = true;
  std::vector<Pose2> poses{{0, 0, 0}};
  const int sides[4] = {18, 12, 18, 12};
  for (int lap = 0; lap < 2; ++lap)
    for (int side = 0; side < 4; ++side)
      for (int k = 0; k < sides[side]; ++k) {
        const double turn = k == sides[side] - 1 ? kPi / 2 : 0.0;
        poses.push_back(ComposePose(poses.back(), {2.0, 0.0, turn}));
      }
  data.num_poses = static_cast<int>(poses.size());
  for (int i = 0; i < data.num_poses; ++i) data.pose_ids.push_back(i);
  const Eigen::Vector3d odometry_std(0.03, 0.02, 0.01);
  data.dead_reckoning.push_back(poses.front());
  for (int i = 1; i < data.num_poses; ++i) {
    const Pose2& a = poses[i - 1];
    const Pose2& b = poses[i];
    const Eigen::Vector3d d = a.WorldToRobot(Eigen::Vector3d(b.x, b.y, 0));
    RelativePoseMeasurement edge;
    edge.from = i - 1;
    edge.to = i;
    edge.delta = {d.x() + odometry_std.x() * normal(rng), d.y() + odometry_std.y() * normal(rng),
                  WrapAngle(b.theta - a.theta + odometry_std.z() * normal(rng))};
    edge.covariance = odometry_std.cwiseAbs2().asDiagonal();
    data.odometry.push_back(edge);
    data.dead_reckoning.push_back(ComposePose(data.dead_reckoning.back(), edge.delta));
  }
  for (int i = 0; i < data.num_poses; ++i)
    for (size_t id = 0; id < trees.size(); ++id) {
      const Eigen::Vector2d d = trees[id] - Eigen::Vector2d(poses[i].x, poses[i].y);
      const double bearing = WrapAngle(std::atan2(d.y(), d.x()) - poses[i].theta);
      if (d.norm() > 14.0 || std::abs(bearing) > 1.4) continue;
      LandmarkSighting s;
      s.pose = i;
      s.landmark = static_cast<int>(id);
      s.range_std_m = 0.1;
      s.bearing_std_rad = 0.01;
      s.range_m = d.norm() + s.range_std_m * normal(rng);
      s.bearing_rad = WrapAngle(bearing + s.bearing_std_rad * normal(rng));
      data.sightings.push_back(s);
    }
  if (true_poses) *true_poses = poses;
  return data;
}

// A lap of a 40 m x 30 m block A (trees around it), then a 420 m excursion
// through new trees (south 80 m, east 150 m, north 80 m, then west 150 m,
// entering A along its south side) and on around A (west and north sides). The odometry turns left
// `heading_bias_rad` per step more than the car did, far beyond its stated
// noise, so the car re-enters A tens of metres and degrees off: one re-seen
// tree cannot pay for bending the excursion, all of them together can.
LandmarkDataset SimulateExcursion(unsigned seed, double heading_bias_rad) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  // The path as (length in 2 m steps, turn at its end) legs from (0, 0) east.
  const std::vector<std::pair<int, double>> legs = {
      {20, kPi / 2},  {15, kPi / 2},  {20, kPi / 2}, {15, kPi / 2},  // lap of A
      {0, -kPi / 2},  {40, kPi / 2},  {75, kPi / 2}, {40, kPi / 2},  // excursion
      {75, -kPi / 2}, {15, -kPi / 2}, {20, 0.0}};                    // back around A
  std::vector<Pose2> poses{{0, 0, 0}};
  for (const auto& [steps, turn] : legs) {
    for (int k = 0; k < steps; ++k) poses.push_back(ComposePose(poses.back(), {2.0, 0.0, 0.0}));
    if (turn != 0) {
      Pose2& last = poses.back();
      last.theta = WrapAngle(last.theta + turn);
    }
  }
  // Trees 4-7 m beside the path, at least 6 m apart.
  std::vector<Eigen::Vector2d> trees;
  for (int attempt = 0; attempt < 20000 && trees.size() < 70; ++attempt) {
    const Pose2& p = poses[std::uniform_int_distribution<size_t>(0, poses.size() - 1)(rng)];
    const double side = uniform(rng) < 0.5 ? -1 : 1, offset = side * (4 + 3 * uniform(rng));
    const Eigen::Vector2d t(p.x - offset * std::sin(p.theta), p.y + offset * std::cos(p.theta));
    bool clear = true;
    for (const auto& o : trees) clear = clear && (o - t).norm() > 6.0;
    for (const auto& q : poses) clear = clear && (Eigen::Vector2d(q.x, q.y) - t).norm() > 3.0;
    if (clear) trees.push_back(t);
  }
  LandmarkDataset data;
  data.path = "simulated";
  data.format = "simulated";
  data.has_landmark_ids = true;
  data.num_poses = static_cast<int>(poses.size());
  for (int i = 0; i < data.num_poses; ++i) data.pose_ids.push_back(i);
  const Eigen::Vector3d odometry_std(0.02, 0.01, 0.002);
  data.dead_reckoning.push_back(poses.front());
  for (int i = 1; i < data.num_poses; ++i) {
    const Pose2& a = poses[i - 1];
    const Pose2& b = poses[i];
    const Eigen::Vector3d d = a.WorldToRobot(Eigen::Vector3d(b.x, b.y, 0));
    RelativePoseMeasurement edge;
    edge.from = i - 1;
    edge.to = i;
    edge.delta = {d.x() + odometry_std.x() * normal(rng), d.y() + odometry_std.y() * normal(rng),
                  WrapAngle(b.theta - a.theta + heading_bias_rad + odometry_std.z() * normal(rng))};
    edge.covariance = odometry_std.cwiseAbs2().asDiagonal();
    data.odometry.push_back(edge);
    data.dead_reckoning.push_back(ComposePose(data.dead_reckoning.back(), edge.delta));
  }
  for (int i = 0; i < data.num_poses; ++i)
    for (size_t id = 0; id < trees.size(); ++id) {
      const Eigen::Vector2d d = trees[id] - Eigen::Vector2d(poses[i].x, poses[i].y);
      const double bearing = WrapAngle(std::atan2(d.y(), d.x()) - poses[i].theta);
      if (d.norm() > 14.0 || std::abs(bearing) > 1.4) continue;
      LandmarkSighting s;
      s.pose = i;
      s.landmark = static_cast<int>(id);
      s.range_std_m = 0.1;
      s.bearing_std_rad = 0.01;
      s.range_m = d.norm() + s.range_std_m * normal(rng);
      s.bearing_rad = WrapAngle(bearing + s.bearing_std_rad * normal(rng));
      data.sightings.push_back(s);
    }
  return data;
}

LandmarkTargetOptions TargetOptions(LandmarkEvaluationMode mode) {
  LandmarkTargetOptions options;
  options.mode = mode;
  options.slam.landmark_prior_std_m = 50.0;
  options.slam.landmark_prior_mean_m = Eigen::Vector2d(18, 12);
  options.proposal_iterations = 50;  // "exact": converged re-solves
  return options;
}

AssociationState Separate(size_t num_tracks) {
  AssociationState state;
  for (size_t t = 0; t < num_tracks; ++t) {
    state.blocks.push_back({static_cast<int>(t)});
    state.classes.push_back(0);
  }
  return state;
}

AssociationState Merged(const AssociationState& state, int a, int b) {
  AssociationState merged = state;
  const int ja = merged.BlockOf(a), jb = merged.BlockOf(b);
  merged.blocks[ja].insert(merged.blocks[ja].end(), merged.blocks[jb].begin(),
                           merged.blocks[jb].end());
  std::sort(merged.blocks[ja].begin(), merged.blocks[ja].end());
  merged.blocks.erase(merged.blocks.begin() + jb);
  merged.classes.pop_back();
  merged.Canonicalize();
  return merged;
}

TEST(LandmarkTargetTest, TracksArePureAndSplitByLap) {
  const LandmarkDataset data = SimulateDrive(3, nullptr);
  const auto tracks = BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2});
  std::set<int> trees;
  size_t sightings = 0;
  for (const auto& track : tracks) {
    for (int k : track) EXPECT_EQ(data.sightings[k].landmark, data.sightings[track[0]].landmark);
    trees.insert(data.sightings[track[0]].landmark);
    sightings += track.size();
  }
  EXPECT_EQ(sightings, data.sightings.size());
  EXPECT_EQ(trees.size(), 14u);
  EXPECT_GE(tracks.size(), 2 * trees.size());  // each lap at least one track per tree
  EXPECT_LT(tracks.size(), data.sightings.size() / 3);
  EXPECT_THROW(BuildLandmarkTracks(data, {}, {1.0, 2}), Error);
  EXPECT_THROW(BuildLandmarkTracks(data, data.dead_reckoning, {0.0, 2}), Error);
}

// From the all-separate state, every merge of two tracks of one tree and of
// nearby different trees: the marginal (closed-form) evaluation's decision
// (better or worse than separate) agrees with the exact one's.
TEST(LandmarkTargetTest, LocalEvaluationRanksMergesLikeExact) {
  const LandmarkDataset data = SimulateDrive(4, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  LandmarkEvaluator exact(target, TargetOptions(LandmarkEvaluationMode::kExact));
  LandmarkEvaluator local(target, TargetOptions(LandmarkEvaluationMode::kLocal));
  LandmarkEvaluator marginal(target, TargetOptions(LandmarkEvaluationMode::kMarginal));
  const AssociationState separate = Separate(target.tracks.size());
  const EvaluationPtr exact_start = exact.Refine(separate, nullptr);
  const EvaluationPtr local_start = local.Refine(separate, nullptr);
  const EvaluationPtr marginal_start = marginal.Refine(separate, nullptr);
  ASSERT_TRUE(exact_start->valid && local_start->valid);
  EXPECT_DOUBLE_EQ(exact_start->log_target, local_start->log_target);
  int compared = 0, agree = 0, agree_marginal = 0, true_merges = 0, false_merges = 0, excluded = 0;
  for (size_t a = 0; a < target.tracks.size(); ++a)
    for (size_t b = a + 1; b < target.tracks.size(); ++b) {
      const double distance = (local_start->locations[a] - local_start->locations[b]).norm();
      if (distance > 8.0) continue;  // as the merge proposal: only nearby candidates
      const AssociationState merged = Merged(separate, int(a), int(b));
      const EvaluationPtr e = exact.Evaluate(merged, exact_start.get());
      const EvaluationPtr l = local.Evaluate(merged, local_start.get());
      const EvaluationPtr g = marginal.Evaluate(merged, marginal_start.get());
      const bool same = data.sightings[target.tracks[a][0]].landmark ==
                        data.sightings[target.tracks[b][0]].landmark;
      if (!e->valid) {  // two trees seen from one pose: one sighting per scan forbids it
        EXPECT_FALSE(same);
        EXPECT_FALSE(g->valid || l->valid);
        ++excluded;
        continue;
      }
      ASSERT_TRUE(g->valid);
      agree_marginal +=
          (g->log_target > marginal_start->log_target) == (e->log_target > exact_start->log_target);
      ASSERT_TRUE(l->valid);
      const bool exact_merges = e->log_target > exact_start->log_target;
      const bool local_merges = l->log_target > local_start->log_target;
      ++compared;
      agree += exact_merges == local_merges;
      // Held poses cannot bend the second lap onto the first: the local
      // evaluation rejects loop-closing merges, but never accepts a false one.
      if (!same) {
        EXPECT_FALSE(local_merges) << "tracks " << a << ", " << b;
      }
      if (same)
        ++true_merges;
      else
        ++false_merges;
      EXPECT_EQ(exact_merges, same) << "tracks " << a << ", " << b;
    }
  std::printf(
      "%d merge proposals (%d true, %d false; %d more excluded by one sighting per scan): agree "
      "with exact: marginal %d, local %d\n",
      compared, true_merges, false_merges, excluded, agree_marginal, agree);
  EXPECT_GE(true_merges, 10);
  EXPECT_GE(false_merges, 10);
  EXPECT_EQ(agree_marginal, compared);
}

TEST(LandmarkTargetTest, HillClimbingRecoversTheTrueAssociation) {
  std::vector<Pose2> truth;
  const LandmarkDataset data = SimulateDrive(5, &truth);
  LandmarkSlamOptions known_options = TargetOptions(LandmarkEvaluationMode::kExact).slam;
  const LandmarkSlamResult known = LandmarkSlam(known_options).Solve(data, GivenAssociation(data));
  for (const auto mode : {LandmarkEvaluationMode::kMarginal, LandmarkEvaluationMode::kExact}) {
    UnknownAssociationOptions options;
    options.tracks = {1.0, 2};
    options.target = TargetOptions(mode);
    options.target.proposal_iterations = 5;
    options.moves.merge_distance_m = 5.0;
    options.moves.merge_sigma_m = 2.5;
    options.window_poses = 0;
    options.targeted_radius_m = 0;  // random moves only
    options.hill_climb_steps_per_track = 15;
    options.seed = 7;
    const UnknownAssociationResult result = SolveUnknownAssociation(data, options);
    const PairwiseAgreement a = ComparePairwise(result.association, GivenAssociation(data));
    std::printf(
        "mode %d: %zu tracks -> %zu landmarks, agreement %.4f, P %.3f R %.3f, %ld "
        "proposals, %.3f s\n",
        static_cast<int>(mode), result.tracks.size(), result.solution.landmarks.size(), a.agreement,
        a.precision, a.recall, result.proposals, result.total_time_s);
    EXPECT_EQ(result.solution.landmarks.size(), 14u);
    EXPECT_DOUBLE_EQ(a.agreement, 1.0);
    EXPECT_LT(TrajectoryRmse(result.solution.trajectory, truth), 1.0);
    EXPECT_LT(TrajectoryRmse(result.solution.trajectory, known.trajectory), 0.05);
  }
}

TEST(LandmarkTargetTest, WindowsAndSamplingKeepTheTrueAssociation) {
  const LandmarkDataset data = SimulateDrive(6, nullptr);
  UnknownAssociationOptions options;
  options.tracks = {1.0, 2};
  options.target = TargetOptions(LandmarkEvaluationMode::kMarginal);
  options.moves.merge_distance_m = 5.0;
  options.moves.merge_sigma_m = 2.5;
  options.window_poses = 40;
  options.free_poses = 60;
  options.hill_climb_steps_per_track = 15;
  options.final_hill_climb_steps = 50;
  options.samples = 40;
  options.burn_in = 10;
  options.seed = 3;
  int lines = 0;
  const UnknownAssociationResult result =
      SolveUnknownAssociation(data, options, [&](const std::string&) { ++lines; });
  EXPECT_GT(lines, 3);  // tracks, windows, passes
  const PairwiseAgreement a = ComparePairwise(result.association, GivenAssociation(data));
  EXPECT_DOUBLE_EQ(a.agreement, 1.0);
  EXPECT_GT(result.sampler.swaps_proposed, 0);
}

// The re-entry into A after the drifting excursion: the single targeted
// merges leave it open, the joint merge (RANSAC alignment, correction spread
// along the excursion, kept on the full evidence) closes it.
TEST(LandmarkTargetTest, JointMergeClosesALoopNoSingleMergeCloses) {
  const LandmarkDataset data = SimulateExcursion(11, 0.0015);
  const std::vector<int> truth = GivenAssociation(data);
  UnknownAssociationOptions options;
  options.seed = 5;
  options.joint_recent_poses = 80;  // 160 m (Victoria Park's 300 poses are about 170 m)
  options.joint_every_poses = 20;
  UnknownAssociationOptions single = options;
  single.joint_min_inliers = 0;
  const UnknownAssociationResult without = SolveUnknownAssociation(data, single);
  const UnknownAssociationResult with = SolveUnknownAssociation(data, options);
  const PairwiseAgreement a = ComparePairwise(without.association, truth);
  const PairwiseAgreement b = ComparePairwise(with.association, truth);
  const LandmarkSlamResult known =
      LandmarkSlam(options.target.slam).Solve(data, GivenAssociation(data));
  std::printf(
      "single merges only: P %.3f R %.3f, %zu landmarks, RMSE %.2f m, log target %.1f; joint: "
      "P %.3f R %.3f, %zu landmarks, RMSE %.2f m, log target %.1f (%ld tries, %ld pairs); "
      "true association %.1f\n",
      a.precision, a.recall, without.solution.landmarks.size(),
      TrajectoryRmse(without.solution.trajectory, known.trajectory), without.log_target,
      b.precision, b.recall, with.solution.landmarks.size(),
      TrajectoryRmse(with.solution.trajectory, known.trajectory), with.log_target, with.joint_tries,
      with.joint_merges, known.evidence.log_evidence);
  // Measured: single merges P 0.97-0.99, R 0.60-0.67, 10-17 m off; joint:
  // the true association, 0.01-0.02 m off (8 simulated drives).
  EXPECT_LT(a.recall, 0.8);
  EXPECT_GT(TrajectoryRmse(without.solution.trajectory, known.trajectory), 5.0);
  EXPECT_GT(with.joint_merges, 0);
  EXPECT_DOUBLE_EQ(b.agreement, 1.0);
  EXPECT_EQ(with.solution.landmarks.size(), std::set<int>(truth.begin(), truth.end()).size());
  EXPECT_LT(TrajectoryRmse(with.solution.trajectory, known.trajectory), 0.1);
  EXPECT_GT(with.log_target, without.log_target);
}

// With trunk diameters measured, the closed-form merge score carries their
// part of the evidence: it matches the converged re-solve on every nearby
// pair (true merges within a fraction of a nat), as without diameters.
TEST(LandmarkTargetTest, MarginalMergeScoresDiametersLikeExact) {
  LandmarkDataset data = SimulateDrive(4, nullptr);
  std::mt19937 rng(2);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (LandmarkSighting& s : data.sightings)
    s.diameter_m = 0.2 + 0.04 * (s.landmark % 7) + 0.05 * normal(rng);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  LandmarkEvaluator exact(target, TargetOptions(LandmarkEvaluationMode::kExact));
  LandmarkEvaluator marginal(target, TargetOptions(LandmarkEvaluationMode::kMarginal));
  const AssociationState separate = Separate(target.tracks.size());
  const EvaluationPtr exact_start = exact.Refine(separate, nullptr);
  const EvaluationPtr marginal_start = marginal.Refine(separate, nullptr);
  ASSERT_TRUE(exact_start->valid && marginal_start->valid);
  int compared = 0, agree = 0, true_merges = 0;
  double worst_true = 0;
  for (size_t a = 0; a < target.tracks.size(); ++a)
    for (size_t b = a + 1; b < target.tracks.size(); ++b) {
      if ((marginal_start->locations[a] - marginal_start->locations[b]).norm() > 8.0) continue;
      const AssociationState merged = Merged(separate, int(a), int(b));
      const EvaluationPtr e = exact.Evaluate(merged, exact_start.get());
      const EvaluationPtr g = marginal.Evaluate(merged, marginal_start.get());
      if (!e->valid) continue;  // one sighting per scan
      ASSERT_TRUE(g->valid);
      const double de = e->log_target - exact_start->log_target;
      const double dg = g->log_target - marginal_start->log_target;
      ++compared;
      agree += (de > 0) == (dg > 0);
      if (data.sightings[target.tracks[a][0]].landmark ==
          data.sightings[target.tracks[b][0]].landmark) {
        ++true_merges;
        worst_true = std::max(worst_true, std::abs(de - dg));
      }
    }
  std::printf("%d merge proposals (%d true): marginal agrees on %d; worst true-merge gap %.3f\n",
              compared, true_merges, agree, worst_true);
  EXPECT_GE(true_merges, 10);
  EXPECT_EQ(agree, compared);
  EXPECT_LT(worst_true, 0.5);
}

// Two trees 0.9 m apart seen with a loose sighting noise (as GTSAM's file
// states it), in turns during the first window and both in every scan of the
// second: merged in the first window, their tracks go on into scans that see
// both, and the merged landmark must not keep two sightings of one scan.
TEST(LandmarkTargetTest, NoLandmarkKeepsTwoSightingsOfOneScan) {
  LandmarkDataset data;
  data.path = "simulated";
  data.format = "simulated";
  data.has_landmark_ids = true;
  data.num_poses = 40;
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int i = 0; i < data.num_poses; ++i) {
    data.pose_ids.push_back(i);
    data.dead_reckoning.push_back({0.5 * i, 0.0, 0.0});
    if (i == 0) continue;
    RelativePoseMeasurement edge;
    edge.from = i - 1;
    edge.to = i;
    edge.delta = {0.5, 0.0, 0.0};
    edge.covariance = Eigen::Vector3d(1e-4, 1e-4, 4e-6).asDiagonal();
    data.odometry.push_back(edge);
  }
  const Eigen::Vector2d trees[2] = {{10.0, 5.0}, {10.9, 5.0}};
  for (int i = 0; i < data.num_poses; ++i)
    for (int id = 0; id < 2; ++id) {
      if (i < 20 && i % 2 != id) continue;  // first window: in turns
      const Pose2& p = data.dead_reckoning[i];
      const Eigen::Vector2d d = trees[id] - Eigen::Vector2d(p.x, p.y);
      LandmarkSighting s;
      s.pose = i;
      s.landmark = id;
      s.range_std_m = 0.6;  // stated loosely; the true noise is small
      s.bearing_std_rad = 0.2;
      s.range_m = d.norm() + 0.01 * normal(rng);
      s.bearing_rad = WrapAngle(std::atan2(d.y(), d.x()) + 0.001 * normal(rng));
      data.sightings.push_back(s);
    }
  UnknownAssociationOptions options;
  options.tracks = {0.5, 2};
  options.window_poses = 20;
  options.joint_min_inliers = 0;
  const UnknownAssociationResult result = SolveUnknownAssociation(data, options);
  ASSERT_EQ(result.tracks.size(), 2u);  // one per tree
  std::set<std::pair<int, int>> seen;   // (landmark, pose)
  for (size_t k = 0; k < data.sightings.size(); ++k) {
    ASSERT_GE(result.association[k], 0);
    EXPECT_TRUE(seen.insert({result.association[k], data.sightings[k].pose}).second)
        << "landmark " << result.association[k] << " seen twice in scan " << data.sightings[k].pose;
  }
  EXPECT_EQ(result.solution.landmarks.size(), 2u);
  EXPECT_EQ(result.scan_splits, 1);  // merged in the first window, split in the second
}

// Tracks shorter than min_track_sightings are clutter: out of the state, -1.
TEST(LandmarkTargetTest, ShortTracksAreLeftToClutter) {
  LandmarkDataset data = SimulateDrive(5, nullptr);
  const size_t real = data.sightings.size();
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int i = 0; i < data.num_poses; i += 3) {  // a false detection every third scan
    LandmarkSighting s;
    s.pose = i;
    s.range_std_m = 0.1;
    s.bearing_std_rad = 0.01;
    s.range_m = 2 + 10 * uniform(rng);
    s.bearing_rad = -1.4 + 2.8 * uniform(rng);
    data.sightings.push_back(s);
  }
  std::stable_sort(
      data.sightings.begin(), data.sightings.end(),
      [](const LandmarkSighting& a, const LandmarkSighting& b) { return a.pose < b.pose; });
  UnknownAssociationOptions options;
  options.tracks = {1.0, 2};
  options.target = TargetOptions(LandmarkEvaluationMode::kMarginal);
  options.moves.merge_distance_m = 5.0;  // as HillClimbingRecoversTheTrueAssociation
  options.moves.merge_sigma_m = 2.5;
  options.window_poses = 0;
  options.targeted_radius_m = 0;
  options.hill_climb_steps_per_track = 15;
  options.min_track_sightings = 2;
  options.seed = 7;
  const UnknownAssociationResult result = SolveUnknownAssociation(data, options);
  long clutter = 0, real_left_out = 0;
  std::vector<int> kept, kept_truth;  // the sightings given to landmarks
  for (size_t k = 0; k < data.sightings.size(); ++k) {
    if (result.association[k] >= 0) {
      kept.push_back(result.association[k]);
      kept_truth.push_back(data.sightings[k].landmark);
      continue;
    }
    ++clutter;
    real_left_out += data.sightings[k].landmark >= 0;
  }
  EXPECT_EQ(clutter, result.clutter_sightings);
  EXPECT_GE(result.clutter_sightings, long(data.sightings.size() - real));
  EXPECT_LE(real_left_out, 8);  // trees at the edge of view, seen once
  const PairwiseAgreement a = ComparePairwise(kept, kept_truth);
  std::printf("%ld sightings left to clutter (%ld of trees), kept: P %.4f R %.4f\n", clutter,
              real_left_out, a.precision, a.recall);
  EXPECT_DOUBLE_EQ(a.recall, 1.0);
  EXPECT_DOUBLE_EQ(a.precision, 1.0);
}

TEST(LandmarkTargetTest, PairwiseAgreementCountsPairs) {
  // truth {0,1,2} {3}; estimate {0,1} {2,3}: pairs (6): same in truth 3,
  // same in estimate 2, same in both 1 ((0,1)); disagreements (0,2) (1,2) (2,3).
  const PairwiseAgreement a = ComparePairwise({5, 5, 7, 7}, {1, 1, 1, 2});
  EXPECT_EQ(a.pairs, 6);
  EXPECT_EQ(a.same_truth, 3);
  EXPECT_EQ(a.same_estimate, 2);
  EXPECT_EQ(a.same_both, 1);
  EXPECT_DOUBLE_EQ(a.agreement, 0.5);
  EXPECT_DOUBLE_EQ(a.precision, 0.5);
  EXPECT_DOUBLE_EQ(a.recall, 1.0 / 3.0);
  // -1 is a landmark of its own, never "same" as another -1.
  const PairwiseAgreement b = ComparePairwise({-1, -1, 3}, {-1, -1, 4});
  EXPECT_EQ(b.same_estimate, 0);
  EXPECT_DOUBLE_EQ(b.agreement, 1.0);
  EXPECT_THROW(ComparePairwise({1}, {1, 2}), Error);
}

TEST(LandmarkTargetTest, RejectsAFlatLandmarkPrior) {
  const LandmarkDataset data = SimulateDrive(3, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  LandmarkTargetOptions options = TargetOptions(LandmarkEvaluationMode::kLocal);
  options.slam.landmark_prior_std_m = 0;
  EXPECT_THROW(LandmarkEvaluator(target, options), Error);
  UnknownAssociationOptions bad;
  bad.samples = 5;
  bad.burn_in = 5;
  std::string why;
  EXPECT_FALSE(bad.Validate(&why));
  UnknownAssociationOptions joint;
  joint.joint_min_inliers = 2;  // any two landmarks align: no evidence of a re-entry
  EXPECT_FALSE(joint.Validate(&why));
  joint.joint_min_inliers = 0;  // off: the other joint options are not used
  joint.joint_inlier_m = 0;
  EXPECT_TRUE(joint.Validate(&why));
}

}  // namespace
}  // namespace oslam

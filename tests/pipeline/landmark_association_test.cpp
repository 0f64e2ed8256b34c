// The landmark association pipeline on simulated drives: hill climbing
// from separate tracks recovers the true association, in one window or
// growing ones, with MC³ after it; after a drifting excursion the joint
// re-entry merge closes the loop the single merges leave open, also when its
// alignment pairs some trees wrongly, and in a city grid that repeats itself
// by the alignment weighted by fit; no landmark
// keeps two sightings of one scan; a false return riding a track is split
// off it; short tracks are left to clutter; a run
// is reproducible from its seed; the option checks.
#include "pipeline/landmark_association.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "association/association_metrics.h"
#include "core/angles.h"
#include "core/error.h"
#include "slam/landmark_simulation.h"
#include "tests/association/landmark_drives.h"

namespace oslam {
namespace {

using testing::DriveTargetOptions;
using testing::SimulateDrive;
using testing::SimulateExcursion;

TEST(LandmarkAssociationTest, HillClimbingRecoversTheTrueAssociation) {
  std::vector<Pose2> truth;
  const LandmarkDataset data = SimulateDrive(5, &truth);
  LandmarkSlamOptions known_options = DriveTargetOptions(LandmarkEvaluationMode::kExact).slam;
  const LandmarkSlamResult known = LandmarkSlam(known_options).Solve(data, GivenAssociation(data));
  for (const auto mode : {LandmarkEvaluationMode::kMarginal, LandmarkEvaluationMode::kExact}) {
    UnknownAssociationOptions options;
    options.tracks = {1.0, 2};
    options.target = DriveTargetOptions(mode);
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
    // The association re-solved under the model the result reports (its
    // noise, its location prior) is the result: what comparisons with
    // another association rely on.
    const LandmarkSlamResult again =
        LandmarkSlam(result.slam_options)
            .Solve(WithNoiseScales(data, result.noise_scales), result.association);
    EXPECT_LT(TrajectoryRmse(again.trajectory, result.solution.trajectory), 1e-4);
    EXPECT_NEAR(again.evidence.log_evidence, result.log_target, 1e-3);
  }
}

TEST(LandmarkAssociationTest, WindowsAndSamplingKeepTheTrueAssociation) {
  const LandmarkDataset data = SimulateDrive(6, nullptr);
  UnknownAssociationOptions options;
  options.tracks = {1.0, 2};
  options.target = DriveTargetOptions(LandmarkEvaluationMode::kMarginal);
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

// Joint merges on the excursion drives (2 m steps): stretches of 80 poses,
// RANSAC every 20.
UnknownAssociationOptions ExcursionOptions() {
  UnknownAssociationOptions options;
  options.seed = 5;
  options.joint_recent_m = 160;  // 80 poses (Victoria Park's 300 poses are about 170 m)
  options.joint_every_poses = 20;
  return options;
}

// The re-entry into A after the drifting excursion: the single targeted
// merges leave it open, the joint merge (RANSAC alignment, correction spread
// along the excursion, kept on the full evidence) closes it.
TEST(LandmarkAssociationTest, JointMergeClosesALoopNoSingleMergeCloses) {
  const LandmarkDataset data = SimulateExcursion(12, 0.0015);
  const std::vector<int> truth = GivenAssociation(data);
  const UnknownAssociationOptions options = ExcursionOptions();
  UnknownAssociationOptions single = options;
  single.joint_min_inliers = 0;
  const UnknownAssociationResult without = SolveUnknownAssociation(data, single);
  const UnknownAssociationResult with = SolveUnknownAssociation(data, options);
  const PairwiseAgreement a = ComparePairwise(without.association, truth);
  const PairwiseAgreement b = ComparePairwise(with.association, truth);
  // The true association under the noise the search calibrated.
  const LandmarkSlamResult known =
      LandmarkSlam(with.slam_options).Solve(WithNoiseScales(data, with.noise_scales), truth);
  std::printf(
      "single merges only: P %.3f R %.3f, %zu landmarks, RMSE %.2f m, log target %.1f; joint: "
      "P %.3f R %.3f, %zu landmarks, RMSE %.2f m, log target %.1f (%ld tries, %ld pairs); "
      "true association %.1f\n",
      a.precision, a.recall, without.solution.landmarks.size(),
      TrajectoryRmse(without.solution.trajectory, known.trajectory), without.log_target,
      b.precision, b.recall, with.solution.landmarks.size(),
      TrajectoryRmse(with.solution.trajectory, known.trajectory), with.log_target, with.joint_tries,
      with.joint_merges, known.evidence.log_evidence);
  // Measured on 12 simulated drives: single merges R 0.60-0.68 on 11 (the
  // batch repair of the targeted merges closes the 12th, seed 11); joint:
  // the true association on all 12.
  EXPECT_LT(a.recall, 0.8);
  EXPECT_GT(TrajectoryRmse(without.solution.trajectory, known.trajectory), 5.0);
  EXPECT_GT(with.joint_merges, 0);
  EXPECT_DOUBLE_EQ(b.agreement, 1.0);
  EXPECT_EQ(with.solution.landmarks.size(), std::set<int>(truth.begin(), truth.end()).size());
  EXPECT_LT(TrajectoryRmse(with.solution.trajectory, known.trajectory), 0.1);
  EXPECT_GT(with.log_target, without.log_target);
}

// Every loop-closing batch of targeted merges on probation (any gain, any
// shift): its windows are run again without it and the better path goes on.
// Each decision follows the targets it reports, the run ends at the true
// association, and it is reproducible.
TEST(LandmarkAssociationTest, WeakLoopClosuresAreDecidedByRunningTheirWindowsAgain) {
  const LandmarkDataset data = SimulateExcursion(12, 0.0015);
  UnknownAssociationOptions options = ExcursionOptions();
  options.probation_windows = 2;
  options.probation_max_gain = 1e9;
  options.probation_shift_spacing = 0;
  std::vector<std::string> lines;
  const UnknownAssociationResult result = SolveUnknownAssociation(
      data, options, [&](const std::string& line) { lines.push_back(line); });
  int decisions = 0, undone = 0, again = 0;
  for (const std::string& line : lines) {
    again += line.rfind("again: window", 0) == 0;
    double with = 0, without = 0;
    char verdict[16] = {};
    if (std::sscanf(line.c_str(),
                    "probation of %*d merges from window %*d: log target %lf with them, "
                    "%lf without -> %15s",
                    &with, &without, verdict) != 3)
      continue;
    ++decisions;
    const bool was_undone = std::string(verdict) == "undone";
    undone += was_undone;
    EXPECT_EQ(was_undone, without > with + 0.01) << line;
  }
  std::printf("%d probations (%d undone), %d windows run again, %zu landmarks\n", decisions, undone,
              again, result.solution.landmarks.size());
  EXPECT_EQ(decisions, result.probations);
  EXPECT_EQ(undone, result.probations_undone);
  EXPECT_GT(decisions, 0);
  EXPECT_GE(again, 3 * decisions);  // its own window and the two after it
  EXPECT_DOUBLE_EQ(ComparePairwise(result.association, GivenAssociation(data)).agreement, 1.0);
  const UnknownAssociationResult second = SolveUnknownAssociation(data, options);
  EXPECT_EQ(second.association, result.association);
  EXPECT_EQ(second.log_target, result.log_target);
}

// Trees 3-4 m apart and a stronger drift: the re-entry's alignment pairs a
// few trees wrongly, and those pairs alone sink the joint merge's evidence.
// Splitting the misfit pairs off again and re-solving keeps the loop closed.
TEST(LandmarkAssociationTest, JointMergeSplitsItsMisfitPairs) {
  // Measured on 8 drives x spacings 3 and 4 m x heading drift 0.003 and
  // 0.005: without the repair 3 of 32 left the loop open (recall
  // 0.65-0.66; which ones depends on where the recent stretch starts), all
  // at 4 m; with it all 32 are the truth. Three of them: every one repaired
  // is the truth, and at least one is not without.
  double worst_unrepaired_recall = 1;
  for (unsigned seed : {5u, 6u, 7u}) {
    const LandmarkDataset data = SimulateExcursion(seed, 0.005, 4.0);
    const std::vector<int> truth = GivenAssociation(data);
    const UnknownAssociationOptions options = ExcursionOptions();
    UnknownAssociationOptions unrepaired = options;
    unrepaired.joint_repair_rounds = 0;
    const UnknownAssociationResult without = SolveUnknownAssociation(data, unrepaired);
    const UnknownAssociationResult with = SolveUnknownAssociation(data, options);
    const PairwiseAgreement a = ComparePairwise(without.association, truth);
    const PairwiseAgreement b = ComparePairwise(with.association, truth);
    std::printf(
        "drive %u: unrepaired P %.4f R %.4f (%ld pairs kept), repaired P %.4f R %.4f "
        "(%ld pairs kept)\n",
        seed, a.precision, a.recall, without.joint_merges, b.precision, b.recall,
        with.joint_merges);
    worst_unrepaired_recall = std::min(worst_unrepaired_recall, a.recall);
    EXPECT_DOUBLE_EQ(b.agreement, 1.0) << "drive " << seed;
    EXPECT_GT(with.joint_merges, 0) << "drive " << seed;
    // (The same state reached by other solves may differ in the last digits.)
    EXPECT_GE(with.log_target, without.log_target - 1e-3) << "drive " << seed;
  }
  EXPECT_LT(worst_unrepaired_recall, 0.8);
}

// A city grid repeats itself every block. On this 1,500-pose drive the first
// re-entry's true alignment has 6 to 11 pairs, all within 0.2 m, while
// alignments shifted by a block collect 12 to 13 pairs at random distances
// within the inlier radius. The alignment weighted by fit closes the loop;
// on this drive so do the plain count, the drift-bounded windows and the
// screen.
TEST(LandmarkAssociationTest, ALoopInARepeatingGridClosesUnderEitherAlignmentRule) {
  LandmarkWorldOptions world_options;
  world_options.num_poses = 1500;
  world_options.blocks = 5;
  world_options.num_landmarks = 250;
  world_options.seed = 3;
  const LandmarkWorld world = SimulateLandmarkWorld(world_options);
  // Windows of 40 poses only, and no screen of the alignments below the
  // floors: the drift-bounded windows, and the screen, close this loop with
  // either alignment rule (below).
  UnknownAssociationOptions weighted;
  weighted.window_drift_spacing = 0;
  weighted.joint_screen_candidates = 0;
  UnknownAssociationOptions by_count = weighted;
  by_count.joint_close_ratio = 0;
  const UnknownAssociationResult a = SolveUnknownAssociation(world.data, by_count);
  const UnknownAssociationResult b = SolveUnknownAssociation(world.data, weighted);
  const PairwiseAgreement pa = ComparePairwise(a.association, world.true_association);
  const PairwiseAgreement pb = ComparePairwise(b.association, world.true_association);
  std::printf("by count: P %.4f R %.4f, %zu landmarks; weighted by fit: P %.4f R %.4f, %zu\n",
              pa.precision, pa.recall, a.solution.landmarks.size(), pb.precision, pb.recall,
              b.solution.landmarks.size());
  // Measured: either rule P 0.9997 R 0.9987, 240 landmarks (240 true).
  EXPECT_GT(pa.recall, 0.99);
  EXPECT_GT(pa.precision, 0.99);
  EXPECT_GT(pb.recall, 0.99);
  EXPECT_GT(pb.precision, 0.99);
  // Every clutter sighting is a landmark of its own, as in the file's ids.
  std::set<int> file_landmarks;
  for (const LandmarkSighting& z : world.data.sightings) file_landmarks.insert(z.landmark);
  EXPECT_NEAR(static_cast<double>(b.solution.landmarks.size()),
              static_cast<double>(file_landmarks.size()), 2.0);
  // Windows that end where the drift reaches a tenth of the landmarks'
  // spacing (the default) decide the re-entry early.
  by_count.window_drift_spacing = 0.1;
  const PairwiseAgreement pc = ComparePairwise(
      SolveUnknownAssociation(world.data, by_count).association, world.true_association);
  std::printf("by count, drift-bounded windows: P %.4f R %.4f\n", pc.precision, pc.recall);
  EXPECT_GT(pc.recall, 0.99);
  EXPECT_GT(pc.precision, 0.99);
  // So does the screen: the alignments below the floors judged by the joint
  // compatibility of their pairs.
  by_count.window_drift_spacing = 0;
  by_count.joint_screen_candidates = 64;
  const PairwiseAgreement pd = ComparePairwise(
      SolveUnknownAssociation(world.data, by_count).association, world.true_association);
  std::printf("by count, screened: P %.4f R %.4f\n", pd.precision, pd.recall);
  EXPECT_GT(pd.recall, 0.99);
  EXPECT_GT(pd.precision, 0.99);
}

// Two trees 0.9 m apart seen with a loose sighting noise (as GTSAM's file
// states it), in turns during the first window and both in every scan of the
// second: merged in the first window, their tracks go on into scans that see
// both, and the merged landmark must not keep two sightings of one scan.
TEST(LandmarkAssociationTest, NoLandmarkKeepsTwoSightingsOfOneScan) {
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
  // Under the loose noise as stated (the calibrated noise would not merge
  // them in the first place).
  options.calibrate_on_tracks = false;
  options.calibration_rounds = 0;
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

// One window of random hill climbing on SimulateDrive's trees, as
// HillClimbingRecoversTheTrueAssociation with the closed-form evaluation.
UnknownAssociationOptions OneWindowClimbOptions() {
  UnknownAssociationOptions options;
  options.tracks = {1.0, 2};
  options.target = DriveTargetOptions(LandmarkEvaluationMode::kMarginal);
  options.moves.merge_distance_m = 5.0;
  options.moves.merge_sigma_m = 2.5;
  options.window_poses = 0;
  options.targeted_radius_m = 0;  // random moves only
  options.hill_climb_steps_per_track = 15;
  options.seed = 7;
  return options;
}

// The middle sighting of tree 0's first stretch of SimulateDrive.
size_t MiddleSightingOfTreeZero(const LandmarkDataset& data) {
  std::vector<size_t> of_tree;
  for (size_t k = 0; k < data.sightings.size(); ++k)
    if (data.sightings[k].landmark == 0 && data.sightings[k].pose < data.num_poses / 2)
      of_tree.push_back(k);
  if (of_tree.size() < 3) throw Error("SimulateDrive: tree 0 seen fewer than 3 times");
  return of_tree[of_tree.size() / 2];
}

// The one-window search on `data` without, then with, the joins and splits
// after the final solve.
std::pair<UnknownAssociationResult, UnknownAssociationResult> WithoutAndWithSplits(
    const LandmarkDataset& data) {
  UnknownAssociationOptions without = OneWindowClimbOptions();
  without.sighting_split_gate = 0;
  return {SolveUnknownAssociation(data, without),
          SolveUnknownAssociation(data, OneWindowClimbOptions())};
}

// A false return within the track gate continues a tree's track; the
// search keeps tracks whole, so only the sighting split after the final
// solve gives it its own landmark, and the true association's evidence.
TEST(LandmarkAssociationTest, AMisfitSightingIsSplitOffItsTrack) {
  LandmarkDataset data = SimulateDrive(5, nullptr);
  // The middle sighting of tree 0's first stretch, 0.6 m long in range (6
  // sigma; the track gate is 1 m): a return of something else.
  const size_t wrong = MiddleSightingOfTreeZero(data);
  data.sightings[wrong].range_m += 0.6;
  data.sightings[wrong].landmark = 99;
  const auto [kept, split] = WithoutAndWithSplits(data);
  const std::vector<int> truth = GivenAssociation(data);
  const PairwiseAgreement a = ComparePairwise(kept.association, truth);
  const PairwiseAgreement b = ComparePairwise(split.association, truth);
  std::printf("tracks whole: P %.4f, %.1f; split: P %.4f, %.1f (%ld split)\n", a.precision,
              kept.log_target, b.precision, split.log_target, split.sighting_splits);
  EXPECT_LT(a.precision, 1.0);  // the false return rides with its track
  EXPECT_EQ(kept.sighting_splits, 0);
  EXPECT_EQ(split.sighting_splits, 1);
  EXPECT_DOUBLE_EQ(b.precision, 1.0);
  EXPECT_DOUBLE_EQ(b.recall, 1.0);
  EXPECT_GT(split.log_target, kept.log_target);
  // The result is the true association's solve under the search's model.
  const LandmarkSlamResult known =
      LandmarkSlam(split.slam_options).Solve(WithNoiseScales(data, split.noise_scales), truth);
  EXPECT_NEAR(split.log_target, known.evidence.log_evidence, 1e-3);
}

// A false return beside a tree's true one in the same scan ends the tree's
// track there (two candidates), and rides with one of its two parts, which
// then can never merge (one sighting per scan) however close they are:
// joined with the farther sighting of the shared scan split off, the true
// association comes back.
TEST(LandmarkAssociationTest, PartsSharingAScanAreJoinedWithoutTheFalseReturn) {
  LandmarkDataset data = SimulateDrive(5, nullptr);
  const size_t middle = MiddleSightingOfTreeZero(data);
  LandmarkSighting false_return = data.sightings[middle];
  false_return.range_m += 0.3;  // 3 sigma: no misfit beyond the gate
  false_return.landmark = 99;
  data.sightings.insert(data.sightings.begin() + middle + 1, false_return);
  const auto [parts, joined] = WithoutAndWithSplits(data);
  const std::vector<int> truth = GivenAssociation(data);
  const PairwiseAgreement a = ComparePairwise(parts.association, truth);
  const PairwiseAgreement b = ComparePairwise(joined.association, truth);
  std::printf("without: P %.4f R %.4f, %.1f; joined: P %.4f R %.4f, %.1f (%ld joins)\n",
              a.precision, a.recall, parts.log_target, b.precision, b.recall, joined.log_target,
              joined.shared_scan_joins);
  EXPECT_LT(a.recall, 1.0);  // the tree in two parts
  EXPECT_EQ(joined.shared_scan_joins, 1);
  EXPECT_DOUBLE_EQ(b.precision, 1.0);
  EXPECT_DOUBLE_EQ(b.recall, 1.0);
  EXPECT_GT(joined.log_target, parts.log_target);
}

// Tracks shorter than min_track_sightings are clutter: out of the state, -1.
TEST(LandmarkAssociationTest, ShortTracksAreLeftToClutter) {
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
  UnknownAssociationOptions options = OneWindowClimbOptions();
  options.min_track_sightings = 2;
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

// With neither targeted merges nor random moves, the duplicate sweep alone
// joins the tracks of each tree (within 2 m of each other).
TEST(LandmarkAssociationTest, TheSweepAloneJoinsDuplicates) {
  const LandmarkDataset data = SimulateDrive(6, nullptr);
  UnknownAssociationOptions options;
  options.tracks = {1.0, 2};
  options.target = DriveTargetOptions(LandmarkEvaluationMode::kMarginal);
  options.window_poses = 40;
  options.targeted_radius_m = 0;
  options.hill_climb_steps_per_track = 0;
  options.joint_min_inliers = 0;
  options.calibration_rounds = 0;  // its merge sweeps too
  const UnknownAssociationResult without = SolveUnknownAssociation(data, options);
  EXPECT_EQ(without.solution.landmarks.size(), without.tracks.size());
  options.sweep_radius_m = 2.0;
  std::vector<std::string> lines;
  const UnknownAssociationResult with = SolveUnknownAssociation(
      data, options, [&](const std::string& line) { lines.push_back(line); });
  EXPECT_DOUBLE_EQ(ComparePairwise(with.association, GivenAssociation(data)).agreement, 1.0);
  EXPECT_EQ(with.solution.landmarks.size(), 14u);
  int sweeps = 0;
  for (const std::string& line : lines) sweeps += line.rfind("final sweep", 0) == 0;
  EXPECT_EQ(sweeps, 1);
}

// Targeted merges with a candidate cap and the sweep: still the true
// association, and the same seed gives the same result to the bit.
TEST(LandmarkAssociationTest, ARunIsReproducibleFromItsSeed) {
  const LandmarkDataset data = SimulateDrive(6, nullptr);
  UnknownAssociationOptions options;
  options.tracks = {1.0, 2};
  options.target = DriveTargetOptions(LandmarkEvaluationMode::kMarginal);
  options.moves.merge_distance_m = 5.0;
  options.moves.merge_sigma_m = 2.5;
  options.window_poses = 40;
  options.targeted_max_candidates = 3;
  options.sweep_radius_m = 1.5;
  options.seed = 4;
  const UnknownAssociationResult first = SolveUnknownAssociation(data, options);
  LandmarkAssociation association(data, options);
  const UnknownAssociationResult second = association.Run();
  EXPECT_THROW(association.Run(), Error);  // one run per object
  EXPECT_DOUBLE_EQ(ComparePairwise(first.association, GivenAssociation(data)).agreement, 1.0);
  EXPECT_EQ(first.association, second.association);
  EXPECT_EQ(first.state, second.state);
  EXPECT_EQ(first.log_target, second.log_target);
  EXPECT_EQ(first.proposals, second.proposals);
  EXPECT_EQ(first.accepted, second.accepted);
}

// One diameter per track: the trunks still tell the trees apart and the map
// reports one per landmark.
TEST(LandmarkAssociationTest, DiameterPerTrackKeepsTheTrueAssociation) {
  LandmarkDataset data = SimulateDrive(5, nullptr);
  std::mt19937 rng(2);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (LandmarkSighting& s : data.sightings)
    s.diameter_m = 0.2 + 0.04 * (s.landmark % 7) + 0.02 * normal(rng);
  UnknownAssociationOptions options;
  options.tracks = {1.0, 2};
  options.target = DriveTargetOptions(LandmarkEvaluationMode::kMarginal);
  options.target.slam.diameter_std_m = 0.05;
  options.diameter_per_track = true;
  options.window_poses = 40;
  const UnknownAssociationResult result = SolveUnknownAssociation(data, options);
  EXPECT_DOUBLE_EQ(ComparePairwise(result.association, GivenAssociation(data)).agreement, 1.0);
  ASSERT_EQ(result.solution.landmarks.size(), 14u);
  for (const MappedLandmark& l : result.solution.landmarks) {
    EXPECT_TRUE(std::isfinite(l.diameter_m)) << "landmark " << l.id;
    EXPECT_NEAR(l.diameter_m, 0.3, 0.2) << "landmark " << l.id;
  }
}

TEST(LandmarkAssociationTest, NoTrackLongEnoughIsAnError) {
  const LandmarkDataset data = SimulateDrive(3, nullptr);
  UnknownAssociationOptions options;
  options.tracks = {1.0, 2};
  options.min_track_sightings = 1000;
  EXPECT_THROW(SolveUnknownAssociation(data, options), Error);
}

TEST(LandmarkAssociationTest, RejectsInvalidOptions) {
  const LandmarkDataset data = SimulateDrive(3, nullptr);
  std::string why;
  EXPECT_TRUE(UnknownAssociationOptions().Validate(&why));
  UnknownAssociationOptions bad;
  bad.samples = 5;
  bad.burn_in = 5;
  EXPECT_FALSE(bad.Validate(&why));
  EXPECT_THROW(LandmarkAssociation(data, bad), Error);
  UnknownAssociationOptions joint;
  joint.joint_min_inliers = 2;  // any two landmarks align: no evidence of a re-entry
  EXPECT_FALSE(joint.Validate(&why));
  joint.joint_min_inliers = 8;
  joint.joint_misfit_z = 0;
  EXPECT_FALSE(joint.Validate(&why));
  joint.joint_misfit_z = 4;
  joint.joint_repair_rounds = -1;
  EXPECT_FALSE(joint.Validate(&why));
  joint.joint_repair_rounds = 5;
  joint.joint_min_inliers = 0;  // off: the other joint options are not used
  joint.joint_inlier_m = 0;
  EXPECT_TRUE(joint.Validate(&why));
  UnknownAssociationOptions split;
  split.sighting_split_gate = -1;
  EXPECT_FALSE(split.Validate(&why));
  split.sighting_split_gate = std::nan("");
  EXPECT_FALSE(split.Validate(&why));
  split.sighting_split_gate = 0;  // off
  split.sighting_split_rounds = -1;
  EXPECT_FALSE(split.Validate(&why));
  split.sighting_split_rounds = 5;
  split.shared_scan_join_gate = std::nan("");
  EXPECT_FALSE(split.Validate(&why));
  UnknownAssociationOptions targeted;  // the targeted merges need the closed form
  targeted.target.mode = LandmarkEvaluationMode::kLocal;
  EXPECT_FALSE(targeted.Validate(&why));
  targeted.targeted_radius_m = 0;
  EXPECT_TRUE(targeted.Validate(&why));
  targeted.sweep_radius_m = 1.0;
  EXPECT_FALSE(targeted.Validate(&why));
  UnknownAssociationOptions screen;
  screen.joint_screen_candidates = -1;
  EXPECT_FALSE(screen.Validate(&why));
  screen.joint_screen_candidates = 64;
  screen.joint_screen_min_inliers = 2;
  EXPECT_FALSE(screen.Validate(&why));
  screen.joint_screen_min_inliers = 4;
  screen.joint_screen_min_gain = std::nan("");
  EXPECT_FALSE(screen.Validate(&why));
  screen.joint_screen_candidates = 0;  // off: the rest unused
  EXPECT_TRUE(screen.Validate(&why));
  UnknownAssociationOptions probation;
  probation.probation_windows = -1;
  EXPECT_FALSE(probation.Validate(&why));
  probation.probation_windows = 0;  // off
  EXPECT_TRUE(probation.Validate(&why));
  probation.probation_max_gain = std::nan("");
  EXPECT_FALSE(probation.Validate(&why));
  probation.probation_max_gain = 5;
  probation.probation_shift_spacing = -1;
  EXPECT_FALSE(probation.Validate(&why));
  UnknownAssociationOptions flat;
  flat.target.slam.landmark_density_per_m2 = 0;
  EXPECT_FALSE(flat.Validate(&why));
}

}  // namespace
}  // namespace oslam

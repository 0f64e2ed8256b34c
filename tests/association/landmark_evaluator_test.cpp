// The landmark sampler's target: the marginal (closed-form) and local
// (poses held) evaluations rank merge proposals as the exact re-solve does,
// trunk diameters included; one sighting per scan; the reference the
// closed form works from; the association and residuals it reports.
#include "association/landmark_evaluator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "association/landmark_tracks.h"
#include "core/error.h"
#include "slam/landmark_factors.h"
#include "tests/association/landmark_drives.h"

namespace oslam {
namespace {

using testing::DrivePrior;
using testing::DriveTargetOptions;
using testing::SimulateDrive;

AssociationState Separate(size_t num_tracks) {
  AssociationState state;
  for (size_t t = 0; t < num_tracks; ++t) {
    state.blocks.push_back({static_cast<int>(t)});
    state.classes.push_back(0);
  }
  return state;
}

AssociationState Merged(const AssociationState& state, int a, int b) {
  return state.WithBlocksMerged(state.BlockOf(a), state.BlockOf(b));
}

// From the all-separate state, every merge of two tracks of one tree and of
// nearby different trees: the marginal (closed-form) evaluation's decision
// (better or worse than separate) agrees with the exact one's.
TEST(LandmarkEvaluatorTest, LocalEvaluationRanksMergesLikeExact) {
  const LandmarkDataset data = SimulateDrive(4, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  LandmarkEvaluator exact(target, DriveTargetOptions(LandmarkEvaluationMode::kExact));
  LandmarkEvaluator local(target, DriveTargetOptions(LandmarkEvaluationMode::kLocal));
  LandmarkEvaluator marginal(target, DriveTargetOptions(LandmarkEvaluationMode::kMarginal));
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

// With trunk diameters measured, the closed-form merge score carries their
// part of the evidence: it matches the converged re-solve on every nearby
// pair (true merges within a fraction of a nat), as without diameters.
// Under either location prior (the closed form has a term for each).
void CheckMarginalMergeScoresDiametersLikeExact(DrivePrior prior) {
  LandmarkDataset data = SimulateDrive(4, nullptr);
  std::mt19937 rng(2);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (LandmarkSighting& s : data.sightings)
    s.diameter_m = 0.2 + 0.04 * (s.landmark % 7) + 0.05 * normal(rng);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  LandmarkEvaluator exact(target, DriveTargetOptions(LandmarkEvaluationMode::kExact, prior));
  LandmarkEvaluator marginal(target, DriveTargetOptions(LandmarkEvaluationMode::kMarginal, prior));
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
      double joint = 0;  // the same merge as a group of two
      ASSERT_TRUE(marginal.JointMergeDelta(separate, {{int(a), int(b)}}, &joint));
      EXPECT_NEAR(joint, dg, 1e-6);
      double gain = 0;  // the same merge without building the state
      ASSERT_TRUE(marginal.MergeGain(*marginal_start, int(a), int(b), &gain));
      EXPECT_NEAR(gain, dg, 1e-9);
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

TEST(LandmarkEvaluatorTest, MarginalMergeScoresDiametersLikeExact) {
  CheckMarginalMergeScoresDiametersLikeExact(DrivePrior::kDensity);
}

TEST(LandmarkEvaluatorTest, MarginalMergeScoresLikeExactUnderAGaussianPrior) {
  CheckMarginalMergeScoresDiametersLikeExact(DrivePrior::kGaussian);
}

// Several merges scored at once in closed form (JointMergeDelta): one pair
// as the single closed-form merge; every true merge of the drive at once
// (two laps, so loop closures that bend the trajectory) close to the
// converged exact re-solve of that state, and far above any state that
// also joins two different trees.
void CheckJointMergeDeltaScoresSeveralMergesAtOnce(DrivePrior prior) {
  const LandmarkDataset data = SimulateDrive(4, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  LandmarkEvaluator exact(target, DriveTargetOptions(LandmarkEvaluationMode::kExact, prior));
  LandmarkEvaluator marginal(target, DriveTargetOptions(LandmarkEvaluationMode::kMarginal, prior));
  const AssociationState separate = Separate(target.tracks.size());
  const EvaluationPtr start = marginal.Refine(separate, nullptr);
  const EvaluationPtr exact_start = exact.Refine(separate, nullptr);
  ASSERT_TRUE(start->valid && exact_start->valid);

  // The tracks of each tree, as groups of the separate state's blocks.
  std::map<int, std::vector<int>> by_tree;
  for (size_t t = 0; t < target.tracks.size(); ++t)
    by_tree[data.sightings[target.tracks[t][0]].landmark].push_back(
        separate.BlockOf(static_cast<int>(t)));
  std::vector<std::vector<int>> groups;
  AssociationState truth;
  for (const auto& [tree, blocks] : by_tree) {
    if (blocks.size() > 1) groups.push_back(blocks);
    truth.blocks.emplace_back();
    for (int j : blocks) truth.blocks.back().push_back(separate.blocks[j].front());
    truth.classes.push_back(0);
  }
  truth.Canonicalize();
  ASSERT_GE(groups.size(), 5u);

  const std::vector<int>& first = groups.front();
  double one = 0, all = 0;
  ASSERT_TRUE(marginal.JointMergeDelta(separate, {{first[0], first[1]}}, &one));
  const EvaluationPtr single = marginal.Evaluate(
      Merged(separate, separate.blocks[first[0]].front(), separate.blocks[first[1]].front()),
      start.get());
  ASSERT_TRUE(single->valid);
  EXPECT_NEAR(one, single->log_target - start->log_target, 1e-6);

  ASSERT_TRUE(marginal.JointMergeDelta(separate, groups, &all));
  const EvaluationPtr solved = exact.Refine(truth, exact_start.get());
  ASSERT_TRUE(solved->valid);
  const double exact_gain = solved->log_target - exact_start->log_target;
  std::printf("%zu trees merged at once: closed form %.2f, converged re-solve %.2f\n",
              groups.size(), all, exact_gain);
  EXPECT_GT(all, 20.0);
  EXPECT_NEAR(all, exact_gain, 0.02 * std::abs(exact_gain) + 1.0);

  // Also joining two different trees costs: the closed form says so.
  std::vector<std::vector<int>> wrong = groups;
  wrong[0].insert(wrong[0].end(), wrong[1].begin(), wrong[1].end());
  wrong.erase(wrong.begin() + 1);
  double worse = 0;
  ASSERT_TRUE(marginal.JointMergeDelta(separate, wrong, &worse));
  EXPECT_LT(worse, all - 10.0);

  // Only at the reference, and only for groups of two or more.
  EXPECT_FALSE(marginal.JointMergeDelta(truth, {{0, 1}}, &all));
  EXPECT_FALSE(marginal.JointMergeDelta(separate, {{first[0]}}, &all));
}

TEST(LandmarkEvaluatorTest, JointMergeDeltaScoresSeveralMergesAtOnce) {
  CheckJointMergeDeltaScoresSeveralMergesAtOnce(DrivePrior::kDensity);
}

TEST(LandmarkEvaluatorTest, JointMergeDeltaScoresSeveralMergesAtOnceUnderAGaussianPrior) {
  CheckJointMergeDeltaScoresSeveralMergesAtOnce(DrivePrior::kGaussian);
}

// Two tracks seen from one pose (two trees in one scan).
std::pair<int, int> TracksSharingAScan(const LandmarkTargetData& target) {
  for (size_t a = 0; a < target.tracks.size(); ++a) {
    std::set<int> poses;
    for (int k : target.tracks[a]) poses.insert(target.data->sightings[k].pose);
    for (size_t b = a + 1; b < target.tracks.size(); ++b)
      for (int k : target.tracks[b])
        if (poses.count(target.data->sightings[k].pose))
          return {static_cast<int>(a), static_cast<int>(b)};
  }
  return {-1, -1};
}

TEST(LandmarkEvaluatorTest, ASharedScanMakesAMergeInvalid) {
  const LandmarkDataset data = SimulateDrive(4, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  const auto [a, b] = TracksSharingAScan(target);
  ASSERT_GE(a, 0);
  const AssociationState separate = Separate(target.tracks.size());
  const AssociationState merged = Merged(separate, a, b);
  for (const auto mode : {LandmarkEvaluationMode::kExact, LandmarkEvaluationMode::kLocal,
                          LandmarkEvaluationMode::kMarginal}) {
    LandmarkEvaluator evaluator(target, DriveTargetOptions(mode));
    const EvaluationPtr start = evaluator.Refine(separate, nullptr);
    ASSERT_TRUE(start->valid);
    EXPECT_FALSE(evaluator.Evaluate(merged, start.get())->valid) << static_cast<int>(mode);
    EXPECT_FALSE(evaluator.Trial(merged, start.get())->valid) << static_cast<int>(mode);
    double gain = 0;  // only the marginal mode scores merges in closed form
    const bool closed_form =
        evaluator.MergeGain(*start, separate.BlockOf(a), separate.BlockOf(b), &gain);
    EXPECT_EQ(closed_form, mode == LandmarkEvaluationMode::kMarginal);
    if (closed_form) {
      EXPECT_EQ(gain, -std::numeric_limits<double>::infinity());
    }
  }
  // Without the rule the merge is merely unlikely, not impossible.
  LandmarkTargetOptions options = DriveTargetOptions(LandmarkEvaluationMode::kExact);
  options.one_sighting_per_scan = false;
  LandmarkEvaluator permissive(target, options);
  const EvaluationPtr start = permissive.Refine(separate, nullptr);
  const EvaluationPtr e = permissive.Evaluate(merged, start.get());
  EXPECT_TRUE(e->valid);
  EXPECT_LT(e->log_target, start->log_target);
}

TEST(LandmarkEvaluatorTest, AssociationLabelsSightingsByTheEarliestTrack) {
  const LandmarkDataset data = SimulateDrive(3, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  ASSERT_GE(target.tracks.size(), 4u);
  LandmarkEvaluator evaluator(target, DriveTargetOptions(LandmarkEvaluationMode::kMarginal));
  AssociationState state = Merged(Separate(target.tracks.size()), 1, 3);
  // Track 0 left out of the state (as clutter is): its sightings get -1.
  state.blocks.erase(state.blocks.begin());
  state.classes.pop_back();
  const std::vector<int> association = evaluator.Association(state);
  ASSERT_EQ(association.size(), data.sightings.size());
  for (int k : target.tracks[0]) EXPECT_EQ(association[k], -1);
  for (int k : target.tracks[1]) EXPECT_EQ(association[k], 1);
  for (int k : target.tracks[3]) EXPECT_EQ(association[k], 1);
  for (int k : target.tracks[2]) EXPECT_EQ(association[k], 2);
}

TEST(LandmarkEvaluatorTest, RepeatedStatesComeFromTheCache) {
  const LandmarkDataset data = SimulateDrive(3, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  LandmarkEvaluator evaluator(target, DriveTargetOptions(LandmarkEvaluationMode::kLocal));
  const AssociationState separate = Separate(target.tracks.size());
  const EvaluationPtr start = evaluator.Refine(separate, nullptr);
  const AssociationState merged = Merged(separate, 0, 1);
  const EvaluationPtr first = evaluator.Evaluate(merged, start.get());
  const size_t solves = evaluator.num_solves();
  EXPECT_EQ(evaluator.Evaluate(merged, start.get()), first);
  EXPECT_EQ(evaluator.num_cache_hits(), 1u);
  EXPECT_EQ(evaluator.num_solves(), solves);
}

// Disjoint pairs of tracks of one tree (never seen in one scan).
std::vector<std::pair<int, int>> SameTreePairs(const LandmarkTargetData& target) {
  std::vector<std::pair<int, int>> pairs;
  std::set<int> used;
  auto tree = [&](size_t t) { return target.data->sightings[target.tracks[t][0]].landmark; };
  for (size_t a = 0; a < target.tracks.size(); ++a)
    for (size_t b = a + 1; b < target.tracks.size(); ++b)
      if (tree(a) == tree(b) && !used.count(int(a)) && !used.count(int(b))) {
        pairs.push_back({int(a), int(b)});
        used.insert({int(a), int(b)});
      }
  return pairs;
}

// Two marginal evaluators of one drive, both refined at the all-separate
// state: the one a test exercises, and a plain one to compare it with.
struct TwinReferences {
  LandmarkDataset data = SimulateDrive(4, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  std::vector<std::pair<int, int>> pairs = SameTreePairs(target);
  LandmarkTargetOptions options = DriveTargetOptions(LandmarkEvaluationMode::kMarginal);
  LandmarkEvaluator tested{target, options}, plain{target, options};
  AssociationState separate = Separate(target.tracks.size());
  EvaluationPtr reference = tested.Refine(separate, nullptr);
  EvaluationPtr plain_reference = plain.Refine(separate, nullptr);
};

// A trial solve leaves the reference alone: a merge of the reference's
// landmarks is still scored in closed form, exactly as without the trial.
TEST(LandmarkEvaluatorTest, TrialLeavesTheReferenceAlone) {
  TwinReferences twin;
  const std::vector<std::pair<int, int>>& pairs = twin.pairs;
  ASSERT_GE(pairs.size(), 3u);
  LandmarkEvaluator &with_trial = twin.tested, &without = twin.plain;
  const AssociationState& separate = twin.separate;
  const EvaluationPtr &reference = twin.reference, &same_reference = twin.plain_reference;
  ASSERT_TRUE(reference->valid);
  const AssociationState tried =
      Merged(Merged(separate, pairs[0].first, pairs[0].second), pairs[1].first, pairs[1].second);
  const EvaluationPtr trial = with_trial.Trial(tried, reference.get());
  ASSERT_TRUE(trial->valid);
  EXPECT_TRUE(with_trial.IsReference(*reference));
  EXPECT_FALSE(with_trial.IsReference(*trial));
  EXPECT_EQ(trial->state, tried);
  EXPECT_EQ(trial->locations.size(), tried.blocks.size());
  const AssociationState merge = Merged(separate, pairs[2].first, pairs[2].second);
  const EvaluationPtr e = with_trial.Evaluate(merge, reference.get());
  const EvaluationPtr f = without.Evaluate(merge, same_reference.get());
  EXPECT_EQ(with_trial.num_marginal_merges(), 1u);
  ASSERT_TRUE(e->valid);
  EXPECT_EQ(e->log_target, f->log_target);
  // A refine moves the reference: the same merge is no longer one of it.
  ASSERT_TRUE(with_trial.Refine(tried, trial.get())->valid);
  EXPECT_TRUE(with_trial.Evaluate(merge, reference.get())->valid);
  EXPECT_EQ(with_trial.num_marginal_merges(), 1u);
}

// A split scored from the reference's local values (SplitGain) is what
// Evaluate gives for the split state, for every track of every block of a
// state whose blocks hold several tracks (a true and a wrong merge), in
// local and marginal mode; it does not apply off the reference, to a track
// not in the block or alone in it, or in exact mode.
TEST(LandmarkEvaluatorTest, ASplitScoresAsItsEvaluation) {
  const LandmarkDataset data = SimulateDrive(4, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  const std::vector<std::pair<int, int>> pairs = SameTreePairs(target);
  ASSERT_GE(pairs.size(), 3u);
  AssociationState state = Separate(target.tracks.size());
  for (const auto& [a, b] : pairs)
    if (state.BlockOf(a) != state.BlockOf(b)) state = Merged(state, a, b);
  // A wrong merge too: the first tree with another one seen from other poses.
  const auto poses_of = [&](int j) {
    std::set<int> poses;
    for (int t : state.blocks[j])
      for (int k : target.tracks[t]) poses.insert(data.sightings[k].pose);
    return poses;
  };
  const int first = state.BlockOf(pairs[0].first);
  const int tree = data.sightings[target.tracks[pairs[0].first][0]].landmark;
  bool wrong = false;
  for (size_t t = 0; t < target.tracks.size() && !wrong; ++t) {
    const int j = state.BlockOf(static_cast<int>(t));
    if (j == first || data.sightings[target.tracks[t][0]].landmark == tree) continue;
    const std::set<int> mine = poses_of(first), its = poses_of(j);
    if (std::none_of(its.begin(), its.end(), [&](int p) { return mine.count(p) > 0; })) {
      state = Merged(state, pairs[0].first, static_cast<int>(t));
      wrong = true;
    }
  }
  ASSERT_TRUE(wrong);
  for (const LandmarkEvaluationMode mode :
       {LandmarkEvaluationMode::kLocal, LandmarkEvaluationMode::kMarginal}) {
    LandmarkEvaluator evaluator(target, DriveTargetOptions(mode));
    const EvaluationPtr at = evaluator.Refine(state, nullptr);
    ASSERT_TRUE(at->valid);
    int scored = 0;
    for (size_t j = 0; j < state.blocks.size(); ++j) {
      if (state.blocks[j].size() < 2) continue;
      for (int t : state.blocks[j]) {
        const AssociationState split = state.WithTrackMoved(t, -1, 0);
        double gain = 0;
        ASSERT_TRUE(evaluator.SplitGain(*at, static_cast<int>(j), t, &gain));
        const EvaluationPtr e = evaluator.Evaluate(split, at.get());
        if (!e->valid) {  // the rest still holds two sightings of one scan
          EXPECT_EQ(gain, -std::numeric_limits<double>::infinity());
          continue;
        }
        EXPECT_NEAR(gain, e->log_target - at->log_target, 1e-9 * std::abs(at->log_target));
        ++scored;
      }
    }
    EXPECT_GE(scored, 8);
    double gain = 0;
    const int alone = state.BlockOf(static_cast<int>(target.tracks.size()) - 1);
    EXPECT_FALSE(evaluator.SplitGain(*at, -1, 0, &gain));
    const int multi = state.BlockOf(pairs[1].first);
    const int outside = state.blocks[multi].front() == 0 ? 1 : 0;
    if (state.BlockOf(outside) != multi) {
      EXPECT_FALSE(evaluator.SplitGain(*at, multi, outside, &gain));
    }
    if (state.blocks[alone].size() == 1) {
      EXPECT_FALSE(evaluator.SplitGain(*at, alone, state.blocks[alone][0], &gain));
    }
    StateEvaluation copy = *at;  // not the reference
    EXPECT_FALSE(evaluator.SplitGain(copy, multi, pairs[1].first, &gain));
  }
  LandmarkEvaluator exact(target, DriveTargetOptions(LandmarkEvaluationMode::kExact));
  const EvaluationPtr at = exact.Refine(state, nullptr);
  double gain = 0;
  EXPECT_FALSE(exact.SplitGain(*at, state.BlockOf(pairs[1].first), pairs[1].first, &gain));
}

// A reference set aside (StashReference) comes back without a solve: after
// a refine of another state, scored in closed form there, the same merge of
// the first reference scores exactly as on an evaluator that never left it.
TEST(LandmarkEvaluatorTest, AStashedReferenceComesBackWithoutASolve) {
  TwinReferences twin;
  const std::vector<std::pair<int, int>>& pairs = twin.pairs;
  ASSERT_GE(pairs.size(), 3u);
  LandmarkEvaluator &stashing = twin.tested, &without = twin.plain;
  const AssociationState& separate = twin.separate;
  const EvaluationPtr &reference = twin.reference, &same_reference = twin.plain_reference;
  ASSERT_TRUE(reference->valid);

  stashing.StashReference();
  EXPECT_FALSE(stashing.IsReference(*reference));
  EXPECT_THROW(stashing.StashReference(), Error);  // one at a time
  const AssociationState other = Merged(separate, pairs[0].first, pairs[0].second);
  const EvaluationPtr refined = stashing.Refine(other, reference.get());
  ASSERT_TRUE(refined->valid);
  EXPECT_TRUE(stashing.IsReference(*refined));
  double gain_there = 0;
  ASSERT_TRUE(stashing.MergeGain(*refined, refined->state.BlockOf(pairs[1].first),
                                 refined->state.BlockOf(pairs[1].second), &gain_there));

  const size_t solves = stashing.num_solves();
  EXPECT_EQ(stashing.RestoreReference(), reference);
  EXPECT_EQ(stashing.num_solves(), solves);
  EXPECT_TRUE(stashing.IsReference(*reference));
  EXPECT_FALSE(stashing.IsReference(*refined));
  EXPECT_THROW(stashing.RestoreReference(), Error);  // nothing set aside now
  const int a = separate.BlockOf(pairs[1].first), b = separate.BlockOf(pairs[1].second);
  double gain = 0, same_gain = 0;
  ASSERT_TRUE(stashing.MergeGain(*reference, a, b, &gain));
  ASSERT_TRUE(without.MergeGain(*same_reference, a, b, &same_gain));
  EXPECT_EQ(gain, same_gain);
  // Scored at the other reference, the merge gained another amount (the
  // merge of pairs[0] moved the trajectory): the closed form did use it.
  EXPECT_NE(gain, gain_there);

  // The spare solver serves the next stash as well.
  stashing.StashReference();
  ASSERT_TRUE(stashing.Refine(other, reference.get())->valid);
  EXPECT_EQ(stashing.RestoreReference(), reference);
  ASSERT_TRUE(stashing.MergeGain(*reference, a, b, &gain));
  EXPECT_EQ(gain, same_gain);
}

TEST(LandmarkEvaluatorTest, SolveReportsEveryLandmarkWithItsCovariance) {
  const LandmarkDataset data = SimulateDrive(3, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  LandmarkEvaluator evaluator(target, DriveTargetOptions(LandmarkEvaluationMode::kMarginal));
  const AssociationState state = Merged(Separate(target.tracks.size()), 0, 1);
  const LandmarkSlamResult result = evaluator.Solve(state, nullptr);
  ASSERT_TRUE(result.summary.IsUsable());
  ASSERT_EQ(result.landmarks.size(), state.blocks.size());
  for (const MappedLandmark& l : result.landmarks) {
    EXPECT_GT(l.covariance(0, 0), 0) << "landmark " << l.id;
    EXPECT_GT(l.covariance(1, 1), 0) << "landmark " << l.id;
  }
  EXPECT_EQ(result.trajectory.size(), static_cast<size_t>(data.num_poses));
}

TEST(LandmarkEvaluatorTest, SightingResidualIsWhitened) {
  LandmarkDataset data;
  data.num_poses = 1;
  data.sensor_offset_m = Eigen::Vector2d(1.0, 0.0);
  LandmarkSighting s;
  s.range_m = 10.0;
  s.bearing_rad = 0.0;
  s.range_std_m = 0.1;
  s.bearing_std_rad = 0.01;
  data.sightings.push_back(s);
  const std::vector<Pose2> trajectory{{0.0, 0.0, 0.0}};
  // The sensor is 1 m ahead of the robot: the sighting is of (11, 0).
  EXPECT_NEAR(SightingResidual2(data, trajectory, {0}, {11.0, 0.0}), 0.0, 1e-20);
  EXPECT_NEAR(SightingResidual2(data, trajectory, {0}, {11.1, 0.0}), 1.0, 1e-9);  // 1 range std
  // One bearing std off (and 0.005 range std further).
  EXPECT_NEAR(SightingResidual2(data, trajectory, {0}, {11.0, 10.0 * std::tan(0.01)}), 1.000025,
              1e-6);
  EXPECT_EQ(SightingResidual2(data, trajectory, {}, {0.0, 0.0}), 0.0);
}

TEST(LandmarkEvaluatorTest, RejectsInvalidOptions) {
  const LandmarkDataset data = SimulateDrive(3, nullptr);
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2})};
  LandmarkTargetOptions options = DriveTargetOptions(LandmarkEvaluationMode::kLocal);
  options.slam.landmark_density_per_m2 = 0;  // a flat prior: counts of landmarks do not compare
  EXPECT_THROW(LandmarkEvaluator(target, options), Error);
  options.slam.landmark_density_per_m2 = 1e-3;
  options.slam.landmark_prior_std_m = 50;  // two location priors
  EXPECT_THROW(LandmarkEvaluator(target, options), Error);
  std::string why;
  options = DriveTargetOptions(LandmarkEvaluationMode::kLocal);
  EXPECT_TRUE(options.Validate(&why));
  options.local_iterations = 0;
  EXPECT_FALSE(options.Validate(&why));
  options = DriveTargetOptions(LandmarkEvaluationMode::kLocal);
  options.max_cache_entries = 0;
  EXPECT_FALSE(options.Validate(&why));
  LandmarkTargetData no_data{nullptr, {}};
  EXPECT_THROW(LandmarkEvaluator(no_data, DriveTargetOptions(LandmarkEvaluationMode::kLocal)),
               Error);
}

}  // namespace
}  // namespace oslam

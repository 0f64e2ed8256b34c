// The O-SLAM target (slam_target.h) on the synthetic loop of scene_tracks.h:
// the problem a state stands for; its value, the Laplace evidence plus the
// class terms (docs/method.md §8.2); that the true association outscores
// wrong ones; the cache and its roll-back (§9.3); proposals solved from the
// current solution (§9.6); the approximation for delayed acceptance (§9.3);
// covariances added to recorded samples only.
#include "association/slam_target.h"

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "association/scene_tracks.h"
#include "core/error.h"

namespace oslam {
namespace {

using testing::MakeSceneTracks;
using testing::SceneTracks;

SlamTargetOptions Options(int proposal_iterations = 1) {
  SlamTargetOptions options;
  options.slam.pixel_std_px = 3.0;  // the scene's noise
  options.proposal_iterations = proposal_iterations;
  return options;
}

const MappedObject* Object(const GeometricSlamResult& result, int id) {
  for (const MappedObject& object : result.objects)
    if (object.id == id) return &object;
  return nullptr;
}

// `state` with the last track of its first object made an object of its own.
AssociationState SplitOffLastTrack(AssociationState state) {
  const int last = state.blocks[0].back();
  state.blocks[0].pop_back();
  state.blocks.push_back({last});
  state.classes.push_back(state.classes[0]);
  state.Canonicalize();
  return state;
}

// `state` with objects i and j joined, with i's class.
AssociationState Merge(AssociationState state, int i, int j) {
  state.blocks[i].insert(state.blocks[i].end(), state.blocks[j].begin(), state.blocks[j].end());
  state.blocks.erase(state.blocks.begin() + j);
  state.classes.erase(state.classes.begin() + j);
  state.Canonicalize();
  return state;
}

class SlamTargetTest : public ::testing::Test {
 protected:
  SceneTracks s_ = MakeSceneTracks();
  ClassConfusionModel model_ = s_.Model();
};

TEST_F(SlamTargetTest, TheProblemLabelsEachDetectionWithItsObjectsEarliestTrack) {
  const SlamEvaluator evaluator(s_.data, model_, Options());
  for (const AssociationState& state : {s_.truth, s_.Separate(), SplitOffLastTrack(s_.truth)}) {
    const GeometricSlamProblem problem = evaluator.BuildProblem(state);
    EXPECT_EQ(problem.increments.size(), s_.data.increments.size());
    EXPECT_EQ(problem.classes.size(), 2u);
    ASSERT_EQ(problem.observations.size(), s_.data.detections.size());
    std::vector<int> seen(s_.data.detections.size(), 0);
    for (const SliceObservation& o : problem.observations) {
      ASSERT_GE(o.detection_id, 0);
      ASSERT_LT(o.detection_id, static_cast<int>(seen.size()));
      ++seen[o.detection_id];
      const ClassedSlice& d = s_.data.detections[o.detection_id];
      EXPECT_EQ(o.frame, d.frame);
      EXPECT_EQ(o.slice.u_r_px, d.slice.u_r_px);
      // The object is the block holding the detection's track, named by its first track.
      int track = -1;
      for (const Track& t : s_.data.tracks)
        for (int i : t.detections)
          if (i == o.detection_id) track = t.id;
      const int block = state.BlockOf(track);
      ASSERT_GE(block, 0);
      EXPECT_EQ(o.object_id, state.blocks[block].front());
    }
    EXPECT_EQ(seen, std::vector<int>(seen.size(), 1));
    ASSERT_EQ(problem.object_class.size(), state.blocks.size());
    for (size_t j = 0; j < state.blocks.size(); ++j)
      EXPECT_EQ(problem.object_class.at(state.blocks[j].front()), state.classes[j]);
  }
}

TEST_F(SlamTargetTest, TheTargetIsTheLaplaceEvidencePlusTheClassTerms) {
  SlamEvaluator evaluator(s_.data, model_, Options());
  const EvaluationPtr e = evaluator.Refine(s_.truth, nullptr);
  ASSERT_TRUE(e->valid);
  ASSERT_TRUE(e->solution);
  double expected = e->solution->evidence.log_evidence;
  for (size_t j = 0; j < e->state.blocks.size(); ++j)
    expected += model_.BlockLogLikelihood(e->state.blocks[j], e->state.classes[j]);
  EXPECT_NEAR(e->log_target, expected, 1e-9);
  // Per object, the solved location and r^2 of eq. 5.2 the moves use.
  ASSERT_EQ(e->locations.size(), s_.truth.blocks.size());
  ASSERT_EQ(e->residual2.size(), s_.truth.blocks.size());
  for (size_t j = 0; j < s_.truth.blocks.size(); ++j) {
    const MappedObject* object = Object(*e->solution, s_.truth.blocks[j].front());
    ASSERT_NE(object, nullptr);
    EXPECT_EQ(e->locations[j], object->geometry.base_world);
    EXPECT_EQ(e->residual2[j], object->squared_residual);
    EXPECT_GT(e->residual2[j], 0.0);
  }
  // P(C, J) as prod_j 1 / |classes| instead of uniform: log 2 less per object,
  // the solution unchanged.
  SlamTargetOptions per_object = Options();
  per_object.class_prior_per_object = true;
  SlamEvaluator priced(s_.data, model_, per_object);
  for (const AssociationState& state : {s_.truth, s_.Separate()}) {
    const double uniform = evaluator.Refine(state, nullptr)->log_target;
    EXPECT_NEAR(priced.Refine(state, nullptr)->log_target,
                uniform - state.blocks.size() * std::log(2.0), 1e-9);
  }
}

// Against the scene's truth: the true association has the highest target of
// its neighbours (over-split, one track split off, two same-class objects
// merged, one object's class switched), and its map is accurate.
TEST_F(SlamTargetTest, TheTrueAssociationOutscoresWrongOnes) {
  SlamEvaluator evaluator(s_.data, model_, Options());
  const EvaluationPtr truth = evaluator.Refine(s_.truth, nullptr);
  ASSERT_TRUE(truth->valid);
  // Objects 0 and 1 of the canonical truth are both of class 0.
  ASSERT_EQ(s_.truth.classes[0], 0);
  ASSERT_EQ(s_.truth.classes[1], 0);
  AssociationState switched = s_.truth;
  switched.classes[1] = 1;
  const std::vector<std::pair<std::string, AssociationState>> wrong = {
      {"all tracks separate", s_.Separate()},
      {"a track split off", SplitOffLastTrack(s_.truth)},
      {"two objects merged", Merge(s_.truth, 0, 1)},
      {"a class switched", switched}};
  for (const auto& [name, state] : wrong) {
    const EvaluationPtr e = evaluator.Refine(state, nullptr);
    EXPECT_TRUE(e->valid) << name;
    // A split must pay the Occam factor; 1 nat is far below what it loses here.
    EXPECT_LT(e->log_target, truth->log_target - 1.0) << name;
  }
  // Each object within 0.2 m of where it stands (3 px noise, noisy odometry).
  for (size_t j = 0; j < s_.truth.blocks.size(); ++j) {
    const int object = s_.track_object[s_.truth.blocks[j].front()];
    EXPECT_LT((truth->locations[j] - s_.scene.true_objects[object].base_world).norm(), 0.2) << j;
  }
}

TEST_F(SlamTargetTest, RevisitedStatesComeFromTheCacheAndRefineReplacesThem) {
  SlamEvaluator evaluator(s_.data, model_, Options());
  EXPECT_TRUE(evaluator.SupportsRollBack());
  const EvaluationPtr truth = evaluator.Refine(s_.truth, nullptr);
  EXPECT_EQ(evaluator.num_solves(), 1u);
  const AssociationState split = SplitOffLastTrack(s_.truth);
  const EvaluationPtr proposed = evaluator.Evaluate(split, truth.get());
  EXPECT_EQ(evaluator.num_solves(), 2u);
  EXPECT_EQ(evaluator.num_cache_hits(), 0u);
  // Revisited, from wherever: the cached value (one value per state).
  EXPECT_EQ(evaluator.Evaluate(split, proposed.get()), proposed);
  EXPECT_EQ(evaluator.Evaluate(split, nullptr), proposed);
  EXPECT_EQ(evaluator.Evaluate(s_.truth, proposed.get()), truth);
  EXPECT_EQ(evaluator.num_solves(), 2u);
  EXPECT_EQ(evaluator.num_cache_hits(), 3u);
  // A full optimisation replaces the cached value.
  const EvaluationPtr refined = evaluator.Refine(split, truth.get());
  EXPECT_NE(refined, proposed);
  EXPECT_EQ(evaluator.Evaluate(split, truth.get()), refined);
  EXPECT_EQ(evaluator.num_solves(), 3u);
  // An evaluation made elsewhere (another chain's, at a swap) is taken as is.
  auto elsewhere = std::make_shared<StateEvaluation>(*refined);
  elsewhere->state = s_.Separate();
  evaluator.Remember(elsewhere);
  EXPECT_EQ(evaluator.Evaluate(s_.Separate(), nullptr), elsewhere);
  EXPECT_EQ(evaluator.num_solves(), 3u);
}

// Speculative chains undo evaluations: after a roll-back the cache and
// counters are as at the mark, and solving again gives the same value bit for
// bit although the solver has done other work since.
TEST_F(SlamTargetTest, RolledBackEvaluationsAreRedoneExactly) {
  SlamEvaluator evaluator(s_.data, model_, Options());
  const EvaluationPtr from = evaluator.Refine(SplitOffLastTrack(s_.truth), nullptr);
  const size_t mark = evaluator.Mark();
  const size_t solves = evaluator.num_solves(), hits = evaluator.num_cache_hits();
  const AssociationState merged = s_.truth, other = Merge(from->state, 0, 1);
  const EvaluationPtr first = evaluator.Evaluate(merged, from.get());
  evaluator.Evaluate(other, from.get());
  evaluator.Evaluate(merged, from.get());  // a hit
  evaluator.RollBack(mark);
  EXPECT_EQ(evaluator.num_solves(), solves);
  EXPECT_EQ(evaluator.num_cache_hits(), hits);
  // In another order, after other solves: the same numbers.
  const EvaluationPtr again_other = evaluator.Evaluate(other, from.get());
  const EvaluationPtr again = evaluator.Evaluate(merged, from.get());
  EXPECT_NE(again, first);  // solved anew, not found
  EXPECT_EQ(evaluator.num_solves(), solves + 2);
  EXPECT_EQ(again->log_target, first->log_target);
  EXPECT_EQ(again->locations, first->locations);
  EXPECT_EQ(again->residual2, first->residual2);
  evaluator.Release(mark);
  EXPECT_TRUE(again_other->valid);
}

// A class switch changes its object's silhouette: the linearisations it
// made must not stand in for the other class afterwards, or a proposal's value
// depends on what the chain tried before (and a chain that rolls back after a
// swap gets other values than one that did not: docs/method.md §9.4, §9.6).
TEST_F(SlamTargetTest, AClassSwitchLeavesNothingBehindForTheOtherClass) {
  SceneTracks s = MakeSceneTracks();
  for (ClassPrior& prior : s.data.classes) prior.slice_model.silhouette.enabled = true;
  s.data.classes[1].slice_model.silhouette.depth_half_extent = 0.8;
  s.data.classes[1].slice_model.silhouette.width_half_extent = 0.9;
  const ClassConfusionModel model = s.Model();
  SlamEvaluator evaluator(s.data, model, Options()), fresh(s.data, model, Options());
  const EvaluationPtr from = evaluator.Refine(s.truth, nullptr);
  AssociationState switched = s.truth;
  switched.classes[0] = 1 - switched.classes[0];
  ASSERT_TRUE(evaluator.Evaluate(switched, from.get())->valid);
  for (const AssociationState& next : {SplitOffLastTrack(s.truth), Merge(s.truth, 1, 2)}) {
    const EvaluationPtr after = evaluator.Evaluate(next, from.get());
    const EvaluationPtr alone = fresh.Evaluate(next, from.get());
    ASSERT_TRUE(after->valid && alone->valid);
    EXPECT_EQ(after->log_target, alone->log_target) << next.ToString();
    EXPECT_EQ(after->locations, alone->locations) << next.ToString();
  }
}

TEST_F(SlamTargetTest, ACacheBeyondItsLimitStartsAfresh) {
  SlamTargetOptions options = Options();
  options.max_cache_entries = 2;
  SlamEvaluator evaluator(s_.data, model_, options);
  const EvaluationPtr from = evaluator.Refine(s_.truth, nullptr);  // entry 1
  const AssociationState a = SplitOffLastTrack(s_.truth), b = Merge(s_.truth, 0, 1);
  evaluator.Evaluate(a, from.get());  // entry 2
  EXPECT_EQ(evaluator.num_solves(), 2u);
  evaluator.Evaluate(b, from.get());  // full: cleared, then stored
  EXPECT_EQ(evaluator.num_solves(), 3u);
  evaluator.Evaluate(b, from.get());
  EXPECT_EQ(evaluator.num_solves(), 3u);
  evaluator.Evaluate(a, from.get());  // forgotten
  EXPECT_EQ(evaluator.num_solves(), 4u);
}

// A proposal is linearised at the current state's solution: from a
// neighbouring state's solution one Gauss-Newton step already gives the
// fully optimised target to a few thousandths of a nat, and more iterations
// do no worse.
TEST_F(SlamTargetTest, ProposalsSolvedFromTheCurrentSolutionMatchAFullSolve) {
  SlamEvaluator full(s_.data, model_, Options());
  const EvaluationPtr exact = full.Refine(s_.truth, nullptr);
  const EvaluationPtr split = full.Refine(SplitOffLastTrack(s_.truth), nullptr);
  for (int iterations : {1, 2, 10}) {
    SlamEvaluator evaluator(s_.data, model_, Options(iterations));
    const EvaluationPtr merged = evaluator.Evaluate(s_.truth, split.get());
    ASSERT_TRUE(merged->valid) << iterations;
    EXPECT_NEAR(merged->log_target, exact->log_target, 0.01) << iterations;
    for (size_t j = 0; j < merged->locations.size(); ++j)
      EXPECT_LT((merged->locations[j] - exact->locations[j]).norm(), 0.005) << iterations;
    // Proposals carry no covariances (recorded samples get them by Complete).
    EXPECT_FALSE(merged->solution->has_object_covariances);
  }
  EXPECT_TRUE(exact->solution->has_object_covariances);
}

TEST_F(SlamTargetTest, TheApproximationKeepsSharedObjectsAndSolvesTheChangedOnesAlone) {
  SlamEvaluator evaluator(s_.data, model_, Options());
  const EvaluationPtr truth = evaluator.Refine(s_.truth, nullptr);
  const EvaluationPtr split = evaluator.Refine(SplitOffLastTrack(s_.truth), nullptr);
  const size_t solves = evaluator.num_solves();
  // The same state: nothing changes.
  const EvaluationPtr same = evaluator.Approximate(split->state, *split);
  ASSERT_NE(same, nullptr);
  EXPECT_EQ(same->log_target, split->log_target);
  EXPECT_EQ(same->locations, split->locations);
  EXPECT_EQ(same->residual2, split->residual2);
  // The merge back to the truth: within a nat of its solved target (the
  // poses' share of the change is missing), the unchanged objects kept.
  const EvaluationPtr merge = evaluator.Approximate(s_.truth, *split);
  ASSERT_NE(merge, nullptr);
  EXPECT_TRUE(merge->valid);
  EXPECT_EQ(merge->state, s_.truth);
  EXPECT_NEAR(merge->log_target, truth->log_target, 1.0);
  ASSERT_EQ(merge->locations.size(), s_.truth.blocks.size());
  for (size_t j = 0; j < s_.truth.blocks.size(); ++j) {
    EXPECT_LT((merge->locations[j] - truth->locations[j]).norm(), 0.05) << j;
    const int kept = split->state.BlockOf(s_.truth.blocks[j].front());
    if (split->state.blocks[kept] == s_.truth.blocks[j]) {
      EXPECT_EQ(merge->locations[j], split->locations[kept]) << j;
    }
  }
  // A wrong merge is approximated as far below the truth, as it is when solved.
  const EvaluationPtr wrong = evaluator.Approximate(Merge(s_.truth, 0, 1), *truth);
  ASSERT_NE(wrong, nullptr);
  EXPECT_LT(wrong->log_target, truth->log_target - 100.0);
  // No solve of the whole problem was needed, and nothing was cached.
  EXPECT_EQ(evaluator.num_solves(), solves);
  EXPECT_EQ(evaluator.num_cache_hits(), 0u);
  // Without a valid solution to start from there is no approximation.
  StateEvaluation unsolved = *split;
  unsolved.solution.reset();
  EXPECT_EQ(evaluator.Approximate(s_.truth, unsolved), nullptr);
  StateEvaluation invalid = *split;
  invalid.valid = false;
  EXPECT_EQ(evaluator.Approximate(s_.truth, invalid), nullptr);
}

// The objects' local values are kept while proposals come from one state;
// what is kept must be what a fresh evaluator computes.
// After LineariseAt every proposal is solved from the reference, so a
// state's value is the same whichever neighbour proposed it (docs/method.md
// §9.6); values cached before LineariseAt were linearised elsewhere and go.
TEST_F(SlamTargetTest, AfterLineariseAtAStatesValueDoesNotDependOnItsNeighbour) {
  SlamEvaluator solver(s_.data, model_, Options());
  const EvaluationPtr reference = solver.Refine(s_.truth, nullptr);
  const EvaluationPtr merged = solver.Refine(Merge(s_.truth, 0, 1), nullptr);
  const AssociationState split = SplitOffLastTrack(s_.truth);
  SlamEvaluator a(s_.data, model_, Options()), b(s_.data, model_, Options());
  const EvaluationPtr before = a.Evaluate(split, merged.get());
  a.LineariseAt(reference);
  b.LineariseAt(reference);
  const EvaluationPtr from_merged = a.Evaluate(split, merged.get());
  const EvaluationPtr from_truth = b.Evaluate(split, reference.get());
  ASSERT_TRUE(from_merged->valid && from_truth->valid);
  EXPECT_NE(from_merged, before);  // solved again
  EXPECT_EQ(from_merged->log_target, from_truth->log_target);
  EXPECT_EQ(from_merged->locations, from_truth->locations);
  EXPECT_EQ(from_merged->residual2, from_truth->residual2);
  // The reference itself is kept as it is.
  EXPECT_EQ(a.Evaluate(s_.truth, merged.get()), reference);

  // Linearised at the neighbour (the thesis), the two neighbours disagree.
  SlamTargetOptions thesis = Options();
  thesis.linearise_at_reference = false;
  SlamEvaluator c(s_.data, model_, thesis), d(s_.data, model_, thesis);
  c.LineariseAt(reference);
  d.LineariseAt(reference);
  const EvaluationPtr c_split = c.Evaluate(split, merged.get());
  const EvaluationPtr d_split = d.Evaluate(split, reference.get());
  EXPECT_NE(c_split->log_target, d_split->log_target);
  EXPECT_EQ(d_split->log_target, from_truth->log_target);
}

TEST_F(SlamTargetTest, TheApproximationIsTheSameRepeatedAndFromAFreshEvaluator) {
  SlamEvaluator evaluator(s_.data, model_, Options()), fresh(s_.data, model_, Options());
  const EvaluationPtr truth = evaluator.Refine(s_.truth, nullptr);
  const EvaluationPtr split = evaluator.Refine(SplitOffLastTrack(s_.truth), nullptr);
  const AssociationState wrong = Merge(s_.truth, 0, 1);
  const EvaluationPtr first = evaluator.Approximate(s_.truth, *split);
  const EvaluationPtr other = evaluator.Approximate(wrong, *truth);  // another state
  const EvaluationPtr again = evaluator.Approximate(s_.truth, *split);
  const EvaluationPtr from_fresh = fresh.Approximate(s_.truth, *split);
  ASSERT_TRUE(first && other && again && from_fresh);
  for (const EvaluationPtr& e : {again, from_fresh}) {
    EXPECT_EQ(e->log_target, first->log_target);
    EXPECT_EQ(e->locations, first->locations);
    EXPECT_EQ(e->residual2, first->residual2);
  }
  EXPECT_EQ(other->log_target, fresh.Approximate(wrong, *truth)->log_target);
}

TEST_F(SlamTargetTest, CompleteAddsCovariancesAtTheSameEstimateOnce) {
  SlamEvaluator full(s_.data, model_, Options()), evaluator(s_.data, model_, Options());
  const EvaluationPtr exact = full.Refine(s_.truth, nullptr);
  const EvaluationPtr split = full.Refine(SplitOffLastTrack(s_.truth), nullptr);
  const EvaluationPtr proposed = evaluator.Evaluate(s_.truth, split.get());
  ASSERT_FALSE(proposed->solution->has_object_covariances);
  const size_t solves = evaluator.num_solves();
  const EvaluationPtr completed = evaluator.Complete(proposed);
  EXPECT_EQ(evaluator.num_solves(), solves + 1);
  ASSERT_TRUE(completed->solution->has_object_covariances);
  // The estimate and its value are the proposal's, untouched.
  EXPECT_EQ(completed->log_target, proposed->log_target);
  EXPECT_EQ(completed->locations, proposed->locations);
  ASSERT_EQ(completed->solution->objects.size(), proposed->solution->objects.size());
  for (size_t j = 0; j < completed->solution->objects.size(); ++j) {
    const MappedObject& object = completed->solution->objects[j];
    EXPECT_EQ(object.geometry.base_world, proposed->solution->objects[j].geometry.base_world);
    // A covariance: symmetric, positive definite, and close to the full
    // solve's (the two estimates differ by millimetres).
    EXPECT_LT((object.covariance - object.covariance.transpose()).norm(), 1e-12);
    EXPECT_EQ(object.covariance.llt().info(), Eigen::Success) << j;
    const Eigen::Matrix<double, 5, 5>& reference = Object(*exact->solution, object.id)->covariance;
    EXPECT_LT((object.covariance - reference).norm(), 0.05 * reference.norm()) << j;
  }
  // The completed evaluation replaces the cached one; completing it again,
  // or a solve that has covariances already, costs nothing.
  EXPECT_EQ(evaluator.Evaluate(s_.truth, split.get()), completed);
  EXPECT_EQ(evaluator.Complete(completed), completed);
  EXPECT_EQ(evaluator.Complete(exact), exact);
  EXPECT_EQ(evaluator.Complete(nullptr), nullptr);
  EXPECT_EQ(evaluator.num_solves(), solves + 1);
}

TEST(SlamTargetOptionsTest, InvalidOptionsAreRefusedByName) {
  auto why = [](const SlamTargetOptions& options) {
    std::string message;
    EXPECT_FALSE(options.Validate(&message));
    return message;
  };
  EXPECT_TRUE(SlamTargetOptions().Validate(nullptr));
  SlamTargetOptions options;
  options.proposal_iterations = 0;
  EXPECT_EQ(why(options), "the solver iterations per proposal must be >= 1");
  options = {};
  options.max_cache_entries = 0;
  EXPECT_EQ(why(options), "the state cache needs room for at least one entry");
  // The geometric solver's own options are checked too.
  options = {};
  options.slam.pixel_std_px = -1.0;
  EXPECT_FALSE(options.Validate(nullptr));
  const SceneTracks s = MakeSceneTracks();
  const ClassConfusionModel model = s.Model();
  options = {};
  options.proposal_iterations = 0;
  try {
    SlamEvaluator evaluator(s.data, model, options);
    FAIL() << "invalid options were taken";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "O-SLAM target options: the solver iterations per proposal must be >= 1");
  }
}

}  // namespace
}  // namespace oslam

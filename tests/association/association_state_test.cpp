// The sampler's state (canonical form, hash), the class-confusion model and
// the evaluation cache with its roll-back journal (association_state.h).
#include "association/association_state.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "association/association_fixture.h"
#include "core/error.h"

namespace oslam {
namespace {

using testing::EnumerateStates;
using testing::TestModel;

TEST(AssociationStateTest, EnumerationCountsPartitionsTimesClasses) {
  // Bell(4) = 15 partitions; sum over partitions of 2^blocks = 2 + 28 + 48 + 16.
  EXPECT_EQ(EnumerateStates(4, 2).size(), 94u);
}

TEST(AssociationStateTest, CanonicalFormIsOrderFree) {
  AssociationState a{{{3, 1}, {0, 2}}, {1, 0}}, b{{{0, 2}, {1, 3}}, {0, 1}};
  a.Canonicalize();
  b.Canonicalize();
  EXPECT_EQ(a, b);
  EXPECT_EQ(AssociationStateHash()(a), AssociationStateHash()(b));
  EXPECT_EQ(a.ToString(), "{0,2}:0 {1,3}:1");
  EXPECT_EQ(a.BlockOf(3), 1);
}

TEST(AssociationStateTest, CanonicalizeSortsTracksAndDropsEmptyObjects) {
  AssociationState s{{{3, 1}, {}, {2, 0}}, {1, 0, 1}};
  s.Canonicalize();
  EXPECT_EQ(s.blocks, (std::vector<std::vector<int>>{{0, 2}, {1, 3}}));
  EXPECT_EQ(s.classes, (std::vector<int>{1, 1}));
  EXPECT_EQ(s.num_tracks(), 4u);
  EXPECT_EQ(s.BlockOf(0), 0);
  EXPECT_EQ(s.BlockOf(1), 1);
  EXPECT_EQ(s.BlockOf(7), -1);
  AssociationState empty;
  empty.Canonicalize();
  EXPECT_EQ(empty.ToString(), "");
  EXPECT_EQ(empty.num_tracks(), 0u);
}

// Moving a track re-places only the objects it leaves and joins: the same
// state as moving it and canonicalising everything, for every move of every
// state of the test problem.
TEST(AssociationStateTest, MovingATrackKeepsTheStateCanonical) {
  int moves = 0;
  for (const AssociationState& s : EnumerateStates(4, 2))
    for (int track = 0; track < 4; ++track)
      for (int target = -1; target < static_cast<int>(s.blocks.size()); ++target)
        for (int c = 0; c < 2; ++c) {
          AssociationState expected = s;
          const int from = s.BlockOf(track);
          auto& block = expected.blocks[from];
          block.erase(std::find(block.begin(), block.end(), track));
          if (target >= 0) {
            expected.blocks[target].push_back(track);
            expected.classes[target] = c;
          } else {
            expected.blocks.push_back({track});
            expected.classes.push_back(c);
          }
          expected.Canonicalize();
          EXPECT_EQ(s.WithTrackMoved(track, target, c), expected) << s.ToString() << " " << track;
          ++moves;
        }
  EXPECT_GT(moves, 1000);
}

// Merging two objects in place gives the canonical state, the earlier's class kept.
TEST(AssociationStateTest, MergingObjectsKeepsTheStateCanonical) {
  const AssociationState s{{{0, 4}, {1}, {2, 5}, {3}}, {1, 0, 2, 0}};
  for (const auto& [a, b] : std::vector<std::pair<int, int>>{{0, 2}, {2, 0}, {1, 3}, {3, 0}}) {
    AssociationState expected = s;
    expected.blocks[a].insert(expected.blocks[a].end(), s.blocks[b].begin(), s.blocks[b].end());
    expected.classes[a] = s.classes[std::min(a, b)];
    expected.blocks[b].clear();
    expected.Canonicalize();
    EXPECT_EQ(s.WithBlocksMerged(a, b), expected) << a << " " << b;
  }
  EXPECT_EQ(s.WithBlocksMerged(0, 2).ToString(), "{0,2,4,5}:1 {1}:0 {3}:0");
  EXPECT_THROW(s.WithBlocksMerged(1, 1), Error);
}

// Equal states hash equal (above); here the 94 different ones of the test
// problem, some differing only in a class, all hash differently.
TEST(AssociationStateTest, DifferentStatesHashDifferently) {
  std::unordered_set<size_t> hashes;
  for (const AssociationState& s : EnumerateStates(4, 2)) hashes.insert(AssociationStateHash()(s));
  EXPECT_EQ(hashes.size(), 94u);
}

TEST(AssociationStateTest, SeparateTracksStartsWithTheDetectedClasses) {
  const AssociationState s = SeparateTracksState({2, 0, 1});
  EXPECT_EQ(s.ToString(), "{0}:2 {1}:0 {2}:1");
  AssociationState canonical = s;
  canonical.Canonicalize();
  EXPECT_EQ(canonical, s);
}

// P(a | c) floored at `floor`, rows renormalised; a track counts its size
// times.
TEST(ClassConfusionModelTest, FloorsRenormalisesAndWeighsByTrackSize) {
  const ClassConfusionModel model({{1.0, 0.0}, {0.5, 0.5}}, 0.1, {1, 0}, {2, 3});
  EXPECT_EQ(model.num_classes(), 2);
  EXPECT_EQ(model.num_tracks(), 2);
  EXPECT_EQ(model.track_class(0), 1);
  EXPECT_EQ(model.track_size(1), 3);
  // Row 0: (1, 0.1) / 1.1; row 1 unchanged.
  EXPECT_NEAR(model.BlockLogLikelihood({0}, 0), 2 * std::log(0.1 / 1.1), 1e-12);
  EXPECT_NEAR(model.BlockLogLikelihood({1}, 0), 3 * std::log(1.0 / 1.1), 1e-12);
  EXPECT_NEAR(model.BlockLogLikelihood({0, 1}, 1), 5 * std::log(0.5), 1e-12);
  EXPECT_EQ(model.BlockLogLikelihood({}, 1), 0.0);

  const ClassConfusionModel identity = ClassConfusionModel::Identity(3, 0.01, {2}, {1});
  EXPECT_NEAR(identity.BlockLogLikelihood({0}, 2), std::log(1.0 / 1.02), 1e-12);
  EXPECT_NEAR(identity.BlockLogLikelihood({0}, 0), std::log(0.01 / 1.02), 1e-12);
}

TEST(ClassConfusionModelTest, ClassProposalIsNormalised) {
  const ClassConfusionModel model = TestModel();
  for (const std::vector<int>& block :
       {std::vector<int>{0}, std::vector<int>{2}, std::vector<int>{0, 1, 2, 3}}) {
    const std::vector<double> log_q = model.ClassLogProposal(block);
    ASSERT_EQ(log_q.size(), 2u);
    EXPECT_NEAR(std::exp(log_q[0]) + std::exp(log_q[1]), 1.0, 1e-12);
    // The ratio is the likelihood ratio of the block's detections.
    EXPECT_NEAR(log_q[0] - log_q[1],
                model.BlockLogLikelihood(block, 0) - model.BlockLogLikelihood(block, 1), 1e-12);
  }
}

TEST(ClassConfusionModelTest, RejectsInconsistentInput) {
  EXPECT_THROW(ClassConfusionModel({}, 0.1, {}, {}), Error);
  EXPECT_THROW(ClassConfusionModel({{1.0, 0.0}}, 0.1, {}, {}), Error);              // not square
  EXPECT_THROW(ClassConfusionModel({{1.0, 0.0}, {0.0, 1.0}}, 1.0, {}, {}), Error);  // floor
  EXPECT_THROW(ClassConfusionModel({{1.0, 0.0}, {0.0, 1.0}}, -0.1, {}, {}), Error);
  EXPECT_THROW(ClassConfusionModel({{0.0, 0.0}, {0.0, 1.0}}, 0.0, {}, {}), Error);  // empty row
  EXPECT_THROW(ClassConfusionModel({{1.0, 0.0}, {0.0, 1.0}}, 0.1, {0, 1}, {1}), Error);
  EXPECT_THROW(ClassConfusionModel({{1.0, 0.0}, {0.0, 1.0}}, 0.1, {2}, {1}), Error);
  EXPECT_THROW(ClassConfusionModel({{1.0, 0.0}, {0.0, 1.0}}, 0.1, {-1}, {1}), Error);
}

TEST(ClassConfusionModelTest, ClassProposalFollowsTheConfusionProduct) {
  const ClassConfusionModel model = TestModel();
  // Tracks 0 (3 x class 0) and 2 (3 x class 1): q(0) ∝ 0.8^3 0.2^3, q(1) ∝ 0.3^3 0.7^3.
  const std::vector<double> q = model.ClassLogProposal({0, 2});
  const double p0 = std::pow(0.8 * 0.2, 3), p1 = std::pow(0.3 * 0.7, 3);
  EXPECT_NEAR(std::exp(q[0]), p0 / (p0 + p1), 1e-3);  // the 1e-3 floor shifts it slightly
}

// Going back to a mark restores the entries (also across a clear of a full
// cache) and the counters; a released mark is refused.
TEST(EvaluationCacheTest, RollBackRestoresEntriesAndCounters) {
  auto evaluation = [](std::vector<std::vector<int>> blocks, double log_target) {
    auto e = std::make_shared<StateEvaluation>();
    e->state.blocks = std::move(blocks);
    e->state.classes.assign(e->state.blocks.size(), 0);
    e->state.Canonicalize();
    e->valid = true;
    e->log_target = log_target;
    return EvaluationPtr(e);
  };
  const EvaluationPtr a = evaluation({{0}, {1}, {2}}, 1.0);
  const EvaluationPtr a_refined = evaluation({{0}, {1}, {2}}, 1.5);
  const EvaluationPtr b = evaluation({{0, 1}, {2}}, 2.0);
  const EvaluationPtr c = evaluation({{0, 2}, {1}}, 3.0);
  const EvaluationPtr d = evaluation({{0, 1, 2}}, 4.0);
  EvaluationCache cache(3);
  cache.Store(a);
  cache.CountSolve();
  EXPECT_EQ(cache.Find(a->state), a);
  const size_t mark = cache.Mark();
  cache.Store(b);
  cache.CountSolve();
  cache.Store(a_refined);  // replaces a
  EXPECT_EQ(cache.Find(b->state), b);
  cache.Store(c);
  cache.Store(d);  // full: cleared first
  EXPECT_EQ(cache.size(), 1u);
  EXPECT_EQ(cache.solves(), 2u);
  EXPECT_EQ(cache.hits(), 2u);
  cache.RollBack(mark);
  EXPECT_EQ(cache.size(), 1u);
  EXPECT_EQ(cache.solves(), 1u);
  EXPECT_EQ(cache.hits(), 1u);
  EXPECT_EQ(cache.Find(a->state), a);
  EXPECT_EQ(cache.Find(b->state), nullptr);
  EXPECT_EQ(cache.Find(d->state), nullptr);

  const size_t before_b = cache.Mark();
  cache.Store(b);
  const size_t before_c = cache.Mark();
  cache.Store(c);
  cache.Release(before_c);
  EXPECT_THROW(cache.RollBack(before_b), Error);
  cache.RollBack(before_c);
  EXPECT_EQ(cache.Find(b->state), b);
  EXPECT_EQ(cache.Find(c->state), nullptr);
}

EvaluationPtr CachedEvaluation(std::vector<std::vector<int>> blocks, double log_target) {
  auto e = std::make_shared<StateEvaluation>();
  e->state.blocks = std::move(blocks);
  e->state.classes.assign(e->state.blocks.size(), 0);
  e->state.Canonicalize();
  e->valid = true;
  e->log_target = log_target;
  return e;
}

// Without marks: a hit is counted only when found, a store replaces the
// state's entry, and a full cache is cleared before the next new entry.
TEST(EvaluationCacheTest, FindsReplacesAndClearsWhenFull) {
  EvaluationCache cache(2);
  const EvaluationPtr a = CachedEvaluation({{0}, {1}}, 1.0);
  const EvaluationPtr a_refined = CachedEvaluation({{0}, {1}}, 2.0);
  const EvaluationPtr b = CachedEvaluation({{0, 1}}, 3.0);
  const EvaluationPtr c = CachedEvaluation({{1}, {0}, {2}}, 4.0);
  EXPECT_EQ(cache.Find(a->state), nullptr);
  EXPECT_EQ(cache.hits(), 0u);
  cache.Store(a);
  cache.Store(a_refined);
  EXPECT_EQ(cache.size(), 1u);
  EXPECT_EQ(cache.Find(a->state), a_refined);
  EXPECT_EQ(cache.hits(), 1u);
  cache.Store(b);
  EXPECT_EQ(cache.size(), 2u);
  cache.Store(c);  // full: cleared first
  EXPECT_EQ(cache.size(), 1u);
  EXPECT_EQ(cache.Find(a->state), nullptr);
  EXPECT_EQ(cache.Find(c->state), c);
  EXPECT_EQ(cache.hits(), 2u);
  EXPECT_EQ(cache.solves(), 0u);
  cache.CountSolve();
  EXPECT_EQ(cache.solves(), 1u);
}

}  // namespace
}  // namespace oslam

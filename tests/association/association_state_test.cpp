// The sampler's state (canonical form, hash), the class-confusion model and
// the evaluation cache with its roll-back journal (association_state.h).
#include "association/association_state.h"

#include <cmath>

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

}  // namespace
}  // namespace oslam

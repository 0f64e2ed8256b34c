#include "solver/linearization.h"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "tests/solver/linear_factor.h"

namespace oslam {
namespace {

using testing::LinearFactor;

// A linear factor that counts its linearisations and can be made to fail.
struct CountingFactor : LinearFactor {
  using LinearFactor::LinearFactor;
  bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                 Eigen::MatrixXd* jacobian) const override {
    ++calls;
    return !fail && LinearFactor::Linearize(values, error, jacobian);
  }
  mutable int calls = 0;
  bool fail = false;
};

// Two scalar variables; a reading of each (slots 0 and 1) and of their
// difference (no slot).
struct Problem {
  FactorGraph graph;
  CountingFactor* first;
  CountingFactor* second;
  CountingFactor* difference;
  Evaluation evaluation;

  Problem() {
    const int a = graph.AddVariable(Eigen::VectorXd::Constant(1, 1.0));
    const int b = graph.AddVariable(Eigen::VectorXd::Constant(1, 3.0));
    const Eigen::MatrixXd one = Eigen::MatrixXd::Identity(1, 1);
    first = graph.Emplace<CountingFactor>(std::vector<int>{a}, one, Eigen::VectorXd::Zero(1), 0.5);
    second = graph.Emplace<CountingFactor>(std::vector<int>{b}, one, Eigen::VectorXd::Zero(1), 1.0);
    difference =
        graph.Emplace<CountingFactor>(std::vector<int>{a, b}, Eigen::RowVector2d(-1.0, 1.0).eval(),
                                      Eigen::VectorXd::Constant(1, 1.5), 1.0);
    first->set_linearization_slot(0);
    second->set_linearization_slot(1);
    evaluation.Resize(3);
    evaluation.Shape(0, 1, 1);
    evaluation.Shape(1, 1, 1);
    evaluation.Shape(2, 1, 2);
  }
};

TEST(LinearizerTest, EvaluatesEveryFactorAndHalfTheSquaredError) {
  Problem p;
  Linearizer linearizer;
  double cost = 0.0;
  ASSERT_TRUE(linearizer.Evaluate(p.graph, p.graph.values(), true, &p.evaluation, &cost));
  // Errors: 1 / 0.5 = 2, 3, (3 - 1 - 1.5) = 0.5.
  EXPECT_EQ(p.evaluation.errors[0][0], 2.0);
  EXPECT_EQ(p.evaluation.errors[1][0], 3.0);
  EXPECT_EQ(p.evaluation.errors[2][0], 0.5);
  EXPECT_EQ(p.evaluation.jacobians[0](0, 0), 2.0);
  EXPECT_EQ(p.evaluation.jacobians[2], Eigen::RowVector2d(-1.0, 1.0));
  EXPECT_EQ(cost, 0.5 * (4.0 + 9.0 + 0.25));
  EXPECT_EQ(linearizer.computed(), 3);
  EXPECT_EQ(linearizer.reused(), 0);
}

TEST(LinearizerTest, ReusesAKeptLinearizationWhereTheValuesAreBitwiseUnchanged) {
  Problem p;
  Linearizer linearizer;
  linearizer.set_reuse(true);
  double cost = 0.0;
  ASSERT_TRUE(linearizer.Evaluate(p.graph, p.graph.values(), true, &p.evaluation, &cost));
  const Evaluation fresh = p.evaluation;
  p.evaluation.errors[0].setZero();  // overwritten by the copy
  double again = 0.0;
  ASSERT_TRUE(linearizer.Evaluate(p.graph, p.graph.values(), true, &p.evaluation, &again));
  EXPECT_EQ(again, cost);
  EXPECT_EQ(p.evaluation.errors[0], fresh.errors[0]);
  EXPECT_EQ(p.evaluation.jacobians[0], fresh.jacobians[0]);
  EXPECT_EQ(p.first->calls, 1);
  EXPECT_EQ(p.second->calls, 1);
  EXPECT_EQ(p.difference->calls, 2);  // no slot: always linearised
  EXPECT_EQ(linearizer.reused(), 2);
  EXPECT_EQ(linearizer.computed(), 4);

  // One bit more in a: only its reading is linearised again.
  Values moved = p.graph.values();
  moved.MutableData(0)[0] = std::nextafter(1.0, 2.0);
  linearizer.ResetCounts();
  ASSERT_TRUE(linearizer.Evaluate(p.graph, moved, true, &p.evaluation, &again));
  EXPECT_EQ(p.first->calls, 2);
  EXPECT_EQ(p.second->calls, 1);
  EXPECT_EQ(linearizer.reused(), 1);
  EXPECT_EQ(linearizer.computed(), 2);
  EXPECT_NE(p.evaluation.errors[0], fresh.errors[0]);
}

TEST(LinearizerTest, ReusesNothingWhenOffWithoutJacobiansOrAfterForgetting) {
  Problem p;
  Linearizer off;
  double cost = 0.0;
  for (int i = 0; i < 2; ++i)
    ASSERT_TRUE(off.Evaluate(p.graph, p.graph.values(), true, &p.evaluation, &cost));
  EXPECT_EQ(off.reused(), 0);
  EXPECT_EQ(p.first->calls, 2);

  Linearizer on;
  on.set_reuse(true);
  // Cost-only evaluations neither keep nor reuse (nor count as linearised).
  ASSERT_TRUE(on.Evaluate(p.graph, p.graph.values(), false, &p.evaluation, &cost));
  ASSERT_TRUE(on.Evaluate(p.graph, p.graph.values(), true, &p.evaluation, &cost));
  EXPECT_EQ(on.reused(), 0);
  EXPECT_EQ(on.computed(), 3);
  ASSERT_TRUE(on.Evaluate(p.graph, p.graph.values(), false, &p.evaluation, &cost));
  EXPECT_EQ(on.reused(), 0);
  on.Forget();
  ASSERT_TRUE(on.Evaluate(p.graph, p.graph.values(), true, &p.evaluation, &cost));
  EXPECT_EQ(on.reused(), 0);
  ASSERT_TRUE(on.Evaluate(p.graph, p.graph.values(), true, &p.evaluation, &cost));
  EXPECT_EQ(on.reused(), 2);
  on.Clear();
  on.ResetCounts();
  ASSERT_TRUE(on.Evaluate(p.graph, p.graph.values(), true, &p.evaluation, &cost));
  EXPECT_EQ(on.reused(), 0);
}

TEST(LinearizerTest, FailsWhenAFactorCannotBeEvaluatedOrTheCostIsNotFinite) {
  Problem p;
  Linearizer linearizer;
  double cost = 0.0;
  p.second->fail = true;
  EXPECT_FALSE(linearizer.Evaluate(p.graph, p.graph.values(), true, &p.evaluation, &cost));
  p.second->fail = false;
  Values infinite = p.graph.values();
  infinite.MutableData(1)[0] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(linearizer.Evaluate(p.graph, infinite, false, &p.evaluation, &cost));
}

// A graph large enough for threads (kParallelFactors and more): a chain of
// scalar variables, a reading of each and of each difference.
struct Chain {
  FactorGraph graph;
  std::vector<CountingFactor*> factors;
  Evaluation evaluation;

  explicit Chain(int length) {
    for (int i = 0; i < length; ++i)
      graph.AddVariable(Eigen::VectorXd::Constant(1, std::sin(0.1 * i)));
    const Eigen::MatrixXd one = Eigen::MatrixXd::Identity(1, 1);
    for (int i = 0; i < length; ++i) {
      factors.push_back(graph.Emplace<CountingFactor>(std::vector<int>{i}, one,
                                                      Eigen::VectorXd::Constant(1, 0.01 * i), 0.5));
      if (i > 0)
        factors.push_back(graph.Emplace<CountingFactor>(std::vector<int>{i - 1, i},
                                                        Eigen::RowVector2d(-1.0, 1.0).eval(),
                                                        Eigen::VectorXd::Constant(1, 0.1), 0.3));
    }
    evaluation.Resize(factors.size());
    for (size_t f = 0; f < factors.size(); ++f)
      evaluation.Shape(f, 1, static_cast<int>(factors[f]->keys().size()));
  }
};

// On threads every factor is linearised once, into its own slot, and the
// cost summed in factor order: the same bits as on one thread; a factor
// that cannot be evaluated fails the evaluation there too.
TEST(LinearizerTest, ThreadsGiveTheSameBitsOnALargeGraph) {
  const int length = static_cast<int>(Linearizer::kParallelFactors);  // 2 length - 1 factors
  Chain serial_chain(length), threaded_chain(length);
  Linearizer serial, threaded;
  threaded.set_threads(3);
  double serial_cost = 0, threaded_cost = 0;
  ASSERT_TRUE(serial.Evaluate(serial_chain.graph, serial_chain.graph.values(), true,
                              &serial_chain.evaluation, &serial_cost));
  ASSERT_TRUE(threaded.Evaluate(threaded_chain.graph, threaded_chain.graph.values(), true,
                                &threaded_chain.evaluation, &threaded_cost));
  EXPECT_EQ(threaded_cost, serial_cost);
  EXPECT_GT(serial_cost, 0.0);
  EXPECT_EQ(threaded.computed(), serial.computed());
  EXPECT_EQ(threaded.computed(), 2 * length - 1);
  for (size_t f = 0; f < serial_chain.factors.size(); ++f) {
    ASSERT_EQ(threaded_chain.factors[f]->calls, 1) << f;
    ASSERT_EQ(threaded_chain.evaluation.errors[f], serial_chain.evaluation.errors[f]) << f;
    ASSERT_EQ(threaded_chain.evaluation.jacobians[f], serial_chain.evaluation.jacobians[f]) << f;
  }
  threaded_chain.factors[length]->fail = true;
  EXPECT_FALSE(threaded.Evaluate(threaded_chain.graph, threaded_chain.graph.values(), false,
                                 &threaded_chain.evaluation, &threaded_cost));
}

TEST(SquaredNormTest, EqualsEigensForEverySize) {
  for (int size = 1; size <= 6; ++size) {
    const Eigen::VectorXd error = Eigen::VectorXd::LinSpaced(size, -0.3, 1.7);
    EXPECT_EQ(SquaredNorm(error), error.squaredNorm()) << size;
  }
}

}  // namespace
}  // namespace oslam

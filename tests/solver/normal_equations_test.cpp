#include "solver/normal_equations.h"

#include <algorithm>
#include <cstdlib>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "tests/solver/linear_factor.h"

namespace oslam {
namespace {

using testing::LinearFactor;

// Variables 0 (2 entries, fixed), 1 (2), 2 (1), 3 (3); a prior on each
// free one and factors linking {0, 1}, {2, 3} and, unless `sparser`,
// {1, 2, 3}. Fixed pseudo-random coefficients.
FactorGraph MixedGraph(bool sparser = false) {
  FactorGraph graph;
  graph.AddVariable(Eigen::Vector2d(0.5, -0.2), -1, /*fixed=*/true);
  graph.AddVariable(Eigen::Vector2d(0.1, 0.3));
  graph.AddVariable(Eigen::VectorXd::Constant(1, -0.4));
  graph.AddVariable(Eigen::Vector3d(0.2, 0.0, 0.7));
  std::srand(7);
  auto add = [&](const std::vector<int>& keys, int rows, double sigma) {
    int columns = 0;
    for (int key : keys) columns += graph.values().Dim(key);
    graph.Emplace<LinearFactor>(keys, Eigen::MatrixXd::Random(rows, columns),
                                Eigen::VectorXd::Random(rows), sigma);
  };
  add({1}, 2, 0.5);
  add({2}, 1, 1.0);
  add({3}, 3, 2.0);
  add({0, 1}, 2, 0.3);
  if (!sparser) add({1, 2, 3}, 3, 0.7);
  add({2, 3}, 2, 1.5);
  return graph;
}

// The whitened J (free variables' columns, in key order) and e, densely.
void DenseSystem(const FactorGraph& graph, Eigen::MatrixXd* j, Eigen::VectorXd* e) {
  std::vector<int> offset;
  int n = 0, m = 0;
  for (int key = 0; key < graph.num_variables(); ++key) {
    offset.push_back(graph.IsFixed(key) ? -1 : n);
    if (!graph.IsFixed(key)) n += graph.values().Dim(key);
  }
  for (const auto& factor : graph.factors()) m += factor->Dimension();
  j->setZero(m, n);
  e->resize(m);
  int row = 0;
  for (const auto& factor : graph.factors()) {
    int columns = 0;
    for (int key : factor->keys()) columns += graph.values().Dim(key);
    Eigen::VectorXd error(factor->Dimension());
    Eigen::MatrixXd jacobian(factor->Dimension(), columns);
    ASSERT_TRUE(factor->Linearize(graph.values(), error, &jacobian));
    int column = 0;
    for (int key : factor->keys()) {
      const int d = graph.values().Dim(key);
      if (offset[key] >= 0)
        j->block(row, offset[key], error.size(), d) = jacobian.middleCols(column, d);
      column += d;
    }
    e->segment(row, error.size()) = error;
    row += factor->Dimension();
  }
}

// Sets up `normal` for `graph` and assembles it at the graph's values.
struct Assembled {
  Evaluation evaluation;
  bool reused = false;
};
Assembled SetUpAndAssemble(NormalEquations* normal, const FactorGraph& graph,
                           bool independent_of_history = false,
                           OrderingType ordering = OrderingType::kAutomatic) {
  Assembled out;
  double analyze_s = 0.0;
  std::string why;
  EXPECT_TRUE(
      normal->SetUp(graph, ordering, independent_of_history, true, &out.reused, &analyze_s, &why))
      << why;
  const ProblemLayout& layout = normal->layout();
  out.evaluation.Resize(graph.factors().size());
  for (size_t f = 0; f < graph.factors().size(); ++f)
    out.evaluation.Shape(f, layout.factor_rows(f), layout.factor_columns[f]);
  Linearizer linearizer;
  double cost = 0.0;
  EXPECT_TRUE(linearizer.Evaluate(graph, graph.values(), true, &out.evaluation, &cost));
  EXPECT_TRUE(normal->Assemble(out.evaluation));
  return out;
}

// The damped system's solution against a dense one.
void ExpectSolvesDensely(NormalEquations* normal, const FactorGraph& graph, double lambda) {
  Eigen::MatrixXd j;
  Eigen::VectorXd e;
  DenseSystem(graph, &j, &e);
  const Eigen::MatrixXd h = j.transpose() * j;
  const Eigen::VectorXd g = j.transpose() * e;
  EXPECT_LT((normal->gradient() - g).lpNorm<Eigen::Infinity>(), 1e-12);
  EXPECT_LT((normal->diagonal() - h.diagonal()).lpNorm<Eigen::Infinity>(), 1e-12);
  SolverOptions options;
  options.min_diagonal = 0.9;  // clamps some of diag(H)
  Eigen::VectorXd d(h.rows());
  for (int c = 0; c < d.size(); ++c) d[c] = std::max(h(c, c), options.min_diagonal);
  ASSERT_TRUE(normal->Factorize(lambda, options));
  Eigen::VectorXd x;
  ASSERT_TRUE(normal->Solve(g, &x));
  const Eigen::VectorXd expected = (h + lambda * Eigen::MatrixXd(d.asDiagonal())).ldlt().solve(g);
  EXPECT_LT((x - expected).lpNorm<Eigen::Infinity>(), 1e-10 * (1 + expected.norm()));
}

TEST(NormalEquationsTest, AssemblesAndSolvesTheDampedNormalEquations) {
  const FactorGraph graph = MixedGraph();
  NormalEquations normal;
  SetUpAndAssemble(&normal, graph);
  EXPECT_EQ(normal.pattern().n, 6);
  EXPECT_EQ(normal.layout().m, 13);
  EXPECT_NE(normal.ordering_used(), OrderingType::kAutomatic);
  for (double lambda : {0.0, 1e-3, 10.0}) ExpectSolvesDensely(&normal, graph, lambda);
}

TEST(NormalEquationsTest, ReusesTheStructureForTheSameGraphAndForSubPatterns) {
  NormalEquations normal;
  const FactorGraph full = MixedGraph();
  EXPECT_FALSE(SetUpAndAssemble(&normal, full).reused);
  const int generation = normal.layout_generation();
  EXPECT_TRUE(SetUpAndAssemble(&normal, full).reused);
  EXPECT_EQ(normal.layout_generation(), generation);  // the same layout
  // The sparser pattern fits in the kept one: assembled into it, the
  // missing blocks zero, and solved alike.
  const FactorGraph sparser = MixedGraph(/*sparser=*/true);
  EXPECT_TRUE(SetUpAndAssemble(&normal, sparser).reused);
  EXPECT_NE(normal.layout_generation(), generation);  // laid out anew
  ExpectSolvesDensely(&normal, sparser, 0.0);
  // Not when the solve must not depend on the solves before it,
  EXPECT_FALSE(SetUpAndAssemble(&normal, sparser, /*independent_of_history=*/true).reused);
  ExpectSolvesDensely(&normal, sparser, 0.0);
  // ... nor for another ordering, or after Clear.
  EXPECT_FALSE(SetUpAndAssemble(&normal, sparser, true, OrderingType::kMetis).reused);
  EXPECT_EQ(normal.ordering_used(), OrderingType::kMetis);
  normal.Clear();
  EXPECT_FALSE(SetUpAndAssemble(&normal, sparser, true, OrderingType::kMetis).reused);
  // A larger pattern than the kept one needs a new analysis.
  EXPECT_FALSE(SetUpAndAssemble(&normal, full, true, OrderingType::kMetis).reused);
  ExpectSolvesDensely(&normal, full, 1e-3);
}

TEST(NormalEquationsTest, ASingularSystemFailsToFactorUndampedOnly) {
  // Two scalars seen only through their difference.
  FactorGraph graph;
  graph.AddVariable(Eigen::VectorXd::Constant(1, 1.0));
  graph.AddVariable(Eigen::VectorXd::Constant(1, 2.0));
  testing::AddScalarReading(&graph, {0, 1}, {-1.0, 1.0}, 0.5, 1.0);
  NormalEquations normal;
  SetUpAndAssemble(&normal, graph);
  const SolverOptions options;
  EXPECT_FALSE(normal.Factorize(0.0, options));
  EXPECT_TRUE(normal.Factorize(1e-3, options));
}

TEST(NormalEquationsTest, SetUpReportsGraphsThatCannotBeSolved) {
  NormalEquations normal;
  bool reused = false;
  double analyze_s = 0.0;
  std::string why;
  FactorGraph fixed_only;
  fixed_only.AddVariable(Eigen::VectorXd::Zero(1), -1, true);
  EXPECT_FALSE(
      normal.SetUp(fixed_only, OrderingType::kAutomatic, false, true, &reused, &analyze_s, &why));
  EXPECT_NE(why.find("no free variable"), std::string::npos) << why;
}

}  // namespace
}  // namespace oslam

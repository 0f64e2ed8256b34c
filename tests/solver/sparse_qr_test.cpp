#include "solver/sparse_qr.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "solver/normal_equations.h"
#include "tests/solver/linear_factor.h"

namespace oslam {
namespace {

using testing::LinearFactor;

// Three free variables (2, 1, 3 entries) and a fixed one, linked by
// linear factors with fixed pseudo-random coefficients; the whitened J and
// e densely, and the layout and J^T J's diagonal from the normal
// equations (as the solver hands them to the QR back end).
struct Problem {
  FactorGraph graph;
  Eigen::MatrixXd j;
  Eigen::VectorXd e;
  NormalEquations normal;
  Evaluation evaluation;

  explicit Problem(bool singular = false) {
    graph.AddVariable(Eigen::Vector2d(0.1, 0.3));
    graph.AddVariable(Eigen::VectorXd::Constant(1, -0.4));
    graph.AddVariable(Eigen::Vector3d(0.2, 0.0, 0.7));
    graph.AddVariable(Eigen::Vector2d(1.0, 1.0), -1, /*fixed=*/true);
    std::srand(11);
    j.setZero(singular ? 3 : 11, 6);
    e.resize(j.rows());
    int row = 0;
    auto add = [&](const std::vector<int>& keys, const std::vector<int>& offsets, int rows) {
      int columns = 0;
      for (int key : keys) columns += graph.values().Dim(key);
      const Eigen::MatrixXd a = Eigen::MatrixXd::Random(rows, columns);
      const Eigen::VectorXd z = Eigen::VectorXd::Random(rows);
      graph.Emplace<LinearFactor>(keys, a, z, 0.5);
      int column = 0;
      Eigen::VectorXd predicted = -z;
      for (size_t k = 0; k < keys.size(); ++k) {
        const int d = graph.values().Dim(keys[k]);
        predicted += a.middleCols(column, d) * graph.values().Get(keys[k]);
        if (offsets[k] >= 0) j.block(row, offsets[k], rows, d) = a.middleCols(column, d) / 0.5;
        column += d;
      }
      e.segment(row, rows) = predicted / 0.5;
      row += rows;
    };
    if (singular) {
      add({0, 1, 2}, {0, 2, 3}, 3);  // 3 rows, 6 unknowns
    } else {
      add({0}, {0}, 2);
      add({1, 2}, {2, 3}, 3);
      add({2, 3}, {3, -1}, 4);
      add({0, 2}, {0, 3}, 2);
    }
    bool reused = false;
    double analyze_s = 0.0;
    std::string why;
    EXPECT_TRUE(
        normal.SetUp(graph, OrderingType::kAutomatic, false, true, &reused, &analyze_s, &why))
        << why;
    evaluation.Resize(graph.factors().size());
    for (size_t f = 0; f < graph.factors().size(); ++f)
      evaluation.Shape(f, normal.layout().factor_rows(f), normal.layout().factor_columns[f]);
    Linearizer linearizer;
    double cost = 0.0;
    EXPECT_TRUE(linearizer.Evaluate(graph, graph.values(), true, &evaluation, &cost));
    EXPECT_TRUE(normal.Assemble(evaluation));
  }
};

TEST(SparseQrTest, UndampedStepResidualAndDeterminantEqualDenseLeastSquares) {
  Problem p;
  ASSERT_EQ(p.normal.pattern().n, 6);
  SparseQr qr;
  Eigen::VectorXd delta;
  double squared_residual = 0.0, log_abs_det_r = 0.0;
  ASSERT_TRUE(qr.Solve(p.normal.layout(), 6, p.evaluation, p.normal.diagonal(), 0.0,
                       SolverOptions(), &delta, &squared_residual, &log_abs_det_r));
  const Eigen::VectorXd expected = p.j.colPivHouseholderQr().solve(-p.e);
  EXPECT_LT((delta - expected).lpNorm<Eigen::Infinity>(), 1e-10);
  EXPECT_NEAR(squared_residual, (p.j * expected + p.e).squaredNorm(), 1e-10);
  const double log_det_information =
      std::log((p.j.transpose() * p.j).determinant());  // = 2 log |det R|
  EXPECT_NEAR(2.0 * log_abs_det_r, log_det_information, 1e-10);
}

TEST(SparseQrTest, DampedStepSolvesTheDampedNormalEquations) {
  Problem p;
  SparseQr qr;
  SolverOptions options;
  options.min_diagonal = 2.0;  // clamps some of diag(J^T J)
  const double lambda = 0.3;
  Eigen::VectorXd delta;
  ASSERT_TRUE(qr.Solve(p.normal.layout(), 6, p.evaluation, p.normal.diagonal(), lambda, options,
                       &delta, nullptr, nullptr));
  const Eigen::MatrixXd h = p.j.transpose() * p.j;
  Eigen::VectorXd d = h.diagonal();
  for (int c = 0; c < d.size(); ++c) d[c] = std::max(d[c], options.min_diagonal);
  const Eigen::VectorXd expected =
      (h + lambda * Eigen::MatrixXd(d.asDiagonal())).ldlt().solve(-p.j.transpose() * p.e);
  EXPECT_LT((delta - expected).lpNorm<Eigen::Infinity>(), 1e-10);
}

TEST(SparseQrTest, FailsOnARankDeficientJacobianUnlessDamped) {
  Problem p(/*singular=*/true);
  SparseQr qr;
  Eigen::VectorXd delta;
  EXPECT_FALSE(qr.Solve(p.normal.layout(), 6, p.evaluation, p.normal.diagonal(), 0.0,
                        SolverOptions(), &delta, nullptr, nullptr));
  EXPECT_TRUE(qr.Solve(p.normal.layout(), 6, p.evaluation, p.normal.diagonal(), 1e-2,
                       SolverOptions(), &delta, nullptr, nullptr));
}

}  // namespace
}  // namespace oslam

#include "solver/evidence.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <cholmod.h>
#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "core/angles.h"
#include "solver/sparse_solver.h"
#include "tests/solver/cholmod_workspace.h"
#include "tests/solver/linear_factor.h"

namespace oslam {
namespace {

using testing::AddScalarReading;

const double kLog2Pi = std::log(2.0 * kPi);

// log N(x; 0, variance).
double LogNormal(double x, double variance) {
  return -0.5 * std::log(2.0 * kPi * variance) - 0.5 * x * x / variance;
}

constexpr LinearSolverType kBackEnds[] = {LinearSolverType::kSparseCholesky,
                                          LinearSolverType::kSparseQR};

// One unknown x read twice: z1 = x + n1, z2 = x + n2. Integrating x out
// (flat prior), z1 - z2 ~ N(0, s1^2 + s2^2), and x's posterior variance is
// 1 / (1/s1^2 + 1/s2^2).
TEST(EvidenceTest, OneUnknownReadTwiceHasTheClosedFormEvidence) {
  const double z1 = 1.3, z2 = 0.4, s1 = 0.5, s2 = 0.2;
  for (const LinearSolverType back_end : kBackEnds) {
    FactorGraph graph;
    const int x = graph.AddVariable(Eigen::VectorXd::Constant(1, 7.0));
    AddScalarReading(&graph, {x}, {1.0}, z1, s1);
    AddScalarReading(&graph, {x}, {1.0}, z2, s2);
    SolverOptions options;
    options.linear_solver = back_end;
    SparseSolver solver(options);
    const SolveResult result = solver.Solve(&graph);
    ASSERT_TRUE(result.summary.IsUsable()) << result.summary.message;
    const Evidence& evidence = result.evidence;
    ASSERT_TRUE(evidence.valid);
    const double variance = s1 * s1 + s2 * s2;
    EXPECT_NEAR(evidence.log_evidence, LogNormal(z1 - z2, variance), 1e-12);
    EXPECT_NEAR(evidence.squared_residual, (z1 - z2) * (z1 - z2) / variance, 1e-12);
    EXPECT_NEAR(evidence.log_det_noise, std::log(s1 * s1) + std::log(s2 * s2), 1e-12);
    EXPECT_NEAR(evidence.log_det_information, std::log(1 / (s1 * s1) + 1 / (s2 * s2)), 1e-12);
    EXPECT_NEAR(evidence.normaliser, -0.5 * kLog2Pi, 1e-15);
    EXPECT_EQ(evidence.num_rows, 2);
    EXPECT_EQ(evidence.num_parameters, 1);
    const double posterior = 1.0 / (1.0 / (s1 * s1) + 1.0 / (s2 * s2));
    EXPECT_NEAR(graph.values().Get(x)[0], posterior * (z1 / (s1 * s1) + z2 / (s2 * s2)), 1e-12);
    std::vector<Eigen::MatrixXd> blocks;
    ASSERT_TRUE(solver.MarginalCovariances({{x}}, &blocks));
    EXPECT_NEAR(blocks[0](0, 0), posterior, 1e-13);
  }
}

// Two unknowns, each read once (z1 = x1 + n1, z2 = x2 + n2), and their
// difference once (z3 = x2 - x1 + n3): integrating both out,
// z3 - (z2 - z1) ~ N(0, s1^2 + s2^2 + s3^2).
TEST(EvidenceTest, TwoUnknownsAndTheirDifferenceHaveTheClosedFormEvidence) {
  const double z1 = 0.2, z2 = 1.1, z3 = 0.5, s1 = 0.3, s2 = 0.4, s3 = 0.1;
  for (const LinearSolverType back_end : kBackEnds) {
    FactorGraph graph;
    const int x1 = graph.AddVariable(Eigen::VectorXd::Zero(1));
    const int x2 = graph.AddVariable(Eigen::VectorXd::Zero(1));
    AddScalarReading(&graph, {x1}, {1.0}, z1, s1);
    AddScalarReading(&graph, {x2}, {1.0}, z2, s2);
    AddScalarReading(&graph, {x1, x2}, {-1.0, 1.0}, z3, s3);
    SolverOptions options;
    options.linear_solver = back_end;
    SparseSolver solver(options);
    const SolveResult result = solver.Solve(&graph);
    ASSERT_TRUE(result.evidence.valid) << result.summary.message;
    EXPECT_NEAR(result.evidence.log_evidence,
                LogNormal(z3 - (z2 - z1), s1 * s1 + s2 * s2 + s3 * s3), 1e-12);
    // The joint posterior covariance: the inverse of the information matrix.
    Eigen::Matrix2d information;
    information << 1 / (s1 * s1) + 1 / (s3 * s3), -1 / (s3 * s3), -1 / (s3 * s3),
        1 / (s2 * s2) + 1 / (s3 * s3);
    std::vector<Eigen::MatrixXd> blocks;
    ASSERT_TRUE(solver.MarginalCovariances({{x1, x2}, {x2}}, &blocks));
    EXPECT_LT((blocks[0] - information.inverse()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_NEAR(blocks[1](0, 0), information.inverse()(1, 1), 1e-12);
  }
}

TEST(EvidenceTest, EvidenceIsTheSumOfItsParts) {
  FactorGraph graph;
  const int x = graph.AddVariable(Eigen::Vector2d::Zero());
  graph.Emplace<testing::LinearFactor>(std::vector<int>{x}, Eigen::MatrixXd::Identity(2, 2),
                                       Eigen::Vector2d(1.0, 2.0), 0.5);
  AddScalarReading(&graph, {x}, {1.0, 1.0}, 0.0, 3.0);
  Evidence evidence;
  SetEvidenceConstants(graph, 3, 2, &evidence);
  EXPECT_EQ(evidence.num_rows, 3);
  EXPECT_EQ(evidence.num_parameters, 2);
  EXPECT_NEAR(evidence.log_det_noise, 2 * std::log(0.25) + std::log(9.0), 1e-15);
  EXPECT_NEAR(evidence.normaliser, -0.5 * kLog2Pi, 1e-15);
  evidence.squared_residual = 1.5;
  evidence.log_det_information = 0.25;
  CompleteEvidence(&evidence);
  EXPECT_EQ(evidence.log_evidence, 0.0);  // not valid: not computed
  evidence.valid = true;
  CompleteEvidence(&evidence);
  EXPECT_NEAR(evidence.log_evidence,
              -0.75 - 0.5 * evidence.log_det_noise - 0.125 + evidence.normaliser, 1e-15);
}

TEST(EvidenceTest, MinimumSquaredResidualOfTheNormalEquations) {
  std::srand(3);
  const Eigen::MatrixXd j = Eigen::MatrixXd::Random(7, 3);
  const Eigen::VectorXd e = Eigen::VectorXd::Random(7);
  const Eigen::VectorXd g = j.transpose() * e;
  const Eigen::VectorXd x = (j.transpose() * j).ldlt().solve(g);
  const Eigen::VectorXd best = j.colPivHouseholderQr().solve(-e);
  EXPECT_NEAR(MinimumSquaredResidual(0.5 * e.squaredNorm(), g, x), (j * best + e).squaredNorm(),
              1e-12);
  // Rounding never makes it negative.
  EXPECT_EQ(MinimumSquaredResidual(0.0, g, x), 0.0);
}

// ---- CHOLMOD factors of a known matrix ----

// A banded SPD matrix of size n (4 entries either side of the diagonal).
Eigen::MatrixXd BandedMatrix(int n) {
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i)
    for (int k = std::max(0, i - 4); k <= i; ++k)
      h(i, k) = h(k, i) = i == k ? 10.0 + 0.1 * i : 1.0 / (1 + i + 2 * k);
  return h;
}

// h with row and column i moved to inverse_permutation[i], as CHOLMOD's
// lower triangle.
cholmod_sparse* PermutedLower(const Eigen::MatrixXd& h, const std::vector<int>& inverse_permutation,
                              cholmod_common* cc) {
  const int n = static_cast<int>(h.rows());
  Eigen::MatrixXd permuted(n, n);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < n; ++k) permuted(inverse_permutation[i], inverse_permutation[k]) = h(i, k);
  cholmod_dense dense;
  dense.nrow = dense.ncol = dense.d = static_cast<size_t>(n);
  dense.nzmax = static_cast<size_t>(n) * n;
  dense.x = permuted.data();
  dense.z = nullptr;
  dense.xtype = CHOLMOD_REAL;
  dense.dtype = CHOLMOD_DOUBLE;
  cholmod_sparse* full = cholmod_dense_to_sparse(&dense, 1, cc);
  cholmod_sparse* lower = cholmod_copy(full, -1, 1, cc);
  cholmod_free_sparse(&full, cc);
  return lower;
}

// Factors `matrix` in its own order: LL' or LDL', simplicial or supernodal.
cholmod_factor* FactorNaturally(cholmod_sparse* matrix, bool ll, bool supernodal,
                                cholmod_common* cc) {
  cc->nmethods = 1;
  cc->method[0].ordering = CHOLMOD_NATURAL;
  cc->postorder = 0;
  cc->supernodal = supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_SIMPLICIAL;
  cc->final_ll = ll;
  cholmod_factor* factor = cholmod_analyze(matrix, cc);
  EXPECT_TRUE(cholmod_factorize(matrix, factor, cc));
  return factor;
}

struct FactorKind {
  bool ll, supernodal;
};
constexpr FactorKind kFactorKinds[] = {{true, false}, {false, false}, {true, true}};

TEST(EvidenceTest, LogDetOfFactorOfEveryKind) {
  const Eigen::MatrixXd h = BandedMatrix(40);
  std::vector<int> identity(40);
  for (int i = 0; i < 40; ++i) identity[i] = i;
  for (const FactorKind kind : kFactorKinds) {
    testing::CholmodWorkspace cholmod;
    cholmod_sparse* matrix = PermutedLower(h, identity, &cholmod.cc);
    cholmod_factor* factor = FactorNaturally(matrix, kind.ll, kind.supernodal, &cholmod.cc);
    ASSERT_EQ(static_cast<bool>(factor->is_ll), kind.ll);
    ASSERT_EQ(static_cast<bool>(factor->is_super), kind.supernodal);
    EXPECT_NEAR(LogDetOfFactor(factor), std::log(h.determinant()), 1e-10);
    cholmod_free_factor(&factor, &cholmod.cc);
    cholmod_free_sparse(&matrix, &cholmod.cc);
  }
}

// Covariance blocks (groups of 3 columns, more than one batch of unit
// columns) of a matrix factored after a permutation: the blocks of the
// dense inverse, whether from a forward solve (LL') or a full one (LDL').
TEST(EvidenceTest, CovarianceBlocksAreBlocksOfTheInverse) {
  constexpr int n = 120;
  const Eigen::MatrixXd h = BandedMatrix(n);
  const Eigen::MatrixXd inverse = h.inverse();
  std::vector<int> inverse_permutation(n);
  for (int i = 0; i < n; ++i) inverse_permutation[i] = (37 * i) % n;  // 37 and 120 coprime
  std::vector<std::vector<int>> columns;
  for (int start = 0; start + 2 < n; start += 3) columns.push_back({start + 2, start, start + 1});
  columns.push_back({5, 80});  // an off-diagonal block too
  for (const FactorKind kind : kFactorKinds) {
    testing::CholmodWorkspace cholmod;
    cholmod_sparse* matrix = PermutedLower(h, inverse_permutation, &cholmod.cc);
    cholmod_factor* factor = FactorNaturally(matrix, kind.ll, kind.supernodal, &cholmod.cc);
    std::vector<Eigen::MatrixXd> blocks;
    std::string why;
    ASSERT_TRUE(CovarianceBlocks(factor, inverse_permutation, &cholmod.cc, columns, &blocks, &why))
        << why;
    ASSERT_EQ(blocks.size(), columns.size());
    for (size_t g = 0; g < columns.size(); ++g) {
      const int size = static_cast<int>(columns[g].size());
      ASSERT_EQ(blocks[g].rows(), size);
      for (int r = 0; r < size; ++r)
        for (int c = 0; c < size; ++c)
          EXPECT_NEAR(blocks[g](r, c), inverse(columns[g][r], columns[g][c]), 1e-13)
              << "group " << g;
    }
    cholmod_free_factor(&factor, &cholmod.cc);
    cholmod_free_sparse(&matrix, &cholmod.cc);
  }
}

}  // namespace
}  // namespace oslam

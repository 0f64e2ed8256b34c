// What the Gaussian at a solve's final point gives (docs/method.md §8.2): the Laplace
// log-evidence and marginal covariances. Both come from the *undamped*
// Gauss-Newton system J^T J delta = -J^T e at the final linearisation point.
//
// With r the residual of that system's least-squares solution, m rows and
// n unknowns, and P_f each factor's noise covariance,
//
//   log P(Z) ~ -1/2 ||r||^2 - 1/2 sum_f log |P_f| - 1/2 log det(J^T J)
//              + 1/2 (n - m) log(2 pi),
//
// the integral of the linearised likelihood over the unknowns (exact for a
// linear-Gaussian problem), and the covariance of the unknowns is
// (J^T J)^{-1}.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "solver/factor_graph.h"
#include "solver/sparse_solver.h"

struct cholmod_common_struct;
struct cholmod_factor_struct;

namespace oslam {

// The parts that do not depend on the solution: m, n, sum_f log |P_f| and
// the normaliser 1/2 (n - m) log(2 pi).
void SetEvidenceConstants(const FactorGraph& graph, int m, int n, Evidence* evidence);
// log_evidence from the parts, when evidence->valid.
void CompleteEvidence(Evidence* evidence);

// min_d ||e + J d||^2 = ||e||^2 - g' H^{-1} g (at d = -H^{-1} g), from the
// cost 1/2 ||e||^2, the gradient g = J^T e and x = H^{-1} g; at least 0
// (rounding).
double MinimumSquaredResidual(double cost, const Eigen::VectorXd& gradient,
                              const Eigen::VectorXd& inverse_hessian_gradient);

// log det of the matrix a CHOLMOD factor holds (LL' or LDL', simplicial or
// supernodal).
double LogDetOfFactor(const cholmod_factor_struct* factor);

// Covariance blocks of the factored matrix H: for every list of scalar
// columns (in delta's order), the matching block of H^{-1}. `inverse_
// permutation` maps a column of delta to its row in the factor. False with
// `why` when CHOLMOD fails.
bool CovarianceBlocks(cholmod_factor_struct* factor, const std::vector<int>& inverse_permutation,
                      cholmod_common_struct* cc, const std::vector<std::vector<int>>& columns,
                      std::vector<Eigen::MatrixXd>* blocks, std::string* why);

// Square-root columns of the covariance: for every list of scalar columns
// E_g, Y_g = L^{-1} P E_g (LL'; D^{-1/2} L^{-1} P E_g for LDL'), n x |g| in
// the factor's order, so that any block of H^{-1} between two lists is
// Y_a' Y_b. Lets a caller
// that needs many pairwise blocks among a few variables solve once per
// variable rather than once per pair, and a forward solve only. False with
// `why` when CHOLMOD fails.
// Solved on the reach of E_g alone (its elimination-tree ancestors: a sparse
// forward solve, cost the sum of those columns' lengths); a supernodal factor
// is first copied to a simplicial one.
bool CovarianceRoots(cholmod_factor_struct* factor, const std::vector<int>& inverse_permutation,
                     cholmod_common_struct* cc, const std::vector<std::vector<int>>& columns,
                     std::vector<CovarianceRoot>* roots, std::string* why);

// Draws from N(0, H^{-1}) for the factored matrix H: H = P' L L' P (LL') or
// P' L D L' P (LDL'), so y = P' L^{-T} z (LL') or P' L^{-T} D^{-1/2} z, with
// z standard normal (std::mt19937_64 seeded with `seed`), one backward
// solve per batch of draws. Row i of `samples` (n x count) holds the draws'
// values at scalar column i. False with `why` when CHOLMOD fails. Estimates
// traces (the redundancy of a group of residuals, Hutchinson-style) where
// the covariance blocks would cost a solve per column.
bool CovarianceSamples(cholmod_factor_struct* factor, const std::vector<int>& inverse_permutation,
                       cholmod_common_struct* cc, int count, unsigned long seed,
                       DrawMatrix* samples, std::string* why);

}  // namespace oslam

// Sparse Levenberg-Marquardt for a FactorGraph (docs/method.md §5.2-§5.4, Algorithm 1),
// with the Laplace log-evidence of docs/method.md §8.2 and marginal covariances.
//
// Linear algebra: the whitened normal equations (J^T J + lambda D) delta =
// -J^T e are assembled straight into a CHOLMOD upper-triangular matrix whose
// pattern (and the fill-reducing symbolic analysis) is computed once per
// problem structure and reused, also across Solve() calls on a new graph
// whose block pattern is a subset of the cached one (the MCMC case: a small
// association change). Alternatively the whitened Jacobian is factored by
// SuiteSparseQR, as the thesis does (slower; kept for cross-checking).
//
// The evidence and the covariances always come from the *undamped*
// Gauss-Newton system at the final linearisation point (docs/method.md §8.2).
//
// This header is the solver's interface; its parts, all in solver/:
//   levenberg_marquardt.h     the LM policy: damping, gain ratio, line search,
//                             convergence tests
//   linearization.h           factor errors and Jacobians, with reuse
//   normal_equations.h        the CHOLMOD back end, built on
//     block_pattern.h           the problem's layout and block pattern,
//     fill_reducing_ordering.h  AMD / CAMD / METIS on the block graph,
//     symbolic_analysis.h       the permuted matrix and its analysis
//   sparse_qr.h               the SuiteSparseQR back end
//   evidence.h                the evidence and covariances
//   serial_openmp.h           CHOLMOD on the calling thread; it changes
//                             OpenMP and OpenBLAS for the whole process
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "solver/factor_graph.h"

namespace oslam {

enum class LinearSolverType { kSparseCholesky, kSparseQR };

// Fill-reducing ordering of the Cholesky path, computed per variable (block).
// kAutomatic tries AMD, CAMD with the variables of high block degree (objects
// seen from many poses) last, and METIS from 2,000 variables on, and keeps
// the one with the fewest factorisation flops; the others force one method.
enum class OrderingType { kAutomatic, kAmd, kHighDegreeLast, kMetis };

struct SolverOptions {
  LinearSolverType linear_solver = LinearSolverType::kSparseCholesky;
  int max_iterations = 50;
  // Converged when an accepted step has max |delta| below this (m, rad;
  // docs/method.md §5.4), or lowers the cost by less than function_tolerance
  // relatively, or when max |J^T e| falls below gradient_tolerance.
  double step_tolerance = 1e-4;
  double function_tolerance = 1e-8;
  // ... or by less than this many nats (the cost 1/2 sum ||e||^2 is a
  // negative log-likelihood). Weakly observed objects (seen from one side,
  // far away) leave a flat, curved valley in which Gauss-Newton converges
  // only linearly; the 10k-pose problem started at the truth still lowered
  // its cost by 0.005 per iteration after 50 iterations (relative 4e-8),
  // long past any difference the evidence comparisons could see. 0: off.
  double absolute_function_tolerance = 1e-3;
  double gradient_tolerance = 1e-10;
  // LM damping lambda multiplies diag(J^T J) (clamped to
  // [min_diagonal, max_diagonal]) - Marquardt's scaling, so metres and
  // radians need no hand tuning.
  double initial_damping = 1e-4;
  double max_damping = 1e16;
  double min_diagonal = 1e-6;
  double max_diagonal = 1e32;
  // A step is accepted when actual / predicted cost reduction exceeds this.
  double min_relative_decrease = 1e-3;
  // Line search beyond accepted steps that gained more than 1.25 times the
  // predicted decrease: up to this multiple of the LM step, at the minimum
  // of the parabola through the cost at 0 and at the step and its slope at 0
  // (<= 1: off). For problems where J^T J overstates the curvature (weakly
  // observed objects' viewing rays: gain ratio near 2, linear convergence).
  double max_step_extrapolation = 0.0;
  OrderingType ordering = OrderingType::kAutomatic;
  // Reuse the cached symbolic analysis when the new block pattern fits in it.
  bool reuse_symbolic_analysis = true;
  // Results depend only on this solve's graph and start values, never on the
  // solves before it: the cached analysis is reused only for the identical
  // pattern, and the automatic ordering is compared afresh at every analysis
  // (long_loop: +3 % instructions). For solves that may be undone and done
  // again in another order (speculative MC3 chains).
  bool independent_of_history = false;
  // Keep the error and Jacobian of every factor with a linearisation slot
  // (Factor::linearization_slot) from one solve's linearisations to the
  // next, and reuse them where the factor's variables are bitwise
  // unchanged: docs/method.md §9.6's Jacobian reuse. An O-SLAM proposal is
  // linearised at its parent state's solution, so all proposals from one
  // state but the first share nearly all their linearisations. The results
  // are the same bit for bit; a linearisation costs one more copy, so this
  // pays only where solves start from the same point (one-step proposals).
  bool reuse_linearizations = false;
  bool compute_evidence = true;
  // Algorithm 1 steps 4-5: end with the undamped Gauss-Newton step of the
  // final linear system (the one the evidence comes from), if it does not
  // raise the cost. Off: the values stay at that system's linearisation point.
  bool apply_final_step = true;
  // Threads linearising the factors of a large problem (at least
  // Linearizer::kParallelFactors factors, without linearisation reuse;
  // 0: one per core). Each factor writes its own error and Jacobian and
  // the cost is summed in factor order: the same results bit for bit.
  int threads = 1;

  bool Validate(std::string* why) const;
};

enum class TerminationType {
  kConverged,      // a tolerance was met
  kMaxIterations,  // usable estimate, not converged
  kFailure,        // no usable estimate (invalid options or graph, non-finite cost, ...)
};
const char* TerminationName(TerminationType type);

struct SolverSummary {
  TerminationType termination = TerminationType::kFailure;
  std::string message;
  int iterations = 0;        // linear solves attempted
  int successful_steps = 0;  // accepted steps
  // Factors whose error and Jacobian were reused (reuse_linearizations)
  // and factors linearised, over all linearisations of this solve.
  int reused_linearizations = 0;
  int computed_linearizations = 0;
  int step_extrapolations = 0;  // line-search stretches (max_step_extrapolation)
  double initial_cost = 0;      // 1/2 sum ||e||^2 at the start
  double final_cost = 0;
  int num_factors = 0;
  int num_residuals = 0;   // m
  int num_parameters = 0;  // n (free variables only)
  bool reused_symbolic_analysis = false;
  OrderingType ordering =
      OrderingType::kAutomatic;  // the one used (never kAutomatic after a solve)
  double total_time_s = 0, linearize_time_s = 0, analyze_time_s = 0, factorize_time_s = 0,
         evidence_time_s = 0;

  bool IsUsable() const { return termination != TerminationType::kFailure; }
};

// log P(Z | C, J) by Laplace (docs/method.md §8.2), and its pieces:
//   log_evidence = -1/2 squared_residual - 1/2 log_det_noise
//                  - 1/2 log_det_information + normaliser
//   normaliser   = 1/2 (n - m) log(2 pi)
// (any detection-class term, log P(a | c), is the caller's to add).
struct Evidence {
  bool valid = false;
  double log_evidence = 0;
  double squared_residual = 0;     // ||r||^2 = min ||A d - b||^2 of the final linear system
  double log_det_information = 0;  // log det(A^T A) = 2 sum log |r_ii|
  double log_det_noise = 0;        // sum over factors of log |P_block|
  double normaliser = 0;           // 1/2 (n - m) log(2 pi)
  int num_rows = 0;                // m
  int num_parameters = 0;          // n
};

struct SolveResult {
  SolverSummary summary;
  Evidence evidence;
  // ||e_f||^2 of every factor (graph order) at the final values; empty
  // when the solve failed.
  std::vector<double> squared_errors;
};

// Square-root columns of the covariance for one group of scalar columns
// (SparseSolver::CovarianceRoots): Y_g = L^{-1} P E_g (scaled by D^{-1/2}
// for LDL'), non-zero only on the elimination-tree ancestors of E_g's rows,
// so kept as those `rows` of the factor (ascending) and `values` there
// (rows.size() x |g|).
struct CovarianceRoot {
  std::vector<int> rows;
  Eigen::MatrixXd values;
  size_t bytes() const {
    return rows.size() * sizeof(int) + static_cast<size_t>(values.size()) * sizeof(double);
  }
};

// Y_a^T Y_b: the covariance block between two groups.
Eigen::MatrixXd RootProduct(const CovarianceRoot& a, const CovarianceRoot& b);

// Draws of every free scalar variable, one row each (count values in a row).
using DrawMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// SparseSolver::CovarianceSamples: the draws of all free variables and, per
// group of keys asked for, its rows in them.
struct CovarianceDraws {
  DrawMatrix all;
  std::vector<std::vector<int>> rows;
  // Group g's draws, dimension x count, into `out` (its storage reused).
  void Gather(size_t group, Eigen::MatrixXd* out) const;
};

class SparseSolver {
 public:
  explicit SparseSolver(const SolverOptions& options = SolverOptions());
  ~SparseSolver();
  SparseSolver(const SparseSolver&) = delete;
  SparseSolver& operator=(const SparseSolver&) = delete;

  const SolverOptions& options() const { return options_; }
  void set_options(const SolverOptions& options) { options_ = options; }

  // Minimises 1/2 sum ||e_f||^2 over the free variables, starting from and
  // updating graph->mutable_values(). Never throws on numerical trouble: the
  // summary says what happened.
  SolveResult Solve(FactorGraph* graph);

  // Joint covariance blocks (one per group of keys, in the groups' order) of
  // the Gaussian at the last Solve's final point, i.e. the matching blocks of
  // (J^T J)^{-1}. False (with `why`) when there is no valid final
  // factorisation, or a key is unknown or fixed.
  bool MarginalCovariances(const std::vector<std::vector<int>>& key_groups,
                           std::vector<Eigen::MatrixXd>* blocks, std::string* why = nullptr);

  // Per group of keys, Y_g with (J^T J)^{-1} blocks Y_a^T Y_b between any
  // two groups (evidence.h's CovarianceRoots; RootProduct), at the last
  // Solve's final point. False (with `why`) as MarginalCovariances.
  bool CovarianceRoots(const std::vector<std::vector<int>>& key_groups,
                       std::vector<CovarianceRoot>* roots, std::string* why = nullptr);

  // Draws from the Gaussian at the last Solve's final point, N(0, (J^T J)^{-1})
  // (evidence.h's CovarianceSamples), of every free variable at once, and
  // where each group of keys lies in them. Same failures as
  // MarginalCovariances.
  bool CovarianceSamples(const std::vector<std::vector<int>>& key_groups, int count,
                         unsigned long seed, CovarianceDraws* draws, std::string* why = nullptr);
  // The same, as a dimension x count matrix per group (memory grows with the
  // groups' total dimension; CovarianceDraws holds each variable once).
  bool CovarianceSamples(const std::vector<std::vector<int>>& key_groups, int count,
                         unsigned long seed, std::vector<Eigen::MatrixXd>* samples,
                         std::string* why = nullptr);

  // Forget the cached symbolic analysis (the next Solve analyses afresh)
  // and the kept linearisations.
  void ClearCache();
  // Forget only the kept linearisations (SolverOptions::reuse_linearizations),
  // e.g. when a slot is given to another measurement.
  void ClearLinearizations();

 private:
  struct Impl;
  SolverOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace oslam

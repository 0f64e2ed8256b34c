// The SuiteSparseQR back end of SparseSolver: each step as the
// least-squares solution of the whitened, damped Jacobian system
//
//   [ J              ]         [ -e ]
//   [ sqrt(lambda D) ] delta = [  0 ]
//
// factored by SPQR, as the thesis does (docs/method.md §5.3). Slower than the normal
// equations (solver/normal_equations.h); kept for cross-checking them. The
// undamped system (lambda = 0) also gives the evidence's pieces: the
// residual ||J delta + e||^2 and log |det R| (= 1/2 log det(J^T J)).
#pragma once

#include <memory>

#include <Eigen/Core>

#include "solver/block_pattern.h"
#include "solver/linearization.h"
#include "solver/sparse_solver.h"

struct cholmod_common_struct;

namespace oslam {

class SparseQr {
 public:
  SparseQr();
  ~SparseQr();
  SparseQr(const SparseQr&) = delete;
  SparseQr& operator=(const SparseQr&) = delete;

  // The step for the errors and Jacobians of `evaluation` (laid out by
  // `layout`, n = number of entries of delta), damped by lambda D
  // (DampingScale of `diagonal`, the diagonal of J^T J). With lambda = 0,
  // when asked, also ||J delta + e||^2 and sum log |r_jj| of the R factor.
  // False when SPQR fails, J is rank-deficient or the step not finite.
  bool Solve(const ProblemLayout& layout, int n, const Evaluation& evaluation,
             const Eigen::VectorXd& diagonal, double lambda, const SolverOptions& options,
             Eigen::VectorXd* delta, double* squared_residual, double* log_abs_det_r);

 private:
  std::unique_ptr<cholmod_common_struct> cc_;  // SPQR works with SuiteSparse_long indices
};

}  // namespace oslam

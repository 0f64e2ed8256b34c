#include "solver/sparse_qr.h"

#include <cmath>

#include <cholmod.h>
#include <SuiteSparseQR.hpp>

#include "solver/levenberg_marquardt.h"

namespace oslam {
namespace {

// The system's matrix [J; sqrt(lambda D)] (the damping rows only when
// lambda > 0) and right-hand side [-e; 0], from the free variables'
// columns of every factor's Jacobian (each free key of a factor has
// exactly one diagonal block pair). Zero Jacobian entries are left out.
void BuildSystem(const ProblemLayout& layout, int n, const Evaluation& evaluation,
                 const Eigen::VectorXd& diagonal, double lambda, const SolverOptions& options,
                 cholmod_common* cc, cholmod_sparse** a, cholmod_dense** b) {
  const int m = layout.m;
  const int rows = m + (lambda > 0 ? n : 0);
  const auto& jacobians = evaluation.jacobians;
  const auto& errors = evaluation.errors;
  size_t nnz = 0;
  for (const auto& jacobian : jacobians) nnz += jacobian.size();
  cholmod_triplet* triplet = cholmod_l_allocate_triplet(rows, n, nnz + n, 0, CHOLMOD_REAL, cc);
  auto* ti = static_cast<SuiteSparse_long*>(triplet->i);
  auto* tj = static_cast<SuiteSparse_long*>(triplet->j);
  auto* tx = static_cast<double*>(triplet->x);
  size_t k = 0;
  *b = cholmod_l_zeros(rows, 1, CHOLMOD_REAL, cc);
  auto* bx = static_cast<double*>((*b)->x);
  for (size_t f = 0; f < jacobians.size(); ++f) {
    const int row0 = layout.factor_row[f];
    for (int r = 0; r < errors[f].size(); ++r) bx[row0 + r] = -errors[f][r];
    for (int pk = layout.pair_begin[f]; pk < layout.pair_begin[f + 1]; ++pk) {
      const BlockPair& pair = layout.pairs[pk];
      if (!pair.diagonal) continue;
      for (int c = 0; c < pair.a_dim; ++c)
        for (int r = 0; r < errors[f].size(); ++r) {
          const double value = jacobians[f](r, pair.a_column + c);
          if (value == 0.0) continue;
          ti[k] = row0 + r;
          tj[k] = pair.a_offset + c;
          tx[k++] = value;
        }
    }
  }
  if (lambda > 0)
    for (int c = 0; c < n; ++c) {
      ti[k] = m + c;
      tj[k] = c;
      tx[k++] = std::sqrt(lambda * DampingScale(diagonal[c], options));
    }
  triplet->nnz = k;
  *a = cholmod_l_triplet_to_sparse(triplet, k, cc);
  cholmod_l_free_triplet(&triplet, cc);
}

// ||J delta + e||^2 over the J rows.
double SquaredResidual(const ProblemLayout& layout, const Evaluation& evaluation,
                       const Eigen::VectorXd& delta) {
  double sum = 0.0;
  for (size_t f = 0; f < evaluation.jacobians.size(); ++f) {
    Eigen::VectorXd residual = evaluation.errors[f];
    for (int pk = layout.pair_begin[f]; pk < layout.pair_begin[f + 1]; ++pk) {
      const BlockPair& pair = layout.pairs[pk];
      if (pair.diagonal)
        residual += evaluation.jacobians[f].middleCols(pair.a_column, pair.a_dim) *
                    delta.segment(pair.a_offset, pair.a_dim);
    }
    sum += residual.squaredNorm();
  }
  return sum;
}

// sum_j log |r_jj| of the n x n factor R; false when a diagonal entry is
// zero. |det R| = prod |r_jj| whatever SPQR's column permutation.
bool LogAbsDetOfR(const cholmod_sparse* r, int n, double* log_abs_det) {
  const auto* rp = static_cast<const SuiteSparse_long*>(r->p);
  const auto* ri = static_cast<const SuiteSparse_long*>(r->i);
  const auto* rx = static_cast<const double*>(r->x);
  double sum = 0.0;
  bool ok = true;
  for (int j = 0; j < n && ok; ++j) {
    double d = 0.0;
    for (SuiteSparse_long q = rp[j]; q < rp[j + 1]; ++q)
      if (ri[q] == j) d = rx[q];
    ok = d != 0.0;
    sum += std::log(std::abs(d));
  }
  *log_abs_det = sum;
  return ok;
}

}  // namespace

SparseQr::SparseQr() : cc_(std::make_unique<cholmod_common>()) {
  cholmod_l_start(cc_.get());
  cc_->print = 0;
  cc_->error_handler = nullptr;
}

SparseQr::~SparseQr() {
  cholmod_l_finish(cc_.get());
}

bool SparseQr::Solve(const ProblemLayout& layout, int n, const Evaluation& evaluation,
                     const Eigen::VectorXd& diagonal, double lambda, const SolverOptions& options,
                     Eigen::VectorXd* delta, double* squared_residual, double* log_abs_det_r) {
  cholmod_common* cc = cc_.get();
  cholmod_sparse* a = nullptr;
  cholmod_dense* b = nullptr;
  BuildSystem(layout, n, evaluation, diagonal, lambda, options, cc, &a, &b);
  cholmod_dense* z = nullptr;
  cholmod_sparse* r = nullptr;
  SuiteSparse_long* e = nullptr;
  const bool want_r = log_abs_det_r != nullptr;
  const SuiteSparse_long rank = SuiteSparseQR<double>(
      SPQR_ORDERING_DEFAULT, SPQR_NO_TOL, n, 2, a, nullptr, b, nullptr, &z, want_r ? &r : nullptr,
      want_r ? &e : nullptr, nullptr, nullptr, nullptr, cc);
  bool ok = z != nullptr && rank == n;
  if (ok) {
    *delta = Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(z->x), n);
    ok = delta->allFinite();
  }
  if (ok && squared_residual) *squared_residual = SquaredResidual(layout, evaluation, *delta);
  if (ok && want_r) ok = LogAbsDetOfR(r, n, log_abs_det_r);
  if (z) cholmod_l_free_dense(&z, cc);
  if (r) cholmod_l_free_sparse(&r, cc);
  if (e) cholmod_l_free(n, sizeof(SuiteSparse_long), e, cc);
  cholmod_l_free_sparse(&a, cc);
  cholmod_l_free_dense(&b, cc);
  return ok;
}

}  // namespace oslam

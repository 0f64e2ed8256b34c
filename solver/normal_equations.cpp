#include "solver/normal_equations.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include <cholmod.h>

#include "solver/levenberg_marquardt.h"

namespace oslam {
namespace {

// What a set-up depends on: each variable's size and whether it is fixed,
// each factor's rows and keys, and whether a larger kept pattern may serve
// (independent_of_history).
void StructureOf(const FactorGraph& graph, bool independent_of_history,
                 std::vector<int>* structure) {
  structure->clear();
  structure->push_back(independent_of_history ? 1 : 0);
  const int num_keys = graph.num_variables();
  structure->reserve(num_keys + 5 * graph.factors().size() + 1);
  for (int key = 0; key < num_keys; ++key)
    structure->push_back(graph.IsFixed(key) ? -graph.values().Dim(key) - 1
                                            : graph.values().Dim(key));
  for (const auto& factor : graph.factors()) {
    structure->push_back(-factor->Dimension() - 1);
    structure->insert(structure->end(), factor->keys().begin(), factor->keys().end());
  }
}

}  // namespace

NormalEquations::NormalEquations() : cc_(std::make_unique<cholmod_common>()) {
  cholmod_common& cc = *cc_;
  cholmod_start(&cc);
  cc.nmethods = 1;
  cc.method[0].ordering = CHOLMOD_AMD;
  cc.postorder = 1;
  cc.print = 0;
  cc.error_handler = nullptr;
  // Amalgamate supernodes a little more than CHOLMOD's default (4/16/48
  // columns, 0.8/0.1/0.05 zeros): each supernode costs OpenMP regions (see
  // serial_openmp.h) and small BLAS calls. At LPA scale the pose chain's
  // supernodes go from 61 to 33; one O-SLAM proposal: -2 % instructions,
  // half the kernel time, -6 % cycles. More (16/32/64: 19 supernodes) adds
  // more zeros than it saves.
  cc.nrelax[0] = 8;
  cc.nrelax[1] = 24;
  cc.zrelax[1] = 0.2;
}

NormalEquations::~NormalEquations() {
  FreeStructure();
  FreeWork();
  cholmod_finish(cc_.get());
}

void NormalEquations::FreeWork() {
  cholmod_common* cc = cc_.get();
  if (rhs_) cholmod_free_dense(&rhs_, cc);
  if (solution_) cholmod_free_dense(&solution_, cc);
  if (work_y_) cholmod_free_dense(&work_y_, cc);
  if (work_e_) cholmod_free_dense(&work_e_, cc);
}

void NormalEquations::FreeStructure() {
  cholmod_common* cc = cc_.get();
  if (hessian_) cholmod_free_sparse(&hessian_, cc);
  if (permuted_.matrix) cholmod_free_sparse(&permuted_.matrix, cc);
  if (factor_) cholmod_free_factor(&factor_, cc);
  pattern_.Clear();
  set_up_structure_.clear();
  factor_is_final_ = false;
}

void NormalEquations::Clear() {
  FreeStructure();
  ordering_.Forget();
}

bool NormalEquations::SetUp(const FactorGraph& graph, OrderingType ordering,
                            bool independent_of_history, bool allow_reuse, bool* reused,
                            double* analyze_s, std::string* why) {
  // The same structure as the last set-up (a re-solve of the same
  // association, a class switch, a proposal made again): everything
  // FullSetUp does would come out the same.
  StructureOf(graph, independent_of_history, &scratch_structure_);
  const bool same_structure = allow_reuse && hessian_ && factor_ &&
                              analysed_ordering_ == ordering &&
                              scratch_structure_ == set_up_structure_;
  if (same_structure) {
    *reused = true;
    factor_is_final_ = false;
    return true;
  }
  set_up_structure_.clear();  // until this set-up succeeds
  if (!FullSetUp(graph, ordering, independent_of_history, allow_reuse, reused, analyze_s, why))
    return false;
  std::swap(set_up_structure_, scratch_structure_);
  return true;
}

bool NormalEquations::FullSetUp(const FactorGraph& graph, OrderingType ordering,
                                bool independent_of_history, bool allow_reuse, bool* reused,
                                double* analyze_s, std::string* why) {
  ++layout_generation_;
  if (!builder_.FindFreeVariables(graph, &layout_, why) ||
      !builder_.FindBlocks(graph, &layout_, why))
    return false;
  // A strictly larger kept pattern factorises the same matrix with other
  // fill, so other rounding: only the identical one keeps a solve
  // independent of the solves before it.
  const bool fits = allow_reuse && hessian_ && factor_ && builder_.dims() == pattern_.dims &&
                    analysed_ordering_ == ordering &&
                    pattern_.Covers(builder_.rows(), independent_of_history);
  *reused = fits;
  if (!fits && !Rebuild(ordering, independent_of_history, analyze_s, why)) return false;
  factor_is_final_ = false;
  if (!builder_.PlaceFactorBlocks(graph, pattern_, &layout_, why)) return false;
  local_hessian_.resize(layout_.max_columns, layout_.max_columns);
  local_gradient_.resize(layout_.max_columns);
  gradient_.resize(pattern_.n);
  diagonal_.resize(pattern_.n);
  return true;
}

bool NormalEquations::Rebuild(OrderingType ordering, bool independent_of_history, double* analyze_s,
                              std::string* why) {
  // The builder takes the old pattern's rows (and their capacity) for the
  // next set-up.
  std::vector<std::vector<int>> previous = std::move(pattern_.rows);
  FreeStructure();
  pattern_.dims = builder_.dims();
  pattern_.rows = std::move(builder_.rows());
  builder_.rows() = std::move(previous);
  pattern_.ComputeLayout();
  AllocateHessian();

  const auto start = std::chrono::steady_clock::now();
  cholmod_common* cc = cc_.get();
  std::vector<int> block_order;
  if (ordering_.Choose(pattern_, ordering, independent_of_history, cc, &block_order) &&
      BuildPermutedHessian(pattern_, block_order, static_cast<const int*>(hessian_->p)[pattern_.n],
                           cc, &permuted_)) {
    factor_ = AnalyzeBlockwise(pattern_, block_order, permuted_, cc);
    if (factor_ && !factor_->is_super && !UseUpperTriangle(&permuted_, cc))
      cholmod_free_factor(&factor_, cc);
    if (factor_ && std::getenv("OSLAM_SOLVER_TRACE"))
      std::fprintf(stderr,
                   "chosen ordering %d, factor ordering %d super %d (%d supernodes) lnz %.0f\n",
                   static_cast<int>(ordering_.used()), factor_->ordering, factor_->is_super,
                   static_cast<int>(factor_->nsuper), cc->lnz);
  }
  analysed_ordering_ = ordering;
  *analyze_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!factor_) {
    *why = "CHOLMOD analysis failed (out of memory?)";
    FreeStructure();
    return false;
  }
  return true;
}

// The Hessian's storage: per column of delta, the rows of its block rows in
// the pattern's order (off-diagonal blocks full, the diagonal block's upper
// triangle), and the work vectors of the solves.
void NormalEquations::AllocateHessian() {
  const int num_free = pattern_.num_blocks(), n = pattern_.n;
  const std::vector<int>& dims = pattern_.dims;
  size_t nnz = 0;
  for (int b = 0; b < num_free; ++b) {
    const int off_rows = pattern_.prefix[b].back();  // rows above the diagonal block
    nnz +=
        static_cast<size_t>(off_rows) * dims[b] + static_cast<size_t>(dims[b]) * (dims[b] + 1) / 2;
  }
  cholmod_common* cc = cc_.get();
  hessian_ = cholmod_allocate_sparse(n, n, nnz, 1, 1, 1, CHOLMOD_REAL, cc);
  auto* p = static_cast<int*>(hessian_->p);
  auto* i = static_cast<int*>(hessian_->i);
  diagonal_position_.resize(n);
  int next = 0;
  for (int b = 0; b < num_free; ++b) {
    for (int q = 0; q < dims[b]; ++q) {
      const int column = pattern_.offsets[b] + q;
      p[column] = next;
      for (int a : pattern_.rows[b]) {
        const int last = (a == b) ? q : dims[a] - 1;
        for (int r = 0; r <= last; ++r) i[next++] = pattern_.offsets[a] + r;
      }
      diagonal_position_[column] = next - 1;
    }
  }
  p[n] = next;
  FreeWork();
  rhs_ = cholmod_zeros(n, 1, CHOLMOD_REAL, cc);
}

bool NormalEquations::Assemble(const Evaluation& evaluation) {
  const int n = pattern_.n;
  auto* x = static_cast<double*>(hessian_->x);
  const auto* p = static_cast<const int*>(hessian_->p);
  std::fill(x, x + p[n], 0.0);
  gradient_.setZero();
  const size_t num_factors = evaluation.jacobians.size();
  for (size_t f = 0; f < num_factors; ++f) {
    const Eigen::MatrixXd& jacobian = evaluation.jacobians[f];
    const Eigen::VectorXd& error = evaluation.errors[f];
    // The common factor shapes (bounding slice 4x8, odometry 3x6, a
    // landmark sighting 2x5, priors) get fixed-size products: Eigen's
    // dynamic lazy product runs a scalar loop per entry (20 % of a one-step
    // O-SLAM proposal's instructions).
    const int rows = static_cast<int>(jacobian.rows()), columns = layout_.factor_columns[f];
    if (rows == 4 && columns == 8)
      AssembleFactor<4, 8>(jacobian, error, f, x, p);
    else if (rows == 2 && columns == 5)
      AssembleFactor<2, 5>(jacobian, error, f, x, p);
    else if (rows == 3 && columns == 6)
      AssembleFactor<3, 6>(jacobian, error, f, x, p);
    else if (rows == 3 && columns == 3)
      AssembleFactor<3, 3>(jacobian, error, f, x, p);
    else if (rows == 2 && columns == 2)
      AssembleFactor<2, 2>(jacobian, error, f, x, p);
    else
      AssembleFactor<Eigen::Dynamic, Eigen::Dynamic>(jacobian, error, f, x, p);
  }
  for (int c = 0; c < n; ++c) diagonal_[c] = x[diagonal_position_[c]];
  return gradient_.allFinite() && diagonal_.allFinite();
}

// Adds factor f's J^T J and J^T e (J: Rows x Columns, or dynamic) into the
// Hessian's entries `x` (column pointers `p`) and the gradient.
template <int Rows, int Columns>
void NormalEquations::AssembleFactor(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& error,
                                     size_t f, double* x, const int* p) {
  using Local = Eigen::Matrix<double, Columns, Columns>;
  using LocalGradient = Eigen::Matrix<double, Columns, 1>;
  const int columns = layout_.factor_columns[f];
  const Eigen::Map<const Eigen::Matrix<double, Rows, Columns>> j(jacobian.data(), jacobian.rows(),
                                                                 columns);
  const Eigen::Map<const Eigen::Matrix<double, Rows, 1>> e(error.data(), error.size());
  Eigen::Map<Local> local(local_hessian_.data(), columns, columns);
  Eigen::Map<LocalGradient> local_g(local_gradient_.data(), columns);
  // A plain (lazy) product: Eigen's blocked GEMM, which it would pick for
  // 8x4x8, costs more in set-up than the product.
  local.noalias() = j.transpose().lazyProduct(j);
  local_g.noalias() = j.transpose().lazyProduct(e);
  for (int k = layout_.pair_begin[f]; k < layout_.pair_begin[f + 1]; ++k) {
    const BlockPair& pair = layout_.pairs[k];
    for (int q = 0; q < pair.b_dim; ++q) {
      double* out = x + p[pair.b_offset + q] + pair.row_prefix;
      const double* in = local.data() + (pair.b_column + q) * columns + pair.a_column;
      const int count = pair.diagonal ? q + 1 : pair.a_dim;
      // Blocks are 1-3 rows high: unrolled, not a short loop with vector
      // set-up and remainder handling.
      switch (count) {
        case 3:
          out[2] += in[2];
          [[fallthrough]];
        case 2:
          out[1] += in[1];
          [[fallthrough]];
        case 1:
          out[0] += in[0];
          break;
        default:
          for (int r = 0; r < count; ++r) out[r] += in[r];
      }
    }
    if (pair.diagonal)
      for (int r = 0; r < pair.a_dim; ++r)
        gradient_[pair.a_offset + r] += local_g[pair.a_column + r];
  }
}

bool NormalEquations::Factorize(double lambda, const SolverOptions& options) {
  const int n = pattern_.n;
  auto* x = static_cast<double*>(hessian_->x);
  for (int c = 0; c < n; ++c)
    x[diagonal_position_[c]] = diagonal_[c] + lambda * DampingScale(diagonal_[c], options);
  auto* px = static_cast<double*>(permuted_.matrix->x);
  const int hnz = static_cast<const int*>(hessian_->p)[n];
  for (int k = 0; k < hnz; ++k) px[permuted_.entry[k]] = x[k];
  for (int c = 0; c < n; ++c) x[diagonal_position_[c]] = diagonal_[c];
  const int ok = cholmod_factorize(permuted_.matrix, factor_, cc_.get());
  return ok && cc_->status == CHOLMOD_OK && factor_->minor == factor_->n;
}

bool NormalEquations::Solve(const Eigen::VectorXd& in, Eigen::VectorXd* out) {
  const int n = pattern_.n;
  const std::vector<int>& inverse_permutation = permuted_.inverse_permutation;
  auto* bx = static_cast<double*>(rhs_->x);
  for (int c = 0; c < n; ++c) bx[inverse_permutation[c]] = in[c];
  if (!cholmod_solve2(CHOLMOD_A, factor_, rhs_, nullptr, &solution_, nullptr, &work_y_, &work_e_,
                      cc_.get()))
    return false;
  const auto* sx = static_cast<const double*>(solution_->x);
  out->resize(n);
  for (int c = 0; c < n; ++c) (*out)[c] = sx[inverse_permutation[c]];
  return out->allFinite();
}

}  // namespace oslam

#include "solver/evidence.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include <cholmod.h>

namespace oslam {
namespace {

constexpr double kLog2Pi = 1.8378770664093454836;

// Unit columns are solved for in batches of at most this many.
constexpr int kCovarianceBatch = 64;

}  // namespace

void SetEvidenceConstants(const FactorGraph& graph, int m, int n, Evidence* evidence) {
  evidence->num_rows = m;
  evidence->num_parameters = n;
  for (const auto& factor : graph.factors()) evidence->log_det_noise += factor->LogDetCovariance();
  evidence->normaliser = 0.5 * (n - m) * kLog2Pi;
}

void CompleteEvidence(Evidence* evidence) {
  if (evidence->valid)
    evidence->log_evidence = -0.5 * evidence->squared_residual - 0.5 * evidence->log_det_noise -
                             0.5 * evidence->log_det_information + evidence->normaliser;
}

double MinimumSquaredResidual(double cost, const Eigen::VectorXd& gradient,
                              const Eigen::VectorXd& inverse_hessian_gradient) {
  return std::max(0.0, 2.0 * cost - gradient.dot(inverse_hessian_gradient));
}

double LogDetOfFactor(const cholmod_factor* factor) {
  double log_det = 0.0;
  const double* x = static_cast<const double*>(factor->x);
  if (factor->is_super) {
    const auto* super = static_cast<const int*>(factor->super);
    const auto* pi = static_cast<const int*>(factor->pi);
    const auto* px = static_cast<const int*>(factor->px);
    for (size_t s = 0; s < factor->nsuper; ++s) {
      const int columns = super[s + 1] - super[s];
      const int rows = pi[s + 1] - pi[s];
      for (int j = 0; j < columns; ++j)
        log_det += 2.0 * std::log(std::abs(x[px[s] + j + j * rows]));
    }
  } else {
    const auto* p = static_cast<const int*>(factor->p);
    const double scale = factor->is_ll ? 2.0 : 1.0;  // LDL' keeps D on the diagonal
    for (size_t j = 0; j < factor->n; ++j) log_det += scale * std::log(std::abs(x[p[j]]));
  }
  return log_det;
}

namespace {

// A right-hand side, its solution and cholmod_solve2's workspace, reused
// across batches (a fresh n x 64 set per batch, megabytes on a long
// trajectory, is page-faulted in anew each time) and freed together.
struct SolveBuffers {
  explicit SolveBuffers(cholmod_common* common) : cc(common) {}
  ~SolveBuffers() {
    for (cholmod_dense** d : {&rhs, &solution, &work_y, &work_e}) cholmod_free_dense(d, cc);
  }
  SolveBuffers(const SolveBuffers&) = delete;
  SolveBuffers& operator=(const SolveBuffers&) = delete;
  // Solves `system` with `factor` for the first `width` columns of rhs.
  bool Solve(int system, cholmod_factor* factor, int width) {
    const size_t allocated_columns = rhs->ncol;
    rhs->ncol = width;
    const int solved =
        cholmod_solve2(system, factor, rhs, nullptr, &solution, nullptr, &work_y, &work_e, cc);
    rhs->ncol = allocated_columns;
    return solved && solution;
  }
  cholmod_common* cc;
  cholmod_dense *rhs = nullptr, *solution = nullptr, *work_y = nullptr, *work_e = nullptr;
};

// Solves with the factor (`system`: CHOLMOD_A or CHOLMOD_L) for the unit
// columns of every group, kCovarianceBatch columns per solve, and hands each
// group the n x size slice of the solution that belongs to it.
bool SolveUnitColumnsInBatches(
    cholmod_factor* factor, const std::vector<int>& inverse_permutation, cholmod_common* cc,
    const std::vector<std::vector<int>>& columns, int system,
    const std::function<void(size_t group, const double* solution)>& take, std::string* why) {
  const int n = static_cast<int>(factor->n);
  size_t total_columns = 0;
  for (const auto& group : columns) total_columns += group.size();
  SolveBuffers buffers(cc);
  const auto allocate = [&](size_t width) {
    cholmod_free_dense(&buffers.rhs, cc);
    buffers.rhs = cholmod_zeros(n, std::max<size_t>(1, width), CHOLMOD_REAL, cc);
    if (!buffers.rhs && why) *why = "CHOLMOD could not allocate the right-hand side";
    return buffers.rhs != nullptr;
  };
  if (!allocate(std::min<size_t>(total_columns, kCovarianceBatch))) return false;
  size_t g = 0;
  while (g < columns.size()) {
    size_t end = g;
    int width = 0;
    while (end < columns.size() &&
           (width == 0 || width + static_cast<int>(columns[end].size()) <= kCovarianceBatch))
      width += static_cast<int>(columns[end++].size());
    // One group wider than a batch.
    if (width > static_cast<int>(buffers.rhs->ncol) && !allocate(width)) return false;
    auto* ux = static_cast<double*>(buffers.rhs->x);
    const auto set_units = [&](double value) {
      int c = 0;
      for (size_t h = g; h < end; ++h)
        for (int column : columns[h])
          ux[static_cast<size_t>(c++) * n + inverse_permutation[column]] = value;
    };
    set_units(1.0);
    const bool solved = buffers.Solve(system, factor, width);
    set_units(0.0);
    if (!solved) {
      if (why) *why = "CHOLMOD solve failed";
      return false;
    }
    const auto* xx = static_cast<const double*>(buffers.solution->x);
    int c = 0;
    for (size_t h = g; h < end; ++h) {
      take(h, xx + static_cast<size_t>(c) * n);
      c += static_cast<int>(columns[h].size());
    }
    g = end;
  }
  return true;
}

}  // namespace

bool CovarianceBlocks(cholmod_factor* factor, const std::vector<int>& inverse_permutation,
                      cholmod_common* cc, const std::vector<std::vector<int>>& columns,
                      std::vector<Eigen::MatrixXd>* blocks, std::string* why) {
  const int n = static_cast<int>(factor->n);
  blocks->assign(columns.size(), Eigen::MatrixXd());
  // With H = L L' (the permuted matrix is factored in its natural order),
  // H^-1 = L^-T L^-1, so a block is Y' Y with Y = L^-1 E: a forward solve
  // only, half the work of solving with H. An LDL' factor solves with H.
  const bool forward_only = factor->is_ll;
  const auto take_block = [&](size_t h, const double* solution) {
    const int size = static_cast<int>(columns[h].size());
    Eigen::MatrixXd& block = (*blocks)[h];
    if (forward_only) {
      const Eigen::Map<const Eigen::MatrixXd> y(solution, n, size);
      block = y.transpose() * y;
      return;
    }
    block.resize(size, size);
    for (int q = 0; q < size; ++q)
      for (int r = 0; r < size; ++r)
        block(r, q) = solution[static_cast<size_t>(q) * n + inverse_permutation[columns[h][r]]];
    block = 0.5 * (block + block.transpose()).eval();
  };
  return SolveUnitColumnsInBatches(factor, inverse_permutation, cc, columns,
                                   forward_only ? CHOLMOD_L : CHOLMOD_A, take_block, why);
}

namespace {

// Y_g of one group on a simplicial factor: L y = e_q for each of the
// group's rows q = inverse_permutation[column], solved on the union of their
// elimination-tree paths (the only rows where y is non-zero), in ascending
// order (a node's ancestors come after it). `position` is scratch of the
// factor's size, all -1 on entry and on return.
CovarianceRoot SimplicialRoot(const cholmod_factor* factor, const std::vector<int>& rows_of_group,
                              std::vector<int>* position) {
  const auto* fp = static_cast<const int*>(factor->p);
  const auto* fi = static_cast<const int*>(factor->i);
  const auto* fnz = static_cast<const int*>(factor->nz);
  const auto* fx = static_cast<const double*>(factor->x);
  // Column j's first entry is its diagonal; its parent the least row below.
  const auto parent = [&](int j) {
    int least = -1;
    for (int k = fp[j] + 1; k < fp[j] + fnz[j]; ++k)
      if (least < 0 || fi[k] < least) least = fi[k];
    return least;
  };
  CovarianceRoot root;
  for (int q : rows_of_group)
    for (int j = q; j >= 0 && (*position)[j] < 0; j = parent(j)) {
      (*position)[j] = 0;
      root.rows.push_back(j);
    }
  std::sort(root.rows.begin(), root.rows.end());
  for (size_t r = 0; r < root.rows.size(); ++r) (*position)[root.rows[r]] = static_cast<int>(r);
  const int width = static_cast<int>(rows_of_group.size());
  root.values = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(root.rows.size()), width);
  for (int c = 0; c < width; ++c) root.values((*position)[rows_of_group[c]], c) = 1.0;
  for (size_t r = 0; r < root.rows.size(); ++r) {
    const int j = root.rows[r];
    auto y = root.values.row(static_cast<Eigen::Index>(r));
    if (factor->is_ll) y /= fx[fp[j]];
    for (int k = fp[j] + 1; k < fp[j] + fnz[j]; ++k)
      root.values.row((*position)[fi[k]]) -= fx[k] * y;
  }
  // LDL': H^-1 = L^-T D^-1 L^-1, so Y = D^-1/2 L^-1 E (L unit-diagonal, D
  // on its diagonal).
  if (!factor->is_ll)
    for (size_t r = 0; r < root.rows.size(); ++r)
      root.values.row(static_cast<Eigen::Index>(r)) /= std::sqrt(std::abs(fx[fp[root.rows[r]]]));
  for (int j : root.rows) (*position)[j] = -1;
  return root;
}

}  // namespace

bool CovarianceRoots(cholmod_factor* factor, const std::vector<int>& inverse_permutation,
                     cholmod_common* cc, const std::vector<std::vector<int>>& columns,
                     std::vector<CovarianceRoot>* roots, std::string* why) {
  if (!factor->is_ll && factor->is_super) {
    if (why) *why = "a supernodal LDL' factor";  // CHOLMOD makes none
    return false;
  }
  const int n = static_cast<int>(factor->n);
  roots->assign(columns.size(), CovarianceRoot());
  // A supernodal factor is copied to a simplicial one (the same L), whose
  // columns a sparse solve can follow: a dense solve per batch of 64 columns
  // costs the whole factor each time and page-faults n x 64 buffers in anew.
  cholmod_factor* simplicial = factor;
  if (factor->is_super) {
    simplicial = cholmod_copy_factor(factor, cc);
    if (!simplicial ||
        !cholmod_change_factor(CHOLMOD_REAL, true, false, true, true, simplicial, cc)) {
      cholmod_free_factor(&simplicial, cc);
      if (why) *why = "CHOLMOD could not make a simplicial copy of the factor";
      return false;
    }
  }
  std::vector<int> position(static_cast<size_t>(n), -1);
  for (size_t h = 0; h < columns.size(); ++h) {
    std::vector<int> rows_of_group;
    for (int column : columns[h]) rows_of_group.push_back(inverse_permutation[column]);
    (*roots)[h] = SimplicialRoot(simplicial, rows_of_group, &position);
  }
  if (simplicial != factor) cholmod_free_factor(&simplicial, cc);
  return true;
}

bool CovarianceSamples(cholmod_factor* factor, const std::vector<int>& inverse_permutation,
                       cholmod_common* cc, int count, unsigned long seed, DrawMatrix* samples,
                       std::string* why) {
  const int n = static_cast<int>(factor->n);
  samples->resize(n, count);
  if (!factor->is_ll && factor->is_super) {
    if (why) *why = "a supernodal LDL' factor";  // CHOLMOD makes none
    return false;
  }
  // LDL' (simplicial): D is the factor's diagonal.
  const auto* fx = static_cast<const double*>(factor->x);
  const auto* fp = static_cast<const int*>(factor->p);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  // The draws and their solutions reused across batches (SolveBuffers).
  SolveBuffers buffers(cc);
  buffers.rhs = cholmod_allocate_dense(n, std::min(kCovarianceBatch, std::max(count, 1)), n,
                                       CHOLMOD_REAL, cc);
  if (!buffers.rhs) {
    if (why) *why = "CHOLMOD could not allocate the draws";
    return false;
  }
  auto* zx = static_cast<double*>(buffers.rhs->x);
  std::vector<int> variable_of(static_cast<size_t>(n));  // factor row -> variable
  for (int i = 0; i < n; ++i) variable_of[inverse_permutation[i]] = i;
  for (int first = 0; first < count; first += kCovarianceBatch) {
    const int width = std::min(kCovarianceBatch, count - first);
    for (int c = 0; c < width; ++c)
      for (int i = 0; i < n; ++i) {
        const double d = factor->is_ll ? 1.0 : fx[fp[i]];
        zx[static_cast<size_t>(c) * n + i] = normal(rng) / std::sqrt(std::abs(d));
      }
    if (!buffers.Solve(CHOLMOD_Lt, factor, width)) {
      if (why) *why = "CHOLMOD solve failed";
      return false;
    }
    // Transposed in blocks of the solution's rows: a block's entries of one
    // draw are contiguous, and the rows they go to stay in cache across the
    // draws (row by row, every read was a page apart).
    const auto* yx = static_cast<const double*>(buffers.solution->x);
    constexpr int kBlock = 32;
    for (int j0 = 0; j0 < n; j0 += kBlock) {
      const int j1 = std::min(n, j0 + kBlock);
      for (int c = 0; c < width; ++c) {
        const double* column = yx + static_cast<size_t>(c) * n;
        for (int j = j0; j < j1; ++j) (*samples)(variable_of[j], first + c) = column[j];
      }
    }
  }
  return true;
}

}  // namespace oslam

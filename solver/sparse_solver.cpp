#include "solver/sparse_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <cholmod.h>
#include <SuiteSparseQR.hpp>

#include "solver/levenberg_marquardt.h"
#include "solver/linearization.h"
#include "solver/serial_openmp.h"

namespace oslam {

namespace {

constexpr double kLog2Pi = 1.8378770664093454836;
// METIS is tried as an ordering from this many variables on (below it, its
// cost exceeds what it can save).
constexpr int kMetisMinBlocks = 2000;
// Problems whose variable counts differ by at most this many are "similar"
// for the choice of ordering kind.
constexpr int kSimilarProblemBlocks = 8;

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

// log det of the matrix factored in L (LL' or LDL', simplicial or supernodal).
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

}  // namespace

const char* TerminationName(TerminationType type) {
  switch (type) {
    case TerminationType::kConverged:
      return "converged";
    case TerminationType::kMaxIterations:
      return "max_iterations";
    case TerminationType::kFailure:
      return "failure";
  }
  return "unknown";
}

bool SolverOptions::Validate(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why) *why = message;
    return false;
  };
  if (max_iterations < 0) return fail("max_iterations must be >= 0");
  if (!(step_tolerance >= 0) || !(function_tolerance >= 0) || !(gradient_tolerance >= 0) ||
      !(absolute_function_tolerance >= 0))
    return fail("tolerances must be >= 0");
  if (!(initial_damping > 0) || !(max_damping >= initial_damping))
    return fail("need 0 < initial_damping <= max_damping");
  if (!(min_diagonal > 0) || !(max_diagonal >= min_diagonal))
    return fail("need 0 < min_diagonal <= max_diagonal");
  if (!(min_relative_decrease > 0) || !(min_relative_decrease < 1))
    return fail("min_relative_decrease must be in (0, 1)");
  if (!(max_step_extrapolation >= 0) || !std::isfinite(max_step_extrapolation))
    return fail("max_step_extrapolation must be finite and >= 0");
  return true;
}

// ---------------------------------------------------------------------------

struct SparseSolver::Impl {
  // One (variable a, variable b) block of J^T J that a factor contributes to,
  // with a <= b in column order.
  // 20 bytes, not 32: SetUp writes one per block of every factor, Assemble
  // reads them all back, per proposal.
  struct BlockPair {
    int a_offset, b_offset;            // offsets in delta
    int row_prefix;                    // position of a's first row inside each column of b
    std::uint16_t a_column, b_column;  // columns in the factor's Jacobian
    std::uint8_t a_dim, b_dim;         // variable sizes
    bool diagonal;
  };
  // What BlockPair can hold (SetUp refuses larger factors or variables).
  static constexpr int kMaxFactorColumns = 65535, kMaxVariableDim = 255;

  cholmod_common cc;
  cholmod_common cc_long;  // SPQR works with SuiteSparse_long indices

  // ---- structure (cached across solves) ----
  std::vector<int> pattern_dims;                 // dimension per free variable
  std::vector<std::vector<int>> pattern_rows;    // block rows (free variable) per block column
  std::vector<std::vector<int>> pattern_prefix;  // scalar row prefix per block row
  std::vector<int> offsets;                      // scalar offset per free variable
  int n = 0;
  cholmod_sparse* hessian = nullptr;  // upper triangle, variables' order
  // The same matrix with the chosen fill-reducing permutation applied,
  // lower triangle: CHOLMOD factors it with its natural ordering, which
  // spares the transpose-and-permute copy that every cholmod_factorize of
  // an unpermuted matrix makes.
  cholmod_sparse* permuted = nullptr;
  std::vector<int> permuted_entry;       // hessian entry -> permuted entry
  std::vector<int> inverse_permutation;  // scalar column -> permuted position
  cholmod_factor* factor = nullptr;
  std::vector<int> diagonal_position;  // in hessian
  bool factor_is_final = false;        // holds the undamped factor at the final point

  // ---- per solve ----
  std::vector<int> free_index;  // per key: free variable index or -1
  std::vector<int> pair_begin;  // per factor, range into pairs
  std::vector<BlockPair> pairs;
  Linearizer linearizer;
  // Errors and Jacobians of every factor at the current point, and at the
  // trial point of a step (swapped in when the step is accepted, so an
  // accepted step costs one evaluation, not two).
  Evaluation current, trial;
  Evaluation stretched;  // a line search's candidate (SolverOptions::max_step_extrapolation)
  Eigen::MatrixXd local_hessian;    // scratch: J_f^T J_f
  Eigen::VectorXd local_gradient;   // scratch: J_f^T e_f
  std::vector<int> factor_columns;  // per factor: its Jacobian's column count
  OrderingType requested_ordering = OrderingType::kAutomatic;
  bool independent_of_history = false;  // SolverOptions::independent_of_history
  OrderingType ordering_used = OrderingType::kAmd;
  OrderingType analysed_ordering = OrderingType::kAutomatic;  // the request the cache was made for
  // The last automatic comparison of orderings: its problem's variable count
  // and the winner (reused for similar problems, see Analyze).
  int compared_num_blocks = -1;
  OrderingType compared_choice = OrderingType::kAmd;
  // BuildPermuted's block pattern below the diagonal: per variable, the
  // variables after it in the permutation that share a factor with it.
  std::vector<int> block_below_begin, block_below;
  // StructureOf the graph the last successful set-up was for (empty if
  // none), and scratch for the next one's.
  std::vector<int> set_up_structure, scratch_structure;
  std::vector<int> factor_row;                 // first row of each factor in J
  std::vector<std::vector<int>> scratch_rows;  // SetUp's block pattern, reused
  std::vector<int> scratch_indices;            // SetUp: fill positions, then a factor's key columns
  // SetUp: factors per free variable (start offsets, factor indices), and
  // the last column each variable was entered in (later reused as each
  // column's cursor when placing blocks).
  std::vector<int> scratch_variable_start, scratch_variable_factors, scratch_stamp;
  int m = 0;
  Eigen::VectorXd gradient, diagonal;
  cholmod_dense* rhs = nullptr;
  cholmod_dense *solution = nullptr, *work_y = nullptr, *work_e = nullptr;

  Impl() {
    UseOneBlasThread();
    cholmod_start(&cc);
    // AMD only: METIS costs more than it saves at our sizes.
    cc.nmethods = 1;
    cc.method[0].ordering = CHOLMOD_AMD;
    cc.postorder = 1;
    cc.print = 0;
    cc.error_handler = nullptr;
    // Amalgamate supernodes a little more than CHOLMOD's default (4/16/48
    // columns, 0.8/0.1/0.05 zeros): each supernode costs OpenMP regions (see
    // serial_openmp.h) and small BLAS calls. At LPA scale the pose chain's supernodes go from 61 to
    // 33; one O-SLAM proposal: -2 % instructions, half the kernel time, -6 % cycles. More
    // (16/32/64: 19 supernodes) adds more zeros than it saves.
    cc.nrelax[0] = 8;
    cc.nrelax[1] = 24;
    cc.zrelax[1] = 0.2;
    cholmod_l_start(&cc_long);
    cc_long.print = 0;
    cc_long.error_handler = nullptr;
  }
  ~Impl() {
    FreeStructure();
    FreeWork();
    cholmod_finish(&cc);
    cholmod_l_finish(&cc_long);
  }
  void FreeWork() {
    if (rhs) cholmod_free_dense(&rhs, &cc);
    if (solution) cholmod_free_dense(&solution, &cc);
    if (work_y) cholmod_free_dense(&work_y, &cc);
    if (work_e) cholmod_free_dense(&work_e, &cc);
  }
  void FreeStructure() {
    if (hessian) cholmod_free_sparse(&hessian, &cc);
    if (permuted) cholmod_free_sparse(&permuted, &cc);
    if (factor) cholmod_free_factor(&factor, &cc);
    pattern_dims.clear();
    pattern_rows.clear();
    pattern_prefix.clear();
    set_up_structure.clear();
    factor_is_final = false;
  }

  // Builds the free-variable layout and block pattern of `graph`; reuses the
  // cached CHOLMOD structure and analysis when the pattern fits in it.
  // Returns false with `why` for a graph that cannot be solved.
  bool SetUp(const FactorGraph& graph, bool allow_reuse, bool* reused, double* analyze_s,
             std::string* why) {
    // The same structure as the last set-up (a re-solve of the same
    // association, a class switch, a proposal made again): everything
    // below would come out the same.
    StructureOf(graph, &scratch_structure);
    const bool same_structure = allow_reuse && hessian && factor &&
                                analysed_ordering == requested_ordering &&
                                scratch_structure == set_up_structure;
    if (same_structure) {
      *reused = true;
      factor_is_final = false;
      return true;
    }
    set_up_structure.clear();  // until this set-up succeeds
    if (!FullSetUp(graph, allow_reuse, reused, analyze_s, why)) return false;
    std::swap(set_up_structure, scratch_structure);
    return true;
  }

  // What a set-up depends on: each variable's size and whether it is
  // fixed, each factor's rows and keys, and whether a larger cached pattern
  // may serve (independent_of_history).
  void StructureOf(const FactorGraph& graph, std::vector<int>* structure) const {
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

  bool FullSetUp(const FactorGraph& graph, bool allow_reuse, bool* reused, double* analyze_s,
                 std::string* why) {
    const int num_keys = graph.num_variables();
    free_index.assign(num_keys, -1);
    std::vector<int> dims;
    for (int key = 0; key < num_keys; ++key) {
      if (graph.IsFixed(key)) continue;
      free_index[key] = static_cast<int>(dims.size());
      dims.push_back(graph.values().Dim(key));
      if (dims.back() > kMaxVariableDim) {
        *why = "a variable has more than " + std::to_string(kMaxVariableDim) + " entries";
        return false;
      }
    }
    const int num_free = static_cast<int>(dims.size());
    if (num_free == 0) {
      *why = "the graph has no free variable";
      return false;
    }
    // Scratch kept across solves (a proposal's graph is much like the last one).
    std::vector<std::vector<int>>& rows = scratch_rows;
    rows.resize(num_free);
    const auto& factors = graph.factors();
    m = 0;
    factor_row.resize(factors.size());
    // The factors of every free variable (compressed columns) ...
    std::vector<int>& start = scratch_variable_start;
    start.assign(num_free + 1, 0);
    for (size_t f = 0; f < factors.size(); ++f) {
      factor_row[f] = m;
      m += factors[f]->Dimension();
      for (int key : factors[f]->keys())
        if (free_index[key] >= 0) ++start[free_index[key] + 1];
    }
    for (int v = 0; v < num_free; ++v) start[v + 1] += start[v];
    std::vector<int>& of_variable = scratch_variable_factors;
    of_variable.resize(start[num_free]);
    std::vector<int>& next = scratch_indices;
    next.assign(start.begin(), start.end() - 1);
    for (size_t f = 0; f < factors.size(); ++f)
      for (int key : factors[f]->keys())
        if (free_index[key] >= 0) of_variable[next[free_index[key]]++] = static_cast<int>(f);
    // ... give each column's rows once each (an object's column would
    // otherwise collect its base point once per detection, all to be sorted
    // and dropped again).
    std::vector<int>& stamp = scratch_stamp;
    stamp.assign(num_free, -1);
    for (int b = 0; b < num_free; ++b) {
      if (start[b] == start[b + 1]) {
        *why = "a free variable is constrained by no factor (add a prior or fix it)";
        return false;
      }
      std::vector<int>& column = rows[b];
      column.clear();
      for (int k = start[b]; k < start[b + 1]; ++k)
        for (int key : factors[of_variable[k]]->keys()) {
          const int a = free_index[key];
          if (a >= 0 && a < b && stamp[a] != b) {
            stamp[a] = b;
            column.push_back(a);
          }
        }
      // Factors come in frame order, so an object's poses mostly arrive
      // sorted already; the diagonal goes last.
      if (!std::is_sorted(column.begin(), column.end())) std::sort(column.begin(), column.end());
      column.push_back(b);
    }

    bool fits = allow_reuse && hessian && factor && dims == pattern_dims &&
                analysed_ordering == requested_ordering;
    // A strictly larger cached pattern factorises the same matrix with
    // other fill, so other rounding: only the identical one keeps a solve
    // independent of the solves before it.
    for (int v = 0; fits && v < num_free; ++v)
      fits = independent_of_history ? pattern_rows[v] == rows[v]
                                    : std::includes(pattern_rows[v].begin(), pattern_rows[v].end(),
                                                    rows[v].begin(), rows[v].end());
    *reused = fits;
    if (!fits) {
      // The scratch takes the old pattern's vectors (and their capacity) for
      // the next set-up.
      std::vector<std::vector<int>> previous = std::move(pattern_rows);
      FreeStructure();
      pattern_dims = dims;
      pattern_rows = std::move(rows);
      rows = std::move(previous);
      BuildHessianStructure();
      const auto start = Clock::now();
      factor = Analyze();
      analysed_ordering = requested_ordering;
      *analyze_s = Seconds(start);
      if (!factor) {
        *why = "CHOLMOD analysis failed (out of memory?)";
        FreeStructure();
        return false;
      }
    }
    factor_is_final = false;

    // Where every factor's blocks go. Consecutive factors of one variable
    // mostly meet the next row of its column (an object's detections in
    // frame order), so each column keeps a cursor at its last hit.
    std::vector<int>& cursor = scratch_stamp;
    cursor.assign(num_free, 0);
    auto position_in_column = [&](int a, int b) {
      const std::vector<int>& col_rows = pattern_rows[b];
      const int size = static_cast<int>(col_rows.size());
      // A column's rows are sorted and end with its own variable.
      if (a == b) return size - 1;
      int& at = cursor[b];
      if (col_rows[at] == a) return at;
      if (at + 1 < size && col_rows[at + 1] == a) return ++at;
      // The row just above the diagonal (an object's base in its size column).
      if (size >= 2 && col_rows[size - 2] == a) return size - 2;
      at = static_cast<int>(std::lower_bound(col_rows.begin(), col_rows.end(), a) -
                            col_rows.begin());
      return at;
    };
    pairs.clear();
    pair_begin.assign(factors.size() + 1, 0);
    current.Resize(factors.size());
    trial.Resize(factors.size());
    factor_columns.resize(factors.size());
    int max_columns = 0;
    for (size_t f = 0; f < factors.size(); ++f) {
      pair_begin[f] = static_cast<int>(pairs.size());
      const auto& keys = factors[f]->keys();
      int total = 0;
      std::vector<int>& columns = scratch_indices;
      columns.clear();
      for (int key : keys) {
        columns.push_back(total);
        total += graph.values().Dim(key);
      }
      if (total > kMaxFactorColumns) {
        *why = "a " + factors[f]->Name() + " factor has more than " +
               std::to_string(kMaxFactorColumns) + " Jacobian columns";
        return false;
      }
      const int rows = (f + 1 < factors.size() ? factor_row[f + 1] : m) - factor_row[f];
      current.Shape(f, rows, total);
      trial.Shape(f, rows, total);
      factor_columns[f] = total;
      max_columns = std::max(max_columns, total);
      for (size_t i = 0; i < keys.size(); ++i) {
        for (size_t j = 0; j < keys.size(); ++j) {
          int a = free_index[keys[i]], b = free_index[keys[j]];
          if (a < 0 || b < 0 || a > b || (a == b && i > j)) continue;
          pairs.push_back({offsets[a], offsets[b], pattern_prefix[b][position_in_column(a, b)],
                           static_cast<std::uint16_t>(columns[i]),
                           static_cast<std::uint16_t>(columns[j]),
                           static_cast<std::uint8_t>(pattern_dims[a]),
                           static_cast<std::uint8_t>(pattern_dims[b]), a == b});
        }
      }
    }
    pair_begin[factors.size()] = static_cast<int>(pairs.size());
    local_hessian.resize(max_columns, max_columns);
    local_gradient.resize(max_columns);
    gradient.resize(n);
    diagonal.resize(n);
    return true;
  }

  void BuildHessianStructure() {
    const int num_free = static_cast<int>(pattern_dims.size());
    offsets.assign(num_free, 0);
    for (int v = 1; v < num_free; ++v) offsets[v] = offsets[v - 1] + pattern_dims[v - 1];
    n = offsets.back() + pattern_dims.back();
    pattern_prefix.assign(num_free, {});
    size_t nnz = 0;
    for (int b = 0; b < num_free; ++b) {
      int prefix = 0;
      for (int a : pattern_rows[b]) {
        pattern_prefix[b].push_back(prefix);
        prefix += pattern_dims[a];
      }
      // Off-diagonal rows are full; the diagonal block is upper-triangular.
      const int off_rows = prefix - pattern_dims[b];
      const int d = pattern_dims[b];
      nnz += static_cast<size_t>(off_rows) * d + static_cast<size_t>(d) * (d + 1) / 2;
    }
    hessian = cholmod_allocate_sparse(n, n, nnz, 1, 1, 1, CHOLMOD_REAL, &cc);
    auto* p = static_cast<int*>(hessian->p);
    auto* i = static_cast<int*>(hessian->i);
    diagonal_position.resize(n);
    int next = 0;
    for (int b = 0; b < num_free; ++b) {
      for (int q = 0; q < pattern_dims[b]; ++q) {
        const int column = offsets[b] + q;
        p[column] = next;
        for (int a : pattern_rows[b]) {
          const int last = (a == b) ? q : pattern_dims[a] - 1;
          for (int r = 0; r <= last; ++r) i[next++] = offsets[a] + r;
        }
        diagonal_position[column] = next - 1;
      }
    }
    p[n] = next;
    FreeWork();
    rhs = cholmod_zeros(n, 1, CHOLMOD_REAL, &cc);
  }

  // Fill-reducing ordering and symbolic analysis of `hessian`. Orderings are
  // computed on the block graph (one node per variable, so a variable's
  // components stay together) and expanded to scalars; candidates are AMD,
  // CAMD with the variables of high block degree last (objects seen from
  // most poses: the pose chain is eliminated first, as a band, and the
  // objects end up in one dense trailing block) and, on big problems,
  // METIS nested dissection (objects seen on many laps of a long run). The
  // one with the fewest factorisation flops is kept.
  cholmod_factor* Analyze() {
    const int num_free = static_cast<int>(pattern_dims.size());
    size_t nnz = 0;
    for (const auto& rows : pattern_rows) nnz += rows.size();
    cholmod_sparse* blocks =
        cholmod_allocate_sparse(num_free, num_free, nnz, 1, 1, 1, CHOLMOD_PATTERN, &cc);
    if (!blocks) return nullptr;
    auto* bp = static_cast<int*>(blocks->p);
    auto* bi = static_cast<int*>(blocks->i);
    std::vector<int> degree(num_free, 0);
    int next = 0;
    for (int b = 0; b < num_free; ++b) {
      bp[b] = next;
      for (int a : pattern_rows[b]) {
        bi[next++] = a;
        if (a != b) {
          ++degree[a];
          ++degree[b];
        }
      }
    }
    bp[num_free] = next;

    std::vector<std::pair<OrderingType, std::vector<int>>> candidates;
    std::vector<int> permutation(num_free);
    OrderingType wanted = requested_ordering;
    // A small association change (an O-SLAM proposal: one object more or
    // less) keeps the problem's character, so the kind that won the last
    // automatic comparison is used again without comparing; a problem that
    // has drifted further from the compared one is compared afresh.
    const bool compare = wanted == OrderingType::kAutomatic &&
                         (independent_of_history || compared_num_blocks < 0 ||
                          std::abs(num_free - compared_num_blocks) > kSimilarProblemBlocks);
    if (wanted == OrderingType::kAutomatic && !compare) wanted = compared_choice;
    auto want = [wanted](OrderingType type) {
      return wanted == OrderingType::kAutomatic || wanted == type;
    };
    if (want(OrderingType::kAmd) && cholmod_amd(blocks, nullptr, 0, permutation.data(), &cc))
      candidates.emplace_back(OrderingType::kAmd, permutation);
    std::vector<int> sorted = degree;
    std::nth_element(sorted.begin(), sorted.begin() + num_free / 2, sorted.end());
    const int threshold = std::max(16, 4 * sorted[num_free / 2]);
    std::vector<int> constraint(num_free, 0);
    bool any_high = false;
    for (int v = 0; v < num_free; ++v)
      if (degree[v] > threshold) constraint[v] = 1, any_high = true;
    if (((any_high && wanted == OrderingType::kAutomatic) ||
         wanted == OrderingType::kHighDegreeLast) &&
        cholmod_camd(blocks, nullptr, 0, constraint.data(), permutation.data(), &cc))
      candidates.emplace_back(OrderingType::kHighDegreeLast, permutation);
    if (((num_free >= kMetisMinBlocks && wanted == OrderingType::kAutomatic) ||
         wanted == OrderingType::kMetis) &&
        cholmod_metis(blocks, nullptr, 0, /*postorder=*/0, permutation.data(), &cc))
      candidates.emplace_back(OrderingType::kMetis, permutation);
    // Candidates are compared by a symbolic analysis of the block pattern
    // (a few times cheaper than the scalar one, and the scalar matrix is
    // then analysed once): factorisation flops ~ sum_j d_j (count_j d)^2,
    // with count_j the block column counts of L and d the mean block size.
    const double mean_dim = static_cast<double>(n) / num_free;
    cc.nmethods = 1;
    cc.method[0].ordering = CHOLMOD_GIVEN;
    const int supernodal = cc.supernodal;
    cc.supernodal = CHOLMOD_SIMPLICIAL;
    std::vector<int> best_blocks;
    double best_flops = 0.0;
    for (const auto& [kind, block_permutation] : candidates) {
      cholmod_factor* analysed =
          cholmod_analyze_p(blocks, const_cast<int*>(block_permutation.data()), nullptr, 0, &cc);
      if (!analysed) continue;
      const auto* perm = static_cast<const int*>(analysed->Perm);  // postordered
      const auto* counts = static_cast<const int*>(analysed->ColCount);
      double flops = 0.0;
      for (int j = 0; j < num_free; ++j)
        flops += pattern_dims[perm[j]] * std::pow(counts[j] * mean_dim, 2);
      if (std::getenv("OSLAM_SOLVER_TRACE"))
        std::fprintf(stderr, "ordering %d: block lnz %.0f estimated flops %.3g\n",
                     static_cast<int>(kind), cc.lnz, flops);
      if (best_blocks.empty() || flops < best_flops) {
        best_blocks.assign(perm, perm + num_free);
        best_flops = flops;
        ordering_used = kind;
      }
      cholmod_free_factor(&analysed, &cc);
    }
    cc.supernodal = supernodal;
    cholmod_free_sparse(&blocks, &cc);
    if (compare && !best_blocks.empty()) {
      compared_num_blocks = num_free;
      compared_choice = ordering_used;
    }
    if (best_blocks.empty()) {  // the natural block order as the fallback
      best_blocks.resize(num_free);
      std::iota(best_blocks.begin(), best_blocks.end(), 0);
      ordering_used = OrderingType::kAmd;
    }
    if (!BuildPermuted(best_blocks)) return nullptr;
    cholmod_factor* natural = AnalyzePermuted(best_blocks);
    if (natural && std::getenv("OSLAM_SOLVER_TRACE"))
      std::fprintf(stderr,
                   "chosen ordering %d, factor ordering %d super %d (%d supernodes) lnz %.0f\n",
                   static_cast<int>(ordering_used), natural->ordering, natural->is_super,
                   static_cast<int>(natural->nsuper), cc.lnz);
    return natural;
  }

  // Symbolic analysis of `permuted` in its own (natural) order. Every
  // variable's scalars form a dense block in it, so the elimination tree
  // and column counts of L are those of the block pattern, expanded: the
  // scalars of a variable form a chain, and its last one's parent is the
  // first scalar of the variable's parent in the block tree. Computed on
  // the blocks (a few thousand entries), this replaces cholmod_analyze's two
  // transposes, elimination tree and column counts on the scalar matrix
  // (~8 % of an O-SLAM proposal); the supernodal analysis is CHOLMOD's, on
  // the same input, so the factor is the one cholmod_analyze would make.
  cholmod_factor* AnalyzePermuted(const std::vector<int>& block_order) {
    const int num_free = static_cast<int>(pattern_dims.size());
    const std::vector<int>& dims = pattern_dims;
    std::vector<int> index_of(num_free), first_scalar(num_free);
    for (int k = 0, position = 0; k < num_free; ++k) {
      index_of[block_order[k]] = k;
      first_scalar[k] = position;
      position += dims[block_order[k]];
    }
    // L's block pattern column by column (in permuted order): the column's
    // own rows below the diagonal, merged with its children's (Liu's
    // column-merge); parent = the pattern's first row.
    std::vector<int> block_parent(num_free, -1), weight(num_free, 0), mark(num_free, -1);
    std::vector<int> child_head(num_free, -1), child_next(num_free, -1);
    std::vector<std::vector<int>> below_pattern(num_free);
    for (int k = 0; k < num_free; ++k) {
      std::vector<int>& rows = below_pattern[k];
      mark[k] = k;
      const int v = block_order[k];
      for (int e = block_below_begin[v]; e < block_below_begin[v + 1]; ++e) {
        const int i = index_of[block_below[e]];
        if (mark[i] != k) mark[i] = k, rows.push_back(i);
      }
      for (int c = child_head[k]; c >= 0; c = child_next[c]) {
        for (int i : below_pattern[c])
          if (mark[i] != k) mark[i] = k, rows.push_back(i);
        std::vector<int>().swap(below_pattern[c]);  // merged: not needed again
      }
      if (rows.empty()) continue;
      const int parent = *std::min_element(rows.begin(), rows.end());
      block_parent[k] = parent;
      child_next[k] = child_head[parent];
      child_head[parent] = k;
      for (int i : rows) weight[k] += dims[block_order[i]];
    }
    cholmod_factor* factor = cholmod_allocate_factor(n, &cc);
    if (!factor) return nullptr;
    auto* column_count = static_cast<int*>(factor->ColCount);
    std::vector<int> parent(n);
    double flops = 0.0, lnz = 0.0;
    for (int k = 0; k < num_free; ++k) {
      const int d = dims[block_order[k]], first = first_scalar[k];
      for (int q = 0; q < d; ++q) {
        const int count = (d - q) + weight[k];
        column_count[first + q] = count;
        flops += static_cast<double>(count) * count;
        lnz += count;
        parent[first + q] = q + 1 < d              ? first + q + 1
                            : block_parent[k] >= 0 ? first_scalar[block_parent[k]]
                                                   : -1;
      }
    }
    // As cholmod_analyze: its flop and size counts, and a supernodal factor
    // when there are enough flops per entry.
    cc.fl = flops;
    cc.lnz = lnz;
    const bool supernodal =
        cc.supernodal > CHOLMOD_AUTO ||
        (cc.supernodal == CHOLMOD_AUTO && lnz > 0 && flops / lnz >= cc.supernodal_switch);
    if (supernodal) {
      cholmod_sparse* upper = cholmod_transpose(permuted, 0, &cc);
      const bool ok = upper && cholmod_super_symbolic2(CHOLMOD_ANALYZE_FOR_CHOLESKY, upper,
                                                       permuted, parent.data(), factor, &cc);
      if (upper) cholmod_free_sparse(&upper, &cc);
      if (!ok) cholmod_free_factor(&factor, &cc);
    }
    if (factor && std::getenv("OSLAM_SOLVER_CHECK_ANALYSIS")) CheckAgainstCholmod(factor);
    return factor;
  }

  // OSLAM_SOLVER_CHECK_ANALYSIS=1: compares every analysis with
  // cholmod_analyze's of the same matrix and reports on stderr (a test
  // runs it; a diagnostic if CHOLMOD's analysis ever changes).
  void CheckAgainstCholmod(const cholmod_factor* mine) {
    cc.method[0].ordering = CHOLMOD_NATURAL;
    cc.postorder = 0;
    cholmod_factor* theirs = cholmod_analyze(permuted, &cc);
    cc.postorder = 1;
    bool same = theirs && theirs->is_super == mine->is_super && theirs->n == mine->n &&
                theirs->nsuper == mine->nsuper && theirs->ssize == mine->ssize &&
                theirs->xsize == mine->xsize && theirs->maxcsize == mine->maxcsize &&
                theirs->maxesize == mine->maxesize && theirs->is_ll == mine->is_ll &&
                theirs->ordering == mine->ordering;
    auto equal = [](const void* a, const void* b, size_t count) {
      return std::memcmp(a, b, count * sizeof(int)) == 0;
    };
    if (same)
      same = equal(theirs->ColCount, mine->ColCount, mine->n) &&
             equal(theirs->Perm, mine->Perm, mine->n);
    if (same && mine->is_super)
      same = equal(theirs->super, mine->super, mine->nsuper + 1) &&
             equal(theirs->pi, mine->pi, mine->nsuper + 1) &&
             equal(theirs->px, mine->px, mine->nsuper + 1) &&
             equal(theirs->s, mine->s, mine->ssize);
    std::fprintf(stderr, "analysis check: %s (n %d super %d nsuper %d)\n",
                 same ? "same" : "DIFFERENT", static_cast<int>(mine->n), mine->is_super,
                 static_cast<int>(mine->nsuper));
    if (theirs) cholmod_free_factor(&theirs, &cc);
  }

  // The hessian (upper triangle, variables' order) with the block
  // permutation `block_order` applied, as the lower triangle `permuted`,
  // and each hessian entry's position in it (permuted_entry). Built block
  // by block: every variable's scalars stay together, so a pair of
  // variables is one dense block in either matrix (per-entry counting
  // sorts, scattering every entry twice, were 8 % of an O-SLAM proposal's
  // time).
  bool BuildPermuted(const std::vector<int>& block_order) {
    const int num_free = static_cast<int>(pattern_dims.size());
    const std::vector<int>& dims = pattern_dims;
    std::vector<int> start(num_free);  // first permuted scalar of each variable
    int position = 0;
    for (int v : block_order) {
      start[v] = position;
      position += dims[v];
    }
    inverse_permutation.resize(n);
    for (int v = 0; v < num_free; ++v)
      for (int q = 0; q < dims[v]; ++q) inverse_permutation[offsets[v] + q] = start[v] + q;
    // Each off-diagonal pair of the pattern (index = its place in
    // pattern_rows, column by column) belongs to the column block of its
    // variable that comes first in the permutation (`low`); its rows there
    // follow the diagonal block, in permuted order.
    std::vector<int> pair_begin_of(num_free + 1, 0);
    for (int b = 0; b < num_free; ++b)
      pair_begin_of[b + 1] = pair_begin_of[b] + static_cast<int>(pattern_rows[b].size());
    const int num_pairs = pair_begin_of[num_free];
    std::vector<int> low_count(num_free + 1, 0);
    for (int b = 0; b < num_free; ++b)
      for (int a : pattern_rows[b])
        if (a != b) ++low_count[(start[a] < start[b] ? a : b) + 1];
    for (int v = 0; v < num_free; ++v) low_count[v + 1] += low_count[v];
    struct Below {
      int row_start, rows, pair, variable;
      bool operator<(const Below& other) const { return row_start < other.row_start; }
    };
    std::vector<Below> below(low_count[num_free]);
    std::vector<int> fill(low_count.begin(), low_count.end() - 1);
    for (int b = 0; b < num_free; ++b)
      for (size_t k = 0; k < pattern_rows[b].size(); ++k) {
        const int a = pattern_rows[b][k];
        if (a == b) continue;
        const bool a_low = start[a] < start[b];
        below[fill[a_low ? a : b]++] = {a_low ? start[b] : start[a], a_low ? dims[b] : dims[a],
                                        pair_begin_of[b] + static_cast<int>(k), a_low ? b : a};
      }
    std::vector<int> pair_prefix(num_pairs, 0), below_rows(num_free, 0);
    block_below_begin = low_count;
    block_below.resize(below.size());
    for (int v = 0; v < num_free; ++v) {
      const auto first = below.begin() + low_count[v], last = below.begin() + low_count[v + 1];
      std::sort(first, last);
      int prefix = 0;
      for (auto it = first; it != last; ++it) {
        pair_prefix[it->pair] = prefix;
        block_below[it - below.begin()] = it->variable;
        prefix += it->rows;
      }
      below_rows[v] = prefix;
    }
    std::size_t nnz = 0;
    for (int v = 0; v < num_free; ++v)
      nnz += static_cast<std::size_t>(dims[v]) * (dims[v] + 1) / 2 +
             static_cast<std::size_t>(dims[v]) * below_rows[v];
    permuted = cholmod_allocate_sparse(n, n, nnz, 1, 1, -1, CHOLMOD_REAL, &cc);
    if (!permuted) return false;
    auto* pp = static_cast<int*>(permuted->p);
    auto* pi = static_cast<int*>(permuted->i);
    int next = 0;
    for (int v : block_order)
      for (int q = 0; q < dims[v]; ++q) {
        pp[start[v] + q] = next;
        for (int r = q; r < dims[v]; ++r) pi[next++] = start[v] + r;
        for (int k = low_count[v]; k < low_count[v + 1]; ++k)
          for (int r = 0; r < below[k].rows; ++r) pi[next++] = below[k].row_start + r;
      }
    pp[n] = next;
    // Hessian entries in its storage order (BuildHessianStructure).
    permuted_entry.resize(static_cast<const int*>(hessian->p)[n]);
    int k = 0;
    for (int b = 0; b < num_free; ++b)
      for (int q = 0; q < dims[b]; ++q)
        for (size_t t = 0; t < pattern_rows[b].size(); ++t) {
          const int a = pattern_rows[b][t];
          if (a == b) {
            for (int r = 0; r <= q; ++r) permuted_entry[k++] = pp[start[b] + r] + (q - r);
            continue;
          }
          const int prefix = pair_prefix[pair_begin_of[b] + static_cast<int>(t)];
          if (start[a] < start[b]) {  // column block a, rows of b
            for (int r = 0; r < dims[a]; ++r)
              permuted_entry[k++] = pp[start[a] + r] + (dims[a] - r) + prefix + q;
          } else {  // column block b, rows of a
            const int base = pp[start[b] + q] + (dims[b] - q) + prefix;
            for (int r = 0; r < dims[a]; ++r) permuted_entry[k++] = base + r;
          }
        }
    return true;
  }

  // J^T J (into hessian), the gradient J^T e and the undamped diagonal from
  // an evaluation with Jacobians; false when they are not finite.
  bool Assemble(const Evaluation& evaluation) {
    auto* x = static_cast<double*>(hessian->x);
    const auto* p = static_cast<const int*>(hessian->p);
    std::fill(x, x + p[n], 0.0);
    gradient.setZero();
    const size_t num_factors = evaluation.jacobians.size();
    for (size_t f = 0; f < num_factors; ++f) {
      const Eigen::MatrixXd& jacobian = evaluation.jacobians[f];
      const Eigen::VectorXd& error = evaluation.errors[f];
      // The common factor shapes (bounding slice 4x8, odometry 3x6, priors)
      // get fixed-size products: Eigen's dynamic lazy product runs a scalar
      // loop per entry (20 % of a one-step O-SLAM proposal's instructions).
      const int rows = static_cast<int>(jacobian.rows()), columns = factor_columns[f];
      if (rows == 4 && columns == 8)
        AssembleFactor<4, 8>(jacobian, error, f, x, p);
      else if (rows == 3 && columns == 6)
        AssembleFactor<3, 6>(jacobian, error, f, x, p);
      else if (rows == 3 && columns == 3)
        AssembleFactor<3, 3>(jacobian, error, f, x, p);
      else if (rows == 2 && columns == 2)
        AssembleFactor<2, 2>(jacobian, error, f, x, p);
      else
        AssembleFactor<Eigen::Dynamic, Eigen::Dynamic>(jacobian, error, f, x, p);
    }
    for (int c = 0; c < n; ++c) diagonal[c] = x[diagonal_position[c]];
    return gradient.allFinite() && diagonal.allFinite();
  }

  // Adds factor f's J^T J and J^T e (J: Rows x Columns, or dynamic) into
  // the hessian's entries `x` (column pointers `p`) and the gradient.
  template <int Rows, int Columns>
  void AssembleFactor(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& error, size_t f,
                      double* x, const int* p) {
    using Local = Eigen::Matrix<double, Columns, Columns>;
    using LocalGradient = Eigen::Matrix<double, Columns, 1>;
    const int columns = factor_columns[f];
    const Eigen::Map<const Eigen::Matrix<double, Rows, Columns>> j(jacobian.data(), jacobian.rows(),
                                                                   columns);
    const Eigen::Map<const Eigen::Matrix<double, Rows, 1>> e(error.data(), error.size());
    Eigen::Map<Local> local(local_hessian.data(), columns, columns);
    Eigen::Map<LocalGradient> local_g(local_gradient.data(), columns);
    // A plain (lazy) product: Eigen's blocked GEMM, which it would pick for
    // 8x4x8, costs more in set-up than the product.
    local.noalias() = j.transpose().lazyProduct(j);
    local_g.noalias() = j.transpose().lazyProduct(e);
    for (int k = pair_begin[f]; k < pair_begin[f + 1]; ++k) {
      const BlockPair& pair = pairs[k];
      for (int q = 0; q < pair.b_dim; ++q) {
        double* out = x + p[pair.b_offset + q] + pair.row_prefix;
        const double* in = local.data() + (pair.b_column + q) * columns + pair.a_column;
        const int count = pair.diagonal ? q + 1 : pair.a_dim;
        // Blocks are 1-3 rows high: unrolled, not a short loop with
        // vector set-up and remainder handling.
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
          gradient[pair.a_offset + r] += local_g[pair.a_column + r];
    }
  }

  // Factors J^T J + lambda D (lambda = 0: undamped); false if not positive definite.
  bool Factorize(double lambda, const SolverOptions& options) {
    auto* x = static_cast<double*>(hessian->x);
    for (int c = 0; c < n; ++c)
      x[diagonal_position[c]] = diagonal[c] + lambda * DampingScale(diagonal[c], options);
    auto* px = static_cast<double*>(permuted->x);
    const int hnz = static_cast<const int*>(hessian->p)[n];
    for (int k = 0; k < hnz; ++k) px[permuted_entry[k]] = x[k];
    for (int c = 0; c < n; ++c) x[diagonal_position[c]] = diagonal[c];
    const int ok = cholmod_factorize(permuted, factor, &cc);
    return ok && cc.status == CHOLMOD_OK && factor->minor == factor->n;
  }

  // Solves (factored matrix) out = in.
  bool SolveFactored(const Eigen::VectorXd& in, Eigen::VectorXd* out) {
    auto* bx = static_cast<double*>(rhs->x);
    for (int c = 0; c < n; ++c) bx[inverse_permutation[c]] = in[c];
    if (!cholmod_solve2(CHOLMOD_A, factor, rhs, nullptr, &solution, nullptr, &work_y, &work_e, &cc))
      return false;
    const auto* sx = static_cast<const double*>(solution->x);
    out->resize(n);
    for (int c = 0; c < n; ++c) (*out)[c] = sx[inverse_permutation[c]];
    return out->allFinite();
  }

  // Least-squares step by SPQR on [J; sqrt(lambda D)] delta = [-e; 0]. With
  // lambda = 0 also returns ||r||^2 and sum log|r_ii| (spec §5.3).
  bool SolveByQr(double lambda, const SolverOptions& options, Eigen::VectorXd* delta,
                 double* squared_residual, double* log_abs_det_r) {
    const int rows = m + (lambda > 0 ? n : 0);
    size_t nnz = 0;
    const auto& jacobians = current.jacobians;
    const auto& errors = current.errors;
    for (const auto& jacobian : jacobians) nnz += jacobian.size();
    cholmod_triplet* triplet =
        cholmod_l_allocate_triplet(rows, n, nnz + n, 0, CHOLMOD_REAL, &cc_long);
    auto* ti = static_cast<SuiteSparse_long*>(triplet->i);
    auto* tj = static_cast<SuiteSparse_long*>(triplet->j);
    auto* tx = static_cast<double*>(triplet->x);
    size_t k = 0;
    cholmod_dense* b = cholmod_l_zeros(rows, 1, CHOLMOD_REAL, &cc_long);
    auto* bx = static_cast<double*>(b->x);
    for (size_t f = 0; f < jacobians.size(); ++f) {
      const int row0 = factor_row[f];
      for (int r = 0; r < errors[f].size(); ++r) bx[row0 + r] = -errors[f][r];
      for (int pk = pair_begin[f]; pk < pair_begin[f + 1]; ++pk) {
        const BlockPair& pair = pairs[pk];
        if (!pair.diagonal) continue;  // each free key has exactly one diagonal pair
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
    cholmod_sparse* a = cholmod_l_triplet_to_sparse(triplet, k, &cc_long);
    cholmod_l_free_triplet(&triplet, &cc_long);
    cholmod_dense* z = nullptr;
    cholmod_sparse* r = nullptr;
    SuiteSparse_long* e = nullptr;
    const bool want_r = log_abs_det_r != nullptr;
    const SuiteSparse_long rank = SuiteSparseQR<double>(
        SPQR_ORDERING_DEFAULT, SPQR_NO_TOL, n, 2, a, nullptr, b, nullptr, &z, want_r ? &r : nullptr,
        want_r ? &e : nullptr, nullptr, nullptr, nullptr, &cc_long);
    bool ok = z != nullptr && rank == n;
    if (ok) {
      *delta = Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(z->x), n);
      ok = delta->allFinite();
    }
    if (ok && squared_residual) {
      // ||J delta + e||^2 over the J rows (the damping rows are absent here).
      double sum = 0.0;
      for (size_t f = 0; f < jacobians.size(); ++f) {
        Eigen::VectorXd residual = errors[f];
        for (int pk = pair_begin[f]; pk < pair_begin[f + 1]; ++pk) {
          const BlockPair& pair = pairs[pk];
          if (pair.diagonal)
            residual += jacobians[f].middleCols(pair.a_column, pair.a_dim) *
                        delta->segment(pair.a_offset, pair.a_dim);
        }
        sum += residual.squaredNorm();
      }
      *squared_residual = sum;
    }
    if (ok && want_r) {
      // |det R| = prod |r_jj|, whatever the column permutation E.
      const auto* rp = static_cast<const SuiteSparse_long*>(r->p);
      const auto* ri = static_cast<const SuiteSparse_long*>(r->i);
      const auto* rx = static_cast<const double*>(r->x);
      double sum = 0.0;
      for (int j = 0; j < n && ok; ++j) {
        double d = 0.0;
        for (SuiteSparse_long q = rp[j]; q < rp[j + 1]; ++q)
          if (ri[q] == j) d = rx[q];
        ok = d != 0.0;
        sum += std::log(std::abs(d));
      }
      *log_abs_det_r = sum;
    }
    if (z) cholmod_l_free_dense(&z, &cc_long);
    if (r) cholmod_l_free_sparse(&r, &cc_long);
    if (e) cholmod_l_free(n, sizeof(SuiteSparse_long), e, &cc_long);
    cholmod_l_free_sparse(&a, &cc_long);
    cholmod_l_free_dense(&b, &cc_long);
    return ok;
  }

  // `from` moved by `step` (entries of delta) into `to`.
  void Retract(const Values& from, const Eigen::VectorXd& step, Values* to) const {
    *to = from;
    for (size_t key = 0; key < free_index.size(); ++key) {
      const int v = free_index[key];
      if (v >= 0) to->Retract(static_cast<int>(key), step.data() + offsets[v]);
    }
  }
};

// ---------------------------------------------------------------------------

SparseSolver::SparseSolver(const SolverOptions& options)
    : options_(options), impl_(std::make_unique<Impl>()) {}
SparseSolver::~SparseSolver() = default;

void SparseSolver::ClearCache() {
  impl_->FreeStructure();
  impl_->compared_num_blocks = -1;
  impl_->linearizer.Clear();
}

void SparseSolver::ClearLinearizations() {
  impl_->linearizer.Forget();
}

SolveResult SparseSolver::Solve(FactorGraph* graph) {
  const auto start = Clock::now();
  const SerialOpenMpScope serial_openmp;
  SolveResult result;
  SolverSummary& summary = result.summary;
  Impl& impl = *impl_;
  impl.linearizer.ResetCounts();
  auto finish = [&](TerminationType type, const std::string& message) {
    summary.termination = type;
    summary.message = message;
    summary.reused_linearizations = impl.linearizer.reused();
    summary.computed_linearizations = impl.linearizer.computed();
    summary.total_time_s = Seconds(start);
    return result;
  };
  std::string why;
  if (!options_.Validate(&why)) return finish(TerminationType::kFailure, "invalid options: " + why);
  if (!graph) return finish(TerminationType::kFailure, "no graph");
  summary.num_factors = static_cast<int>(graph->factors().size());

  double analyze_s = 0.0;
  impl.requested_ordering = options_.ordering;
  impl.independent_of_history = options_.independent_of_history;
  impl.linearizer.set_reuse(options_.reuse_linearizations);
  if (!impl.SetUp(*graph, options_.reuse_symbolic_analysis, &summary.reused_symbolic_analysis,
                  &analyze_s, &why))
    return finish(TerminationType::kFailure, why);
  summary.analyze_time_s = analyze_s;
  summary.ordering = impl.ordering_used;
  summary.num_residuals = impl.m;
  summary.num_parameters = impl.n;
  const bool use_qr = options_.linear_solver == LinearSolverType::kSparseQR;

  Values& values = graph->mutable_values();
  Values trial;
  double cost = 0.0;
  // OSLAM_SOLVER_TRACE=1 prints the orderings tried and every LM step to stderr
  // (a diagnostic for convergence work; off by default).
  const bool trace = std::getenv("OSLAM_SOLVER_TRACE") != nullptr;
  const auto t_first = Clock::now();
  const bool first_ok = impl.linearizer.Evaluate(*graph, values, true, &impl.current, &cost) &&
                        impl.Assemble(impl.current);
  summary.linearize_time_s += Seconds(t_first);
  if (!first_ok)
    return finish(TerminationType::kFailure,
                  "a factor cannot be evaluated at the initial values (e.g. an object has no "
                  "image from a pose that saw it)");
  summary.initial_cost = summary.final_cost = cost;

  // The line search beyond an accepted step (StepExtrapolation). On return
  // `step`, `trial`, impl.trial and `*trial_cost` describe the step taken;
  // the count of stretches is returned.
  Values stretched_values;
  auto extrapolate = [&](double slope, Eigen::VectorXd* step, double* trial_cost) {
    StepExtrapolation search(cost, slope, *trial_cost, options_.max_step_extrapolation);
    const auto& factors = graph->factors();
    if (impl.stretched.errors.size() != factors.size()) impl.stretched.Resize(factors.size());
    // Candidates are evaluated without Jacobians (most are rejected); the
    // point finally taken is evaluated once more with them.
    for (size_t f = 0; f < factors.size(); ++f)
      impl.stretched.errors[f].resize(impl.current.errors[f].size());
    Eigen::VectorXd scaled;
    for (double multiple; search.Next(&multiple);) {
      scaled = multiple * *step;
      impl.Retract(values, scaled, &stretched_values);
      double stretched_cost = 0.0;
      const bool evaluated = impl.linearizer.Evaluate(*graph, stretched_values, false,
                                                      &impl.stretched, &stretched_cost);
      if (search.Report(evaluated, stretched_cost)) std::swap(trial, stretched_values);
    }
    if (search.stretches() == 0) return 0;
    double check = 0.0;
    if (!impl.linearizer.Evaluate(*graph, trial, true, &impl.trial, &check)) {
      // Cannot happen where the cost could be evaluated; back to the LM step.
      impl.Retract(values, *step, &trial);
      impl.linearizer.Evaluate(*graph, trial, true, &impl.trial, trial_cost);
      return 0;
    }
    *trial_cost = check;
    *step *= search.multiple();
    return search.stretches();
  };

  LevenbergMarquardtStrategy lm(options_);
  int extrapolations = 0;
  TerminationType termination = TerminationType::kMaxIterations;
  std::string message = "reached max_iterations";
  Eigen::VectorXd delta;
  while (true) {
    if (lm.GradientConverged(impl.gradient)) {
      termination = TerminationType::kConverged;
      message = "gradient tolerance reached";
      break;
    }
    if (summary.iterations >= options_.max_iterations) break;
    ++summary.iterations;
    const double lambda = lm.damping();
    const auto t_factor = Clock::now();
    bool solved;
    if (use_qr) {
      solved = impl.SolveByQr(lambda, options_, &delta, nullptr, nullptr);
    } else {
      solved = impl.Factorize(lambda, options_) && impl.SolveFactored(-impl.gradient, &delta);
    }
    summary.factorize_time_s += Seconds(t_factor);
    bool accepted = false;
    double new_cost = 0.0, rho = 0.0;
    if (solved) {
      const double predicted = lm.PredictedDecrease(impl.gradient, impl.diagonal, delta);
      impl.Retract(values, delta, &trial);
      const auto t_cost = Clock::now();
      const bool evaluated = impl.linearizer.Evaluate(*graph, trial, true, &impl.trial, &new_cost);
      summary.linearize_time_s += Seconds(t_cost);
      if (evaluated && predicted > 0.0) {
        rho = (cost - new_cost) / predicted;
        accepted = lm.Accepts(rho);
      }
      if (accepted && lm.Extrapolates(rho))
        extrapolations += extrapolate(impl.gradient.dot(delta), &delta, &new_cost);
    }
    if (trace) {
      Eigen::Index where = 0;
      if (solved) delta.cwiseAbs().maxCoeff(&where);
      std::fprintf(stderr,
                   "it %d lambda %.3g cost %.10g -> %.10g rho %.3f |d| %.3g at %ld/%d %s (%d "
                   "stretches)\n",
                   summary.iterations, lambda, cost, new_cost, rho,
                   solved ? delta.lpNorm<Eigen::Infinity>() : -1.0, long(where), impl.n,
                   accepted ? "ok" : "REJ", extrapolations);
    }
    if (accepted) {
      const auto t_assemble = Clock::now();
      // Non-finite Jacobians at a point with a finite cost: a failed step.
      accepted = impl.Assemble(impl.trial);
      if (!accepted) impl.Assemble(impl.current);
      summary.linearize_time_s += Seconds(t_assemble);
    }
    if (!accepted) {
      if (lm.StepRejected()) continue;
      message = "no further decrease possible (damping limit)";
      termination = TerminationType::kConverged;
      break;
    }
    std::swap(values, trial);
    std::swap(impl.current, impl.trial);
    ++summary.successful_steps;
    const double old_cost = cost;
    cost = new_cost;
    lm.StepAccepted(rho);
    if (lm.StepConverged(delta)) {
      termination = TerminationType::kConverged;
      message = "step tolerance reached";
      break;
    }
    if (lm.CostConverged(old_cost, cost)) {
      termination = TerminationType::kConverged;
      message = "function tolerance reached";
      break;
    }
  }
  summary.final_cost = cost;
  summary.step_extrapolations = extrapolations;

  // The undamped Gauss-Newton system at the final point: evidence, the
  // factor later used for covariances, and the final step of Algorithm 1
  // (steps 4-5: theta* = theta0 + delta).
  const auto t_evidence = Clock::now();
  const bool factored = impl.Factorize(0.0, options_);
  impl.factor_is_final = factored;
  Evidence& evidence = result.evidence;
  evidence.num_rows = impl.m;
  evidence.num_parameters = impl.n;
  for (const auto& factor : graph->factors()) evidence.log_det_noise += factor->LogDetCovariance();
  evidence.normaliser = 0.5 * (impl.n - impl.m) * kLog2Pi;
  bool have_step = false;
  const Evaluation* at_final_values = &impl.current;  // errors at `values`
  if (use_qr) {
    double log_abs_det_r = 0.0;
    have_step = impl.SolveByQr(0.0, options_, &delta, &evidence.squared_residual,
                               options_.compute_evidence ? &log_abs_det_r : nullptr);
    evidence.valid = have_step && options_.compute_evidence;
    evidence.log_det_information = 2.0 * log_abs_det_r;
  } else if (factored && impl.SolveFactored(impl.gradient, &delta)) {
    // min ||e + J d||^2 = ||e||^2 - g' H^{-1} g, at d = -H^{-1} g.
    have_step = true;
    evidence.squared_residual = std::max(0.0, 2.0 * cost - impl.gradient.dot(delta));
    delta = -delta;
    if (options_.compute_evidence) {
      evidence.log_det_information = LogDetOfFactor(impl.factor);
      evidence.valid = std::isfinite(evidence.log_det_information);
    }
  }
  if (evidence.valid)
    evidence.log_evidence = -0.5 * evidence.squared_residual - 0.5 * evidence.log_det_noise -
                            0.5 * evidence.log_det_information + evidence.normaliser;
  if (have_step && options_.apply_final_step && termination != TerminationType::kFailure) {
    impl.Retract(values, delta, &trial);
    double new_cost = 0.0;
    if (impl.linearizer.Evaluate(*graph, trial, false, &impl.trial, &new_cost) &&
        new_cost <= cost) {
      std::swap(values, trial);
      at_final_values = &impl.trial;
      summary.final_cost = new_cost;
    }
  }
  if (termination != TerminationType::kFailure) {
    result.squared_errors.resize(at_final_values->errors.size());
    for (size_t f = 0; f < at_final_values->errors.size(); ++f)
      result.squared_errors[f] = at_final_values->errors[f].squaredNorm();
  }
  summary.evidence_time_s = Seconds(t_evidence);
  if (!factored && termination != TerminationType::kFailure) {
    message +=
        "; the final information matrix is not positive definite (no evidence or "
        "covariance)";
  }
  return finish(termination, message);
}

bool SparseSolver::MarginalCovariances(const std::vector<std::vector<int>>& key_groups,
                                       std::vector<Eigen::MatrixXd>* blocks, std::string* why) {
  const SerialOpenMpScope serial_openmp;
  Impl& impl = *impl_;
  if (!impl.factor_is_final) {
    if (why) *why = "no valid final factorisation (call Solve first)";
    return false;
  }
  blocks->assign(key_groups.size(), Eigen::MatrixXd());
  // Scalar columns of each group (-1 for the rows/columns of fixed keys).
  std::vector<std::vector<int>> columns(key_groups.size());
  for (size_t g = 0; g < key_groups.size(); ++g) {
    for (int key : key_groups[g]) {
      if (key < 0 || key >= static_cast<int>(impl.free_index.size())) {
        if (why) *why = "unknown key " + std::to_string(key);
        return false;
      }
      const int v = impl.free_index[key];
      const int dim = v >= 0 ? impl.pattern_dims[v] : 0;
      if (v < 0) {
        // Fixed: its dimension is not in the pattern; ask the key's size via
        // the Jacobian bookkeeping is not possible here, so callers pass free keys.
        if (why) *why = "key " + std::to_string(key) + " is fixed";
        return false;
      }
      for (int r = 0; r < dim; ++r) columns[g].push_back(impl.offsets[v] + r);
    }
  }
  // Solve H X = E for batches of unit columns; pick the groups' rows.
  constexpr int kBatch = 64;
  size_t g = 0;
  while (g < key_groups.size()) {
    size_t end = g;
    int width = 0;
    while (end < key_groups.size() &&
           (width == 0 || width + static_cast<int>(columns[end].size()) <= kBatch))
      width += static_cast<int>(columns[end++].size());
    cholmod_dense* unit = cholmod_zeros(impl.n, width, CHOLMOD_REAL, &impl.cc);
    auto* ux = static_cast<double*>(unit->x);
    int c = 0;
    for (size_t h = g; h < end; ++h)
      for (int column : columns[h])
        ux[static_cast<size_t>(c++) * impl.n + impl.inverse_permutation[column]] = 1.0;
    // With H = L L' (the permuted matrix is factored in its natural order),
    // H^-1 = L^-T L^-1, so a block is Y' Y with Y = L^-1 E: a forward solve
    // only, half the work of solving with H. An LDL' factor solves with H.
    const bool forward_only = impl.factor->is_ll;
    cholmod_dense* x =
        cholmod_solve(forward_only ? CHOLMOD_L : CHOLMOD_A, impl.factor, unit, &impl.cc);
    cholmod_free_dense(&unit, &impl.cc);
    if (!x) {
      if (why) *why = "CHOLMOD solve failed";
      return false;
    }
    const auto* xx = static_cast<const double*>(x->x);
    c = 0;
    for (size_t h = g; h < end; ++h) {
      const int size = static_cast<int>(columns[h].size());
      Eigen::MatrixXd& block = (*blocks)[h];
      if (forward_only) {
        const Eigen::Map<const Eigen::MatrixXd> y(xx + static_cast<size_t>(c) * impl.n, impl.n,
                                                  size);
        block = y.transpose() * y;
      } else {
        block.resize(size, size);
        for (int q = 0; q < size; ++q)
          for (int r = 0; r < size; ++r)
            block(r, q) =
                xx[static_cast<size_t>(c + q) * impl.n + impl.inverse_permutation[columns[h][r]]];
        block = 0.5 * (block + block.transpose()).eval();
      }
      c += size;
    }
    cholmod_free_dense(&x, &impl.cc);
    g = end;
  }
  return true;
}

}  // namespace oslam

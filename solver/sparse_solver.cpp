#include "solver/sparse_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include <cholmod.h>
#include <SuiteSparseQR.hpp>

#include "solver/levenberg_marquardt.h"
#include "solver/linearization.h"
#include "solver/normal_equations.h"
#include "solver/serial_openmp.h"

namespace oslam {

namespace {

constexpr double kLog2Pi = 1.8378770664093454836;

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
  NormalEquations normal;
  cholmod_common cc_long;  // SPQR works with SuiteSparse_long indices
  Linearizer linearizer;
  // Errors and Jacobians of every factor at the current point, and at the
  // trial point of a step (swapped in when the step is accepted, so an
  // accepted step costs one evaluation, not two).
  Evaluation current, trial;
  Evaluation stretched;  // a line search's candidate (SolverOptions::max_step_extrapolation)

  Impl() {
    UseOneBlasThread();
    cholmod_l_start(&cc_long);
    cc_long.print = 0;
    cc_long.error_handler = nullptr;
  }
  ~Impl() { cholmod_l_finish(&cc_long); }

  // Least-squares step by SPQR on [J; sqrt(lambda D)] delta = [-e; 0]. With
  // lambda = 0 also returns ||r||^2 and sum log|r_ii| (spec §5.3).
  bool SolveByQr(double lambda, const SolverOptions& options, Eigen::VectorXd* delta,
                 double* squared_residual, double* log_abs_det_r) {
    const ProblemLayout& layout = normal.layout();
    const int m = layout.m, n = normal.pattern().n;
    const std::vector<int>& factor_row = layout.factor_row;
    const std::vector<int>& pair_begin = layout.pair_begin;
    const std::vector<BlockPair>& pairs = layout.pairs;
    const Eigen::VectorXd& diagonal = normal.diagonal();
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
    const std::vector<int>& free_index = normal.layout().free_index;
    const std::vector<int>& offsets = normal.pattern().offsets;
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
  impl_->normal.Clear();
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
  impl.linearizer.set_reuse(options_.reuse_linearizations);
  NormalEquations& normal = impl.normal;
  if (!normal.SetUp(*graph, options_.ordering, options_.independent_of_history,
                    options_.reuse_symbolic_analysis, &summary.reused_symbolic_analysis, &analyze_s,
                    &why))
    return finish(TerminationType::kFailure, why);
  summary.analyze_time_s = analyze_s;
  summary.ordering = normal.ordering_used();
  const ProblemLayout& layout = normal.layout();
  const int m = layout.m, n = normal.pattern().n;
  summary.num_residuals = m;
  summary.num_parameters = n;
  const auto& factors = graph->factors();
  for (Evaluation* evaluation : {&impl.current, &impl.trial}) {
    evaluation->Resize(factors.size());
    for (size_t f = 0; f < factors.size(); ++f)
      evaluation->Shape(f, layout.factor_rows(f), layout.factor_columns[f]);
  }
  const bool use_qr = options_.linear_solver == LinearSolverType::kSparseQR;

  Values& values = graph->mutable_values();
  Values trial;
  double cost = 0.0;
  // OSLAM_SOLVER_TRACE=1 prints the orderings tried and every LM step to stderr
  // (a diagnostic for convergence work; off by default).
  const bool trace = std::getenv("OSLAM_SOLVER_TRACE") != nullptr;
  const auto t_first = Clock::now();
  const bool first_ok = impl.linearizer.Evaluate(*graph, values, true, &impl.current, &cost) &&
                        normal.Assemble(impl.current);
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
    if (lm.GradientConverged(normal.gradient())) {
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
      solved = normal.Factorize(lambda, options_) && normal.Solve(-normal.gradient(), &delta);
    }
    summary.factorize_time_s += Seconds(t_factor);
    bool accepted = false;
    double new_cost = 0.0, rho = 0.0;
    if (solved) {
      const double predicted = lm.PredictedDecrease(normal.gradient(), normal.diagonal(), delta);
      impl.Retract(values, delta, &trial);
      const auto t_cost = Clock::now();
      const bool evaluated = impl.linearizer.Evaluate(*graph, trial, true, &impl.trial, &new_cost);
      summary.linearize_time_s += Seconds(t_cost);
      if (evaluated && predicted > 0.0) {
        rho = (cost - new_cost) / predicted;
        accepted = lm.Accepts(rho);
      }
      if (accepted && lm.Extrapolates(rho))
        extrapolations += extrapolate(normal.gradient().dot(delta), &delta, &new_cost);
    }
    if (trace) {
      Eigen::Index where = 0;
      if (solved) delta.cwiseAbs().maxCoeff(&where);
      std::fprintf(stderr,
                   "it %d lambda %.3g cost %.10g -> %.10g rho %.3f |d| %.3g at %ld/%d %s (%d "
                   "stretches)\n",
                   summary.iterations, lambda, cost, new_cost, rho,
                   solved ? delta.lpNorm<Eigen::Infinity>() : -1.0, long(where), n,
                   accepted ? "ok" : "REJ", extrapolations);
    }
    if (accepted) {
      const auto t_assemble = Clock::now();
      // Non-finite Jacobians at a point with a finite cost: a failed step.
      accepted = normal.Assemble(impl.trial);
      if (!accepted) normal.Assemble(impl.current);
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
  const bool factored = normal.Factorize(0.0, options_);
  normal.set_factor_is_final(factored);
  Evidence& evidence = result.evidence;
  evidence.num_rows = m;
  evidence.num_parameters = n;
  for (const auto& factor : graph->factors()) evidence.log_det_noise += factor->LogDetCovariance();
  evidence.normaliser = 0.5 * (n - m) * kLog2Pi;
  bool have_step = false;
  const Evaluation* at_final_values = &impl.current;  // errors at `values`
  if (use_qr) {
    double log_abs_det_r = 0.0;
    have_step = impl.SolveByQr(0.0, options_, &delta, &evidence.squared_residual,
                               options_.compute_evidence ? &log_abs_det_r : nullptr);
    evidence.valid = have_step && options_.compute_evidence;
    evidence.log_det_information = 2.0 * log_abs_det_r;
  } else if (factored && normal.Solve(normal.gradient(), &delta)) {
    // min ||e + J d||^2 = ||e||^2 - g' H^{-1} g, at d = -H^{-1} g.
    have_step = true;
    evidence.squared_residual = std::max(0.0, 2.0 * cost - normal.gradient().dot(delta));
    delta = -delta;
    if (options_.compute_evidence) {
      evidence.log_det_information = LogDetOfFactor(normal.factor());
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
  const NormalEquations& normal = impl_->normal;
  if (!normal.factor_is_final()) {
    if (why) *why = "no valid final factorisation (call Solve first)";
    return false;
  }
  blocks->assign(key_groups.size(), Eigen::MatrixXd());
  // The scalar columns of each group.
  const std::vector<int>& free_index = normal.layout().free_index;
  const BlockPattern& pattern = normal.pattern();
  const int n = pattern.n;
  cholmod_common* cc = normal.common();
  cholmod_factor* factor = normal.factor();
  const std::vector<int>& inverse_permutation = normal.inverse_permutation();
  std::vector<std::vector<int>> columns(key_groups.size());
  for (size_t g = 0; g < key_groups.size(); ++g) {
    for (int key : key_groups[g]) {
      if (key < 0 || key >= static_cast<int>(free_index.size())) {
        if (why) *why = "unknown key " + std::to_string(key);
        return false;
      }
      const int v = free_index[key];
      if (v < 0) {
        if (why) *why = "key " + std::to_string(key) + " is fixed";
        return false;
      }
      for (int r = 0; r < pattern.dims[v]; ++r) columns[g].push_back(pattern.offsets[v] + r);
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
    cholmod_dense* unit = cholmod_zeros(n, width, CHOLMOD_REAL, cc);
    auto* ux = static_cast<double*>(unit->x);
    int c = 0;
    for (size_t h = g; h < end; ++h)
      for (int column : columns[h])
        ux[static_cast<size_t>(c++) * n + inverse_permutation[column]] = 1.0;
    // With H = L L' (the permuted matrix is factored in its natural order),
    // H^-1 = L^-T L^-1, so a block is Y' Y with Y = L^-1 E: a forward solve
    // only, half the work of solving with H. An LDL' factor solves with H.
    const bool forward_only = factor->is_ll;
    cholmod_dense* x = cholmod_solve(forward_only ? CHOLMOD_L : CHOLMOD_A, factor, unit, cc);
    cholmod_free_dense(&unit, cc);
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
        const Eigen::Map<const Eigen::MatrixXd> y(xx + static_cast<size_t>(c) * n, n, size);
        block = y.transpose() * y;
      } else {
        block.resize(size, size);
        for (int q = 0; q < size; ++q)
          for (int r = 0; r < size; ++r)
            block(r, q) = xx[static_cast<size_t>(c + q) * n + inverse_permutation[columns[h][r]]];
        block = 0.5 * (block + block.transpose()).eval();
      }
      c += size;
    }
    cholmod_free_dense(&x, cc);
    g = end;
  }
  return true;
}

}  // namespace oslam

#include "solver/sparse_solver.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "solver/evidence.h"
#include "solver/levenberg_marquardt.h"
#include "solver/linearization.h"
#include "solver/normal_equations.h"
#include "solver/serial_openmp.h"
#include "solver/sparse_qr.h"

namespace oslam {

namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
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
  SparseQr qr;
  Linearizer linearizer;
  // Errors and Jacobians of every factor at the current point, and at the
  // trial point of a step (swapped in when the step is accepted, so an
  // accepted step costs one evaluation, not two).
  Evaluation current, trial;
  Evaluation stretched;  // a line search's candidate (SolverOptions::max_step_extrapolation)

  Impl() { UseOneBlasThread(); }

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
      solved = impl.qr.Solve(layout, n, impl.current, normal.diagonal(), lambda, options_, &delta,
                             nullptr, nullptr);
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
  SetEvidenceConstants(*graph, m, n, &evidence);
  bool have_step = false;
  const Evaluation* at_final_values = &impl.current;  // errors at `values`
  if (use_qr) {
    double log_abs_det_r = 0.0;
    have_step = impl.qr.Solve(layout, n, impl.current, normal.diagonal(), 0.0, options_, &delta,
                              &evidence.squared_residual,
                              options_.compute_evidence ? &log_abs_det_r : nullptr);
    evidence.valid = have_step && options_.compute_evidence;
    evidence.log_det_information = 2.0 * log_abs_det_r;
  } else if (factored && normal.Solve(normal.gradient(), &delta)) {
    have_step = true;
    evidence.squared_residual = MinimumSquaredResidual(cost, normal.gradient(), delta);
    delta = -delta;
    if (options_.compute_evidence) {
      evidence.log_det_information = LogDetOfFactor(normal.factor());
      evidence.valid = std::isfinite(evidence.log_det_information);
    }
  }
  CompleteEvidence(&evidence);
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
  return CovarianceBlocks(normal.factor(), normal.inverse_permutation(), normal.common(), columns,
                          blocks, why);
}

}  // namespace oslam

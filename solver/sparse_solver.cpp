#include "solver/sparse_solver.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "core/text.h"
#include "solver/evidence.h"
#include "solver/levenberg_marquardt.h"
#include "solver/linearization.h"
#include "solver/normal_equations.h"
#include "solver/serial_openmp.h"
#include "solver/sparse_qr.h"

namespace oslam {
namespace {

using Clock = std::chrono::steady_clock;

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
  if (threads < 0) return fail("threads must be >= 0");
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

// The solver's state kept across solves (the back ends' structure and work
// space, the kept linearisations) and the phases of one Solve: set-up, the
// Levenberg-Marquardt iterations (their policy: levenberg_marquardt.h) and
// the undamped system at the final point.
struct SparseSolver::Impl {
  NormalEquations normal;
  SparseQr qr;
  Linearizer linearizer;
  // Errors and Jacobians of every factor at the current point, and at the
  // trial point of a step (swapped in when the step is accepted, so an
  // accepted step costs one evaluation, not two); a line search's candidate.
  Evaluation current, trial, stretched;
  int shaped_generation = -1;  // the back end's layout current and trial are shaped for
  Values trial_values, stretched_values;

  // What one LM iteration did (for the minimiser and the trace).
  struct Step {
    bool solved = false, accepted = false;
    double new_cost = 0.0, rho = 0.0;
  };

  bool SetUp(const SolverOptions& options, const FactorGraph& graph, SolverSummary* summary,
             std::string* why);
  TerminationType Minimize(const SolverOptions& options, FactorGraph* graph, double* cost,
                           SolverSummary* summary, std::string* message);
  Step TryStep(const SolverOptions& options, const LevenbergMarquardtStrategy& lm,
               const FactorGraph& graph, double cost, Eigen::VectorXd* delta,
               SolverSummary* summary);
  int Extrapolate(const SolverOptions& options, const FactorGraph& graph, double cost, double slope,
                  Eigen::VectorXd* step, double* trial_cost);
  void SolveFinalSystem(const SolverOptions& options, FactorGraph* graph, double cost,
                        SolveResult* result, std::string* message);
  // The damped step, by the back end the options name.
  bool SolveDamped(const SolverOptions& options, double lambda, Eigen::VectorXd* delta);
  // `from` moved by `step` (entries of delta) into `to`.
  void Retract(const Values& from, const Eigen::VectorXd& step, Values* to) const;
};

void SparseSolver::Impl::Retract(const Values& from, const Eigen::VectorXd& step,
                                 Values* to) const {
  *to = from;
  const std::vector<int>& free_index = normal.layout().free_index;
  const std::vector<int>& offsets = normal.pattern().offsets;
  for (size_t key = 0; key < free_index.size(); ++key) {
    const int v = free_index[key];
    if (v >= 0) to->Retract(static_cast<int>(key), step.data() + offsets[v]);
  }
}

bool SparseSolver::Impl::SetUp(const SolverOptions& options, const FactorGraph& graph,
                               SolverSummary* summary, std::string* why) {
  linearizer.set_reuse(options.reuse_linearizations);
  linearizer.set_threads(options.threads);
  double analyze_s = 0.0;
  if (!normal.SetUp(graph, options.ordering, options.independent_of_history,
                    options.reuse_symbolic_analysis, &summary->reused_symbolic_analysis, &analyze_s,
                    why))
    return false;
  summary->analyze_time_s = analyze_s;
  summary->ordering = normal.ordering_used();
  const ProblemLayout& layout = normal.layout();
  summary->num_residuals = layout.m;
  summary->num_parameters = normal.pattern().n;
  if (shaped_generation != normal.layout_generation()) {
    const size_t num_factors = layout.factor_columns.size();
    for (Evaluation* evaluation : {&current, &trial}) {
      evaluation->Resize(num_factors);
      for (size_t f = 0; f < num_factors; ++f)
        evaluation->Shape(f, layout.factor_rows(f), layout.factor_columns[f]);
    }
    shaped_generation = normal.layout_generation();
  }
  return true;
}

bool SparseSolver::Impl::SolveDamped(const SolverOptions& options, double lambda,
                                     Eigen::VectorXd* delta) {
  if (options.linear_solver == LinearSolverType::kSparseQR)
    return qr.Solve(normal.layout(), normal.pattern().n, current, normal.diagonal(), lambda,
                    options, delta, nullptr, nullptr);
  return normal.Factorize(lambda, options) && normal.Solve(-normal.gradient(), delta);
}

TerminationType SparseSolver::Impl::Minimize(const SolverOptions& options, FactorGraph* graph,
                                             double* cost, SolverSummary* summary,
                                             std::string* message) {
  // OSLAM_SOLVER_TRACE=1 prints the orderings tried and every LM step to
  // stderr (a diagnostic for convergence work; off by default).
  const bool trace = std::getenv("OSLAM_SOLVER_TRACE") != nullptr;
  Values& values = graph->mutable_values();
  LevenbergMarquardtStrategy lm(options);
  Eigen::VectorXd delta;
  *message = "reached max_iterations";
  while (true) {
    if (lm.GradientConverged(normal.gradient())) {
      *message = "gradient tolerance reached";
      return TerminationType::kConverged;
    }
    if (summary->iterations >= options.max_iterations) return TerminationType::kMaxIterations;
    ++summary->iterations;
    const double lambda = lm.damping();
    Step step = TryStep(options, lm, *graph, *cost, &delta, summary);
    if (trace) {
      Eigen::Index where = 0;
      if (step.solved) delta.cwiseAbs().maxCoeff(&where);
      std::fprintf(stderr,
                   "it %d lambda %.3g cost %.10g -> %.10g rho %.3f |d| %.3g at %ld/%d %s (%d "
                   "stretches)\n",
                   summary->iterations, lambda, *cost, step.new_cost, step.rho,
                   step.solved ? delta.lpNorm<Eigen::Infinity>() : -1.0, long(where),
                   normal.pattern().n, step.accepted ? "ok" : "REJ", summary->step_extrapolations);
    }
    if (step.accepted) {
      const auto t_assemble = Clock::now();
      // Non-finite Jacobians at a point with a finite cost: a failed step.
      step.accepted = normal.Assemble(trial);
      if (!step.accepted) normal.Assemble(current);
      summary->linearize_time_s += SecondsSince(t_assemble);
    }
    if (!step.accepted) {
      if (lm.StepRejected()) continue;
      *message = "no further decrease possible (damping limit)";
      return TerminationType::kConverged;
    }
    std::swap(values, trial_values);
    std::swap(current, trial);
    ++summary->successful_steps;
    const double old_cost = *cost;
    *cost = step.new_cost;
    lm.StepAccepted(step.rho);
    if (lm.StepConverged(delta)) {
      *message = "step tolerance reached";
      return TerminationType::kConverged;
    }
    if (lm.CostConverged(old_cost, *cost)) {
      *message = "function tolerance reached";
      return TerminationType::kConverged;
    }
  }
}

// Solves the damped system at the current point, evaluates the step
// (values + delta into trial_values and `trial`) and decides on it by its
// gain ratio, stretching it when the policy says so.
SparseSolver::Impl::Step SparseSolver::Impl::TryStep(const SolverOptions& options,
                                                     const LevenbergMarquardtStrategy& lm,
                                                     const FactorGraph& graph, double cost,
                                                     Eigen::VectorXd* delta,
                                                     SolverSummary* summary) {
  Step step;
  const auto t_factor = Clock::now();
  step.solved = SolveDamped(options, lm.damping(), delta);
  summary->factorize_time_s += SecondsSince(t_factor);
  if (!step.solved) return step;
  const double predicted = lm.PredictedDecrease(normal.gradient(), normal.diagonal(), *delta);
  Retract(graph.values(), *delta, &trial_values);
  const auto t_cost = Clock::now();
  const bool evaluated = linearizer.Evaluate(graph, trial_values, true, &trial, &step.new_cost);
  summary->linearize_time_s += SecondsSince(t_cost);
  if (evaluated && predicted > 0.0) {
    step.rho = (cost - step.new_cost) / predicted;
    step.accepted = lm.Accepts(step.rho);
  }
  if (step.accepted && lm.Extrapolates(step.rho))
    summary->step_extrapolations +=
        Extrapolate(options, graph, cost, normal.gradient().dot(*delta), delta, &step.new_cost);
  return step;
}

// The line search beyond an accepted step (StepExtrapolation). On return
// `step`, trial_values, `trial` and `*trial_cost` describe the step taken;
// returns the count of stretches.
int SparseSolver::Impl::Extrapolate(const SolverOptions& options, const FactorGraph& graph,
                                    double cost, double slope, Eigen::VectorXd* step,
                                    double* trial_cost) {
  StepExtrapolation search(cost, slope, *trial_cost, options.max_step_extrapolation);
  const auto& factors = graph.factors();
  if (stretched.errors.size() != factors.size()) stretched.Resize(factors.size());
  // Candidates are evaluated without Jacobians (most are rejected); the
  // point finally taken is evaluated once more with them.
  for (size_t f = 0; f < factors.size(); ++f) stretched.errors[f].resize(current.errors[f].size());
  Eigen::VectorXd scaled;
  for (double multiple; search.Next(&multiple);) {
    scaled = multiple * *step;
    Retract(graph.values(), scaled, &stretched_values);
    double stretched_cost = 0.0;
    const bool evaluated =
        linearizer.Evaluate(graph, stretched_values, false, &stretched, &stretched_cost);
    if (search.Report(evaluated, stretched_cost)) std::swap(trial_values, stretched_values);
  }
  if (search.stretches() == 0) return 0;
  double check = 0.0;
  if (!linearizer.Evaluate(graph, trial_values, true, &trial, &check)) {
    // Cannot happen where the cost could be evaluated; back to the LM step.
    Retract(graph.values(), *step, &trial_values);
    linearizer.Evaluate(graph, trial_values, true, &trial, trial_cost);
    return 0;
  }
  *trial_cost = check;
  *step *= search.multiple();
  return search.stretches();
}

// The undamped Gauss-Newton system at the final point: the evidence, the
// factor later used for covariances, and the final step of Algorithm 1
// (steps 4-5: theta* = theta0 + delta), taken if it does not raise the cost.
void SparseSolver::Impl::SolveFinalSystem(const SolverOptions& options, FactorGraph* graph,
                                          double cost, SolveResult* result, std::string* message) {
  SolverSummary& summary = result->summary;
  const auto t_evidence = Clock::now();
  const bool factored = normal.Factorize(0.0, options);
  normal.set_factor_is_final(factored);
  Evidence& evidence = result->evidence;
  SetEvidenceConstants(*graph, normal.layout().m, normal.pattern().n, &evidence);
  bool have_step = false;
  Eigen::VectorXd delta;
  if (options.linear_solver == LinearSolverType::kSparseQR) {
    double log_abs_det_r = 0.0;
    have_step = qr.Solve(normal.layout(), normal.pattern().n, current, normal.diagonal(), 0.0,
                         options, &delta, &evidence.squared_residual,
                         options.compute_evidence ? &log_abs_det_r : nullptr);
    evidence.valid = have_step && options.compute_evidence;
    evidence.log_det_information = 2.0 * log_abs_det_r;
  } else if (factored && normal.Solve(normal.gradient(), &delta)) {
    have_step = true;
    evidence.squared_residual = MinimumSquaredResidual(cost, normal.gradient(), delta);
    delta = -delta;
    if (options.compute_evidence) {
      evidence.log_det_information = LogDetOfFactor(normal.factor());
      evidence.valid = std::isfinite(evidence.log_det_information);
    }
  }
  CompleteEvidence(&evidence);

  Values& values = graph->mutable_values();
  const Evaluation* at_final_values = &current;  // errors at `values`
  if (have_step && options.apply_final_step) {
    Retract(values, delta, &trial_values);
    double new_cost = 0.0;
    if (linearizer.Evaluate(*graph, trial_values, false, &trial, &new_cost) && new_cost <= cost) {
      std::swap(values, trial_values);
      at_final_values = &trial;
      summary.final_cost = new_cost;
    }
  }
  result->squared_errors.resize(at_final_values->errors.size());
  for (size_t f = 0; f < at_final_values->errors.size(); ++f)
    result->squared_errors[f] = at_final_values->errors[f].squaredNorm();
  summary.evidence_time_s = SecondsSince(t_evidence);
  if (!factored)
    *message +=
        "; the final information matrix is not positive definite (no evidence or "
        "covariance)";
}

// ---------------------------------------------------------------------------

SparseSolver::SparseSolver(const SolverOptions& options)
    : options_(options), impl_(std::make_unique<Impl>()) {
  UseOneBlasThread();
}

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
  // The last solve's factorisation belongs to another graph: until this
  // solve ends with a usable one, covariances and samples are refused
  // rather than taken from it.
  impl.normal.set_factor_is_final(false);
  auto finish = [&](TerminationType type, const std::string& message) {
    if (type == TerminationType::kFailure) impl.normal.set_factor_is_final(false);
    summary.termination = type;
    summary.message = message;
    summary.reused_linearizations = impl.linearizer.reused();
    summary.computed_linearizations = impl.linearizer.computed();
    summary.total_time_s = SecondsSince(start);
    return result;
  };
  std::string why;
  if (!options_.Validate(&why)) return finish(TerminationType::kFailure, "invalid options: " + why);
  if (!graph) return finish(TerminationType::kFailure, "no graph");
  summary.num_factors = static_cast<int>(graph->factors().size());
  if (!impl.SetUp(options_, *graph, &summary, &why)) return finish(TerminationType::kFailure, why);

  double cost = 0.0;
  const auto t_first = Clock::now();
  const bool first_ok =
      impl.linearizer.Evaluate(*graph, graph->values(), true, &impl.current, &cost) &&
      impl.normal.Assemble(impl.current);
  summary.linearize_time_s += SecondsSince(t_first);
  if (!first_ok)
    return finish(TerminationType::kFailure,
                  "a factor cannot be evaluated at the initial values (e.g. an object has no "
                  "image from a pose that saw it)");
  summary.initial_cost = summary.final_cost = cost;

  std::string message;
  const TerminationType termination = impl.Minimize(options_, graph, &cost, &summary, &message);
  summary.final_cost = cost;
  impl.SolveFinalSystem(options_, graph, cost, &result, &message);
  return finish(termination, message);
}

namespace {

// The scalar columns of each group of keys; false with `why` for an unknown
// or fixed key.
bool GroupColumns(const NormalEquations& normal, const std::vector<std::vector<int>>& key_groups,
                  std::vector<std::vector<int>>* columns, std::string* why) {
  const std::vector<int>& free_index = normal.layout().free_index;
  const BlockPattern& pattern = normal.pattern();
  columns->assign(key_groups.size(), {});
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
      for (int r = 0; r < pattern.dims[v]; ++r) (*columns)[g].push_back(pattern.offsets[v] + r);
    }
  }
  return true;
}

}  // namespace

bool SparseSolver::MarginalCovariances(const std::vector<std::vector<int>>& key_groups,
                                       std::vector<Eigen::MatrixXd>* blocks, std::string* why) {
  const SerialOpenMpScope serial_openmp;
  const NormalEquations& normal = impl_->normal;
  if (!normal.factor_is_final()) {
    if (why) *why = "no valid final factorisation (call Solve first)";
    return false;
  }
  blocks->assign(key_groups.size(), Eigen::MatrixXd());
  std::vector<std::vector<int>> columns;
  if (!GroupColumns(normal, key_groups, &columns, why)) return false;
  return CovarianceBlocks(normal.factor(), normal.inverse_permutation(), normal.common(), columns,
                          blocks, why);
}

Eigen::MatrixXd RootProduct(const CovarianceRoot& a, const CovarianceRoot& b) {
  Eigen::MatrixXd product = Eigen::MatrixXd::Zero(a.values.cols(), b.values.cols());
  size_t i = 0, j = 0;
  while (i < a.rows.size() && j < b.rows.size()) {
    if (a.rows[i] < b.rows[j]) {
      ++i;
    } else if (b.rows[j] < a.rows[i]) {
      ++j;
    } else {
      product.noalias() += a.values.row(static_cast<Eigen::Index>(i)).transpose() *
                           b.values.row(static_cast<Eigen::Index>(j));
      ++i, ++j;
    }
  }
  return product;
}

bool SparseSolver::CovarianceRoots(const std::vector<std::vector<int>>& key_groups,
                                   std::vector<CovarianceRoot>* roots, std::string* why) {
  const SerialOpenMpScope serial_openmp;
  const NormalEquations& normal = impl_->normal;
  if (!normal.factor_is_final()) {
    if (why) *why = "no valid final factorisation (call Solve first)";
    return false;
  }
  std::vector<std::vector<int>> columns;
  if (!GroupColumns(normal, key_groups, &columns, why)) return false;
  return oslam::CovarianceRoots(normal.factor(), normal.inverse_permutation(), normal.common(),
                                columns, roots, why);
}

void CovarianceDraws::Gather(size_t group, Eigen::MatrixXd* out) const {
  const std::vector<int>& group_rows = rows[group];
  out->resize(static_cast<Eigen::Index>(group_rows.size()), all.cols());
  for (size_t r = 0; r < group_rows.size(); ++r)
    out->row(static_cast<Eigen::Index>(r)) = all.row(group_rows[r]);
}

bool SparseSolver::CovarianceSamples(const std::vector<std::vector<int>>& key_groups, int count,
                                     unsigned long seed, CovarianceDraws* draws, std::string* why) {
  const SerialOpenMpScope serial_openmp;
  const NormalEquations& normal = impl_->normal;
  if (!normal.factor_is_final()) {
    if (why) *why = "no valid final factorisation (call Solve first)";
    return false;
  }
  if (count < 1) {
    if (why) *why = "need at least one draw";
    return false;
  }
  if (!GroupColumns(normal, key_groups, &draws->rows, why)) return false;
  return oslam::CovarianceSamples(normal.factor(), normal.inverse_permutation(), normal.common(),
                                  count, seed, &draws->all, why);
}

bool SparseSolver::CovarianceSamples(const std::vector<std::vector<int>>& key_groups, int count,
                                     unsigned long seed, std::vector<Eigen::MatrixXd>* samples,
                                     std::string* why) {
  CovarianceDraws draws;
  if (!CovarianceSamples(key_groups, count, seed, &draws, why)) return false;
  samples->assign(key_groups.size(), Eigen::MatrixXd());
  for (size_t g = 0; g < key_groups.size(); ++g) draws.Gather(g, &(*samples)[g]);
  return true;
}

}  // namespace oslam

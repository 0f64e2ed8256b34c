// The Levenberg-Marquardt policy of SparseSolver (docs/method.md §5.2-§5.4, Algorithm
// 1), apart from the minimiser loop and the linear algebra: the damping
// matrix, the damping's updates, step acceptance by gain ratio, the line
// search beyond a step that gained more than predicted, and the convergence
// tests.
//
// Each iteration solves (H + lambda D) delta = -g with H = J^T J and
// g = J^T e of the whitened problem, and D = diag(H) clamped (Marquardt's
// scaling: metres and radians need no hand tuning). The step's gain ratio
//
//   rho = (cost - cost(x + delta)) / (m(0) - m(delta)),
//   m(d) = 1/2 ||e + J d||^2,
//
// compares the actual decrease of 1/2 sum ||e||^2 with the model's.
#pragma once

#include <algorithm>

#include <Eigen/Core>

#include "solver/sparse_solver.h"

namespace oslam {

// D's entry for an entry of diag(H): the entry clamped to [min_diagonal,
// max_diagonal]. Both back ends damp with it.
inline double DampingScale(double hessian_diagonal, const SolverOptions& options) {
  return std::clamp(hessian_diagonal, options.min_diagonal, options.max_diagonal);
}

class LevenbergMarquardtStrategy {
 public:
  // Damping never falls below this after an accepted step.
  static constexpr double kMinDamping = 1e-15;
  // Gain ratio above which an accepted step is stretched by the line search
  // (SolverOptions::max_step_extrapolation): only where the step gained
  // clearly more than the model predicted. Stretching ordinary steps too
  // (rho ~ 1) made the 10k-pose solve from odometry worse (cost 0.93e6 vs
  // 0.31e6 after 50 iterations).
  static constexpr double kExtrapolationMinGainRatio = 1.25;

  // Starts at options.initial_damping (options valid).
  explicit LevenbergMarquardtStrategy(const SolverOptions& options);

  double damping() const { return lambda_; }

  // m(0) - m(delta) for the delta solving (H + lambda D) delta = -g:
  // -1/2 g'delta + 1/2 lambda delta'D delta (since H delta = -g - lambda D delta).
  double PredictedDecrease(const Eigen::VectorXd& gradient, const Eigen::VectorXd& hessian_diagonal,
                           const Eigen::VectorXd& delta) const;

  // Whether a step of gain ratio rho is taken (rho > min_relative_decrease).
  bool Accepts(double rho) const;
  // Whether an accepted step of gain ratio rho is stretched by the line
  // search (extrapolation enabled and rho > kExtrapolationMinGainRatio).
  bool Extrapolates(double rho) const;

  // After a step that was not taken: lambda *= nu, nu *= 2. False when the
  // damping now exceeds max_damping (no further decrease possible).
  bool StepRejected();
  // After a step taken with gain ratio rho (Nielsen's update): lambda *=
  // max(1/3, 1 - (2 rho - 1)^3), at least kMinDamping; nu = 2. A step the
  // model predicted well lowers the damping, a poor one raises it.
  void StepAccepted(double rho);

  // Convergence tests: max |g| <= gradient_tolerance (before a step);
  // after an accepted step, max |delta| <= step_tolerance, or a decrease
  // old_cost - new_cost <= max(function_tolerance old_cost,
  // absolute_function_tolerance).
  bool GradientConverged(const Eigen::VectorXd& gradient) const;
  bool StepConverged(const Eigen::VectorXd& delta) const;
  bool CostConverged(double old_cost, double new_cost) const;

 private:
  const SolverOptions& options_;
  double lambda_;
  double nu_ = 2.0;
};

// The line search beyond an accepted step (SolverOptions::
// max_step_extrapolation), as a sequence of multiples t of the step to
// evaluate. The cost along t delta is fitted by the parabola through f(0),
// its slope g'delta at 0 and the best f(t) so far; where the cost bends
// less than H predicts (rho near 2: weakly observed objects sliding along
// their viewing rays, where Gauss-Newton converges only linearly), the
// parabola's minimum lies beyond t, and the step is stretched to it while
// that lowers the cost. At most kMaxEvaluations candidates: the parabola's
// minimum; if the cost rises there (the parabola fits the weak directions,
// while the well-determined ones, pose chains, were already right at t = 1),
// a third of the way back to t; after a success, the refitted minimum.
//
//   StepExtrapolation search(cost, slope, step_cost, max_multiple);
//   for (double t; search.Next(&t);)
//     if (search.Report(evaluated at t delta, cost there)) keep that point;
//   // the step taken: search.multiple() delta, costing search.cost()
class StepExtrapolation {
 public:
  static constexpr int kMaxEvaluations = 3;

  // `cost`: f(0); `slope`: g'delta (no search unless negative);
  // `step_cost`: f(1); `max_multiple`: the largest t tried.
  StepExtrapolation(double cost, double slope, double step_cost, double max_multiple);

  // The next multiple to evaluate; false when the search is over.
  bool Next(double* multiple);
  // The outcome at the multiple Next gave: whether the cost could be
  // evaluated there, and its value. True when that point is the best so
  // far (the cost is below cost()), which it then becomes.
  bool Report(bool evaluated, double new_cost);

  double multiple() const { return t_; }  // of the best point so far (1: the step)
  double cost() const { return best_cost_; }
  int stretches() const { return stretches_; }  // successful candidates

 private:
  const double cost_, slope_, max_multiple_;
  double best_cost_;
  double t_ = 1.0;
  double target_ = 0.0;  // the next t to try; 0: from the parabola
  int evaluations_ = 0;
  int stretches_ = 0;
  bool done_;
};

}  // namespace oslam

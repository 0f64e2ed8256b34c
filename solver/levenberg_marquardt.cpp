#include "solver/levenberg_marquardt.h"

#include <algorithm>
#include <cmath>

namespace oslam {

LevenbergMarquardtStrategy::LevenbergMarquardtStrategy(const SolverOptions& options)
    : options_(options), lambda_(options.initial_damping) {}

double LevenbergMarquardtStrategy::PredictedDecrease(const Eigen::VectorXd& gradient,
                                                     const Eigen::VectorXd& hessian_diagonal,
                                                     const Eigen::VectorXd& delta) const {
  double damping_term = 0.0;  // delta' D delta
  for (Eigen::Index c = 0; c < delta.size(); ++c)
    damping_term += DampingScale(hessian_diagonal[c], options_) * delta[c] * delta[c];
  return -0.5 * gradient.dot(delta) + 0.5 * lambda_ * damping_term;
}

bool LevenbergMarquardtStrategy::Accepts(double rho) const {
  return rho > options_.min_relative_decrease;
}

bool LevenbergMarquardtStrategy::Extrapolates(double rho) const {
  return options_.max_step_extrapolation > 1.0 && rho > kExtrapolationMinGainRatio;
}

bool LevenbergMarquardtStrategy::StepRejected() {
  lambda_ *= nu_;
  nu_ *= 2.0;
  return !(lambda_ > options_.max_damping);
}

void LevenbergMarquardtStrategy::StepAccepted(double rho) {
  lambda_ *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
  lambda_ = std::max(lambda_, kMinDamping);
  nu_ = 2.0;
}

bool LevenbergMarquardtStrategy::GradientConverged(const Eigen::VectorXd& gradient) const {
  return gradient.lpNorm<Eigen::Infinity>() <= options_.gradient_tolerance;
}

bool LevenbergMarquardtStrategy::StepConverged(const Eigen::VectorXd& delta) const {
  return delta.lpNorm<Eigen::Infinity>() <= options_.step_tolerance;
}

bool LevenbergMarquardtStrategy::CostConverged(double old_cost, double new_cost) const {
  return old_cost - new_cost <=
         std::max(options_.function_tolerance * old_cost, options_.absolute_function_tolerance);
}

// ---------------------------------------------------------------------------

StepExtrapolation::StepExtrapolation(double cost, double slope, double step_cost,
                                     double max_multiple)
    : cost_(cost),
      slope_(slope),
      max_multiple_(max_multiple),
      best_cost_(step_cost),
      done_(!(slope < 0.0)) {}

bool StepExtrapolation::Next(double* multiple) {
  if (done_ || evaluations_ == kMaxEvaluations) return false;
  ++evaluations_;
  if (target_ == 0.0) {
    const double bend = (best_cost_ - cost_ - slope_ * t_) / (t_ * t_);
    // A cost that falls faster than linearly: double.
    target_ = bend > 0.0 ? -slope_ / (2.0 * bend) : 2.0 * t_;
    target_ = std::min(target_, max_multiple_);
  }
  if (!(target_ > 1.5 * t_)) {
    done_ = true;
    return false;
  }
  *multiple = target_;
  return true;
}

bool StepExtrapolation::Report(bool evaluated, double new_cost) {
  if (!evaluated || !(new_cost < best_cost_)) {
    target_ = t_ + (target_ - t_) / 3.0;
    return false;
  }
  best_cost_ = new_cost;
  t_ = target_;
  target_ = 0.0;
  ++stretches_;
  return true;
}

}  // namespace oslam

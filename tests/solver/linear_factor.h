// A linear-Gaussian factor for the solver's tests: z = A x + noise, noise
// ~ N(0, sigma^2 I), so e(x) = (A x - z) / sigma with the keys' values
// stacked into x. Problems built from it have closed-form solutions,
// covariances and evidences.
#pragma once

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "solver/factor.h"
#include "solver/factor_graph.h"

namespace oslam {
namespace testing {

class LinearFactor : public Factor {
 public:
  LinearFactor(const std::vector<int>& keys, Eigen::MatrixXd a, Eigen::VectorXd z, double sigma)
      : Factor(keys), a_(std::move(a)), z_(std::move(z)), sigma_(sigma) {}

  int Dimension() const override { return static_cast<int>(z_.size()); }
  bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                 Eigen::MatrixXd* jacobian) const override {
    Eigen::VectorXd x(a_.cols());
    int at = 0;
    for (int key : keys()) {
      x.segment(at, values.Dim(key)) = values.Get(key);
      at += values.Dim(key);
    }
    error = (a_ * x - z_) / sigma_;
    if (jacobian) *jacobian = a_ / sigma_;
    return true;
  }
  double LogDetCovariance() const override {
    return static_cast<double>(z_.size()) * std::log(sigma_ * sigma_);
  }
  std::string Name() const override { return "linear"; }

 private:
  Eigen::MatrixXd a_;
  Eigen::VectorXd z_;
  double sigma_;
};

// A scalar reading z of the sum of `coefficients[i]` x_keys[i] (scalar
// variables), standard deviation sigma.
inline void AddScalarReading(FactorGraph* graph, const std::vector<int>& keys,
                             const std::vector<double>& coefficients, double z, double sigma) {
  Eigen::MatrixXd a(1, coefficients.size());
  for (size_t i = 0; i < coefficients.size(); ++i) a(0, i) = coefficients[i];
  graph->Emplace<LinearFactor>(keys, a, Eigen::VectorXd::Constant(1, z), sigma);
}

}  // namespace testing
}  // namespace oslam

// A factor of the geometric SLAM problem (spec §5.1), GTSAM-style: it knows
// its variables (keys), its measurement and its noise, and computes only the
// whitened error
//
//   e(x) = L^{-1} (h(x) - z),   L L^T = P  (the factor's noise covariance)
//
// and its Jacobians de/dx. Linearisation, ordering, damping and solving are
// the solver's business (mapping/sparse_solver.h), so a new measurement type
// (e.g. range-bearing to a landmark) is one new subclass and nothing else.
//
// The solver minimises sum_f ||e_f||^2 / 2; the Laplace evidence (spec §8.2)
// also needs log|P| of every factor, hence LogDetCovariance().
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mapping/values.h"

namespace oslam {

class Factor {
 public:
  explicit Factor(std::vector<int> keys) : keys_(std::move(keys)) {}
  virtual ~Factor() = default;

  const std::vector<int>& keys() const { return keys_; }

  // Rows of the whitened error.
  virtual int Dimension() const = 0;

  // Fills `error` (Dimension() entries, pre-sized) and, when `jacobian` is not
  // null, the whitened Jacobian (Dimension() x sum of the keys' dimensions,
  // pre-sized; the blocks follow the order of keys()). Returns false when the
  // model cannot be evaluated there (e.g. the object has no image); the
  // solver then rejects the step instead of crashing.
  virtual bool Linearize(const Values& values, Eigen::Ref<Eigen::VectorXd> error,
                         Eigen::MatrixXd* jacobian) const = 0;

  // log |P| (natural log) of the noise covariance; constant w.r.t. the unknowns.
  virtual double LogDetCovariance() const = 0;

  // For messages and the O-Map summary.
  virtual std::string Name() const = 0;

 private:
  std::vector<int> keys_;
};

}  // namespace oslam

// A factor of the geometric SLAM problem (docs/method.md §5.1), GTSAM-style: it knows
// its variables (keys), its measurement and its noise, and computes only the
// whitened error
//
//   e(x) = L^{-1} (h(x) - z),   L L^T = P  (the factor's noise covariance)
//
// and its Jacobians de/dx. Linearisation, ordering, damping and solving are
// the solver's business (solver/sparse_solver.h), so a new measurement type
// (e.g. range-bearing to a landmark) is one new subclass and nothing else.
//
// The solver minimises sum_f ||e_f||^2 / 2; the Laplace evidence (docs/method.md §8.2)
// also needs log|P| of every factor, hence LogDetCovariance().
#pragma once

#include <algorithm>
#include <array>
#include <initializer_list>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "solver/values.h"

namespace oslam {

// A factor's variables. Up to four are kept inline: O-SLAM builds a graph
// of thousands of factors per proposal, and a heap block per key list was
// a fifth of its allocations.
class FactorKeys {
 public:
  FactorKeys(std::initializer_list<int> keys) { Assign(keys.begin(), keys.end()); }
  explicit FactorKeys(const std::vector<int>& keys) {
    Assign(keys.data(), keys.data() + keys.size());
  }

  size_t size() const { return size_; }
  const int* begin() const { return data_; }
  const int* end() const { return data_ + size_; }
  int operator[](size_t i) const { return data_[i]; }

  FactorKeys(const FactorKeys&) = delete;
  FactorKeys& operator=(const FactorKeys&) = delete;

 private:
  void Assign(const int* first, const int* last) {
    size_ = static_cast<size_t>(last - first);
    if (size_ > inline_.size()) overflow_.assign(first, last);
    data_ = size_ > inline_.size() ? overflow_.data() : inline_.data();
    std::copy(first, last, data_);
  }
  std::array<int, 4> inline_{};
  std::vector<int> overflow_;
  int* data_ = nullptr;
  size_t size_ = 0;
};

class Factor {
 public:
  Factor(std::initializer_list<int> keys) : keys_(keys) {}
  explicit Factor(const std::vector<int>& keys) : keys_(keys) {}
  virtual ~Factor() = default;

  const FactorKeys& keys() const { return keys_; }

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

  // Linearisation reuse (SolverOptions::reuse_linearizations, docs/method.md §9.6).
  // Factors given the same slot in the solves of one SparseSolver must be
  // the same function of their keys' values (same kind, measurement, noise
  // and model): the solver then reuses the slot's last error and Jacobian
  // where the keys' values are bitwise equal to those it was linearised at.
  // -1 (the default): never reused.
  int linearization_slot() const { return linearization_slot_; }
  void set_linearization_slot(int slot) { linearization_slot_ = slot; }

 private:
  FactorKeys keys_;
  int linearization_slot_ = -1;
};

}  // namespace oslam

// A factor graph: the variables' current values, which of them are held
// fixed (the gauge: pose 1 is excluded from the unknowns, spec §14), and the
// factors. The solver reads the structure and updates the values in place.
#pragma once

#include <memory>
#include <utility>
#include <vector>

#include "mapping/factor.h"
#include "mapping/values.h"

namespace oslam {

class FactorGraph {
 public:
  int AddVariable(const Eigen::Ref<const Eigen::VectorXd>& value, int angle_index = -1,
                  bool fixed = false) {
    fixed_.push_back(fixed);
    return values_.Add(value, angle_index);
  }
  int AddPose(double x_m, double y_m, double theta_rad, bool fixed = false) {
    return AddVariable(Eigen::Vector3d(x_m, y_m, theta_rad), 2, fixed);
  }
  // Room for this many variables (and scalars) and factors.
  void Reserve(int variables, int scalars, int factors) {
    values_.Reserve(variables, scalars);
    fixed_.reserve(variables);
    factors_.reserve(factors);
  }
  // Throws oslam::Error when a key is unknown.
  void Add(std::unique_ptr<Factor> factor);
  template <typename F, typename... Args>
  F* Emplace(Args&&... args) {
    auto factor = std::make_unique<F>(std::forward<Args>(args)...);
    F* raw = factor.get();
    Add(std::move(factor));
    return raw;
  }

  const Values& values() const { return values_; }
  Values& mutable_values() { return values_; }
  bool IsFixed(int key) const { return fixed_[key]; }
  void SetFixed(int key, bool fixed) { fixed_[key] = fixed; }
  int num_variables() const { return values_.size(); }
  const std::vector<std::unique_ptr<Factor>>& factors() const { return factors_; }

 private:
  Values values_;
  std::vector<bool> fixed_;
  std::vector<std::unique_ptr<Factor>> factors_;
};

}  // namespace oslam

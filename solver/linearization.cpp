#include "solver/linearization.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/parallel.h"

namespace oslam {

double SquaredNorm(const Eigen::VectorXd& error) {
  switch (error.size()) {
    case 4:
      return Eigen::Map<const Eigen::Vector4d>(error.data()).squaredNorm();
    case 3:
      return Eigen::Map<const Eigen::Vector3d>(error.data()).squaredNorm();
    case 2:
      return Eigen::Map<const Eigen::Vector2d>(error.data()).squaredNorm();
    default:
      return error.squaredNorm();
  }
}

bool Linearizer::Evaluate(const FactorGraph& graph, const Values& values, bool with_jacobians,
                          Evaluation* out, double* cost) {
  const auto& factors = graph.factors();
  const bool keep = with_jacobians && reuse_;
  if (!keep && threads_ != 1 && factors.size() >= kParallelFactors &&
      ThreadCount(threads_, factors.size()) > 1)
    return EvaluateOnThreads(graph, values, with_jacobians, out, cost);
  double sum = 0.0;
  for (size_t f = 0; f < factors.size(); ++f) {
    const Factor& factor = *factors[f];
    const int slot = keep ? factor.linearization_slot() : -1;
    if (slot >= 0 && Reuse(slot, factor, values, out->errors[f], &out->jacobians[f])) {
      ++reused_;
    } else {
      if (!factor.Linearize(values, out->errors[f], with_jacobians ? &out->jacobians[f] : nullptr))
        return false;
      if (with_jacobians) ++computed_;
      if (slot >= 0) Keep(slot, factor, values, out->errors[f], out->jacobians[f]);
    }
    sum += SquaredNorm(out->errors[f]);
  }
  *cost = 0.5 * sum;
  return std::isfinite(*cost);
}

bool Linearizer::EvaluateOnThreads(const FactorGraph& graph, const Values& values,
                                   bool with_jacobians, Evaluation* out, double* cost) {
  const auto& factors = graph.factors();
  const size_t count = factors.size();
  squared_norms_.resize(count);
  const int threads = ThreadCount(threads_, count);
  const size_t per_thread = (count + static_cast<size_t>(threads) - 1) / threads;
  std::vector<char> failed(static_cast<size_t>(threads), 0);
  ParallelFor(0, static_cast<size_t>(threads), threads, [&](size_t part) {
    const size_t end = std::min(count, (part + 1) * per_thread);
    for (size_t f = part * per_thread; f < end; ++f) {
      if (!factors[f]->Linearize(values, out->errors[f],
                                 with_jacobians ? &out->jacobians[f] : nullptr)) {
        failed[part] = 1;
        return;
      }
      squared_norms_[f] = SquaredNorm(out->errors[f]);
    }
  });
  if (std::find(failed.begin(), failed.end(), 1) != failed.end()) return false;
  if (with_jacobians) computed_ += static_cast<int>(count);
  double sum = 0.0;  // in factor order, as Evaluate's loop
  for (double norm : squared_norms_) sum += norm;
  *cost = 0.5 * sum;
  return std::isfinite(*cost);
}

void Linearizer::Forget() {
  for (Kept& entry : kept_) entry.valid = false;
}

// Copies the slot's kept linearisation into error and jacobian if it was
// made at the factor's current values (bitwise: the same inputs give the
// same outputs) and has their shapes.
bool Linearizer::Reuse(int slot, const Factor& factor, const Values& values, Eigen::VectorXd& error,
                       Eigen::MatrixXd* jacobian) const {
  if (slot >= static_cast<int>(kept_.size())) return false;
  const Kept& entry = kept_[slot];
  if (!entry.valid || entry.error.size() != error.size() ||
      entry.jacobian.rows() != jacobian->rows() || entry.jacobian.cols() != jacobian->cols())
    return false;
  size_t at = 0;
  for (int key : factor.keys()) {
    const size_t dim = static_cast<size_t>(values.Dim(key));
    if (at + dim > entry.at.size() ||
        std::memcmp(values.Data(key), entry.at.data() + at, dim * sizeof(double)) != 0)
      return false;
    at += dim;
  }
  if (at != entry.at.size()) return false;
  error = entry.error;
  *jacobian = entry.jacobian;
  return true;
}

void Linearizer::Keep(int slot, const Factor& factor, const Values& values,
                      const Eigen::VectorXd& error, const Eigen::MatrixXd& jacobian) {
  if (slot >= static_cast<int>(kept_.size())) kept_.resize(slot + 1);
  Kept& entry = kept_[slot];
  entry.at.clear();
  for (int key : factor.keys())
    entry.at.insert(entry.at.end(), values.Data(key), values.Data(key) + values.Dim(key));
  entry.error = error;
  entry.jacobian = jacobian;
  entry.valid = true;
}

}  // namespace oslam

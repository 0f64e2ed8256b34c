// Evaluation of every factor of a graph at a point: the whitened errors and
// Jacobians the solver's iterations consume, with docs/method.md §9.6's Jacobian reuse
// (SolverOptions::reuse_linearizations): a factor given a linearisation
// slot keeps its last error and Jacobian, and they are copied instead of
// recomputed where the factor's variables are bitwise unchanged. An O-SLAM
// proposal is linearised at its parent state's solution, so all proposals
// from one state but the first share nearly all their linearisations. Same
// inputs give the same outputs, so the results are the same bit for bit.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "solver/factor_graph.h"

namespace oslam {

// Errors and Jacobians of every factor (graph order). Shaped once per
// problem structure (Shape), filled in place by Linearizer::Evaluate.
struct Evaluation {
  std::vector<Eigen::VectorXd> errors;
  std::vector<Eigen::MatrixXd> jacobians;

  void Resize(std::size_t size) {
    errors.resize(size);
    jacobians.resize(size);
  }
  // Factor f's error: `rows` entries, Jacobian rows x columns. Resized only
  // when the shape changes: Eigen's resize checks for overflow with an
  // integer division, a real cost at 2,000 factors per proposal.
  void Shape(std::size_t f, int rows, int columns) {
    if (errors[f].size() != rows) errors[f].resize(rows);
    Eigen::MatrixXd& jacobian = jacobians[f];
    if (jacobian.rows() != rows || jacobian.cols() != columns) jacobian.resize(rows, columns);
  }
};

// ||e||^2 with Eigen's fixed-size reduction for the common factor sizes:
// its dynamic-size one spends ~100 instructions per call on peeling and
// unrolling logic, twice per factor per proposal. Same packet order, so the
// same bits.
double SquaredNorm(const Eigen::VectorXd& error);

class Linearizer {
 public:
  // Whether Evaluate keeps and reuses linearisations (SolverOptions::
  // reuse_linearizations).
  void set_reuse(bool reuse) { reuse_ = reuse; }
  // Threads for graphs of at least kParallelFactors factors when nothing is
  // kept (0: one per core); smaller graphs cost less than a thread's start.
  void set_threads(int threads) { threads_ = threads; }
  static constexpr std::size_t kParallelFactors = 4096;

  // Errors (and, with_jacobians, Jacobians) of every factor at `values`
  // into `out` (its errors, and with_jacobians its Jacobians, shaped for
  // the graph); 1/2 sum ||e||^2 in `cost`. False when a factor cannot be
  // evaluated or the cost is not finite. Only evaluations with Jacobians
  // keep or reuse linearisations.
  bool Evaluate(const FactorGraph& graph, const Values& values, bool with_jacobians,
                Evaluation* out, double* cost);

  // Factors whose error and Jacobian were copied from a kept linearisation,
  // and factors linearised, since the last ResetCounts.
  int reused() const { return reused_; }
  int computed() const { return computed_; }
  void ResetCounts() { reused_ = computed_ = 0; }

  // Forgets the kept linearisations, keeping their storage (the next
  // linearisations refill it in place), e.g. when a slot is given to
  // another measurement.
  void Forget();
  // Forgets them and frees their storage.
  void Clear() { kept_.clear(); }

 private:
  // A slot's last linearisation: the values of the factor's variables it
  // was made at, its error and Jacobian.
  struct Kept {
    std::vector<double> at;
    Eigen::VectorXd error;
    Eigen::MatrixXd jacobian;
    bool valid = false;
  };
  bool Reuse(int slot, const Factor& factor, const Values& values, Eigen::VectorXd& error,
             Eigen::MatrixXd* jacobian) const;
  void Keep(int slot, const Factor& factor, const Values& values, const Eigen::VectorXd& error,
            const Eigen::MatrixXd& jacobian);

  // Evaluate on threads, a contiguous range of factors each.
  bool EvaluateOnThreads(const FactorGraph& graph, const Values& values, bool with_jacobians,
                         Evaluation* out, double* cost);

  std::vector<Kept> kept_;             // per slot
  std::vector<double> squared_norms_;  // EvaluateOnThreads: per factor
  bool reuse_ = false;
  int threads_ = 1;
  int reused_ = 0, computed_ = 0;
};

}  // namespace oslam

// The Cholesky back end of SparseSolver: the whitened normal equations
//
//   (J^T J + lambda D) delta = -J^T e
//
// assembled straight into a CHOLMOD upper-triangular matrix and factored by
// CHOLMOD (LL' or LDL', supernodal or simplicial, as CHOLMOD decides).
//
// The matrix's pattern and its fill-reducing symbolic analysis are built
// once per problem structure and kept: a graph whose free variables have
// the same sizes and whose block pattern fits in the kept one (the MCMC
// case: a small association change) is assembled into the kept pattern,
// the missing blocks left zero. A strictly larger kept pattern factorises
// the same matrix with other fill, so other rounding; with
// independent_of_history only the identical pattern is reused, so a solve
// depends on its own graph only.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "solver/block_pattern.h"
#include "solver/fill_reducing_ordering.h"
#include "solver/linearization.h"
#include "solver/sparse_solver.h"
#include "solver/symbolic_analysis.h"

struct cholmod_common_struct;
struct cholmod_dense_struct;
struct cholmod_factor_struct;
struct cholmod_sparse_struct;

namespace oslam {

class NormalEquations {
 public:
  NormalEquations();
  ~NormalEquations();
  NormalEquations(const NormalEquations&) = delete;
  NormalEquations& operator=(const NormalEquations&) = delete;

  // Lays out `graph` (layout(), pattern()) and makes the matrix structure
  // and its analysis, or reuses the kept ones: all of it for a graph of the
  // last set-up's structure, the pattern and analysis when the graph's
  // pattern fits in it (`reused` then; never when !allow_reuse or the
  // ordering asked for differs). Time spent analysing in `analyze_s`.
  // False with `why` for a graph that cannot be solved.
  bool SetUp(const FactorGraph& graph, OrderingType ordering, bool independent_of_history,
             bool allow_reuse, bool* reused, double* analyze_s, std::string* why);
  const ProblemLayout& layout() const { return layout_; }
  const BlockPattern& pattern() const { return pattern_; }
  // Changes whenever a set-up lays a graph out anew (not when it finds the
  // last set-up's structure): buffers shaped for the layout need reshaping
  // only then.
  int layout_generation() const { return layout_generation_; }
  // The ordering of the kept analysis (never kAutomatic).
  OrderingType ordering_used() const { return ordering_.used(); }

  // J^T J (into the matrix), the gradient g = J^T e and the undamped
  // diagonal of J^T J from an evaluation with Jacobians at the set-up's
  // layout; false when they are not finite.
  bool Assemble(const Evaluation& evaluation);
  const Eigen::VectorXd& gradient() const { return gradient_; }
  const Eigen::VectorXd& diagonal() const { return diagonal_; }

  // Factors J^T J + lambda D (DampingScale; lambda = 0: undamped); false if
  // it is not positive definite.
  bool Factorize(double lambda, const SolverOptions& options);
  // Solves (factored matrix) out = in; false when CHOLMOD fails or the
  // solution is not finite.
  bool Solve(const Eigen::VectorXd& in, Eigen::VectorXd* out);

  // Whether the factor holds the undamped matrix at a solve's final point
  // (reset by every set-up).
  bool factor_is_final() const { return factor_is_final_; }
  void set_factor_is_final(bool final) { factor_is_final_ = final; }
  // For the evidence and covariances of the factored matrix.
  cholmod_factor_struct* factor() const { return factor_; }
  cholmod_common_struct* common() const { return cc_.get(); }
  // Scalar column of delta -> row of the factor.
  const std::vector<int>& inverse_permutation() const { return permuted_.inverse_permutation; }

  // Forgets the kept structure and analysis, and the last comparison of
  // orderings.
  void Clear();

 private:
  // Set-up that the last set-up's structure could not spare.
  bool FullSetUp(const FactorGraph& graph, OrderingType ordering, bool independent_of_history,
                 bool allow_reuse, bool* reused, double* analyze_s, std::string* why);
  // The matrix structure and its analysis for the builder's pattern.
  bool Rebuild(OrderingType ordering, bool independent_of_history, double* analyze_s,
               std::string* why);
  void AllocateHessian();
  template <int Rows, int Columns>
  void AssembleFactor(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& error, size_t f,
                      double* x, const int* p);
  void FreeWork();
  void FreeStructure();

  std::unique_ptr<cholmod_common_struct> cc_;

  // ---- structure (kept across solves) ----
  BlockPattern pattern_;
  FillReducingOrdering ordering_;
  OrderingType analysed_ordering_ = OrderingType::kAutomatic;  // the request it was made for
  cholmod_sparse_struct* hessian_ = nullptr;                   // upper triangle, variables' order
  std::vector<int> diagonal_position_;  // per column: its diagonal entry in hessian_
  PermutedHessian permuted_;            // what CHOLMOD factors
  cholmod_factor_struct* factor_ = nullptr;
  bool factor_is_final_ = false;
  // What the last successful set-up depended on (empty if none), and
  // scratch for the next one's.
  std::vector<int> set_up_structure_, scratch_structure_;

  // ---- per set-up ----
  ProblemLayout layout_;
  int layout_generation_ = 0;
  BlockPatternBuilder builder_;

  // ---- numeric ----
  Eigen::VectorXd gradient_, diagonal_;
  Eigen::MatrixXd local_hessian_;   // scratch: J_f^T J_f
  Eigen::VectorXd local_gradient_;  // scratch: J_f^T e_f
  cholmod_dense_struct* rhs_ = nullptr;
  cholmod_dense_struct *solution_ = nullptr, *work_y_ = nullptr, *work_e_ = nullptr;
};

}  // namespace oslam

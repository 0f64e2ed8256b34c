// oslam's geometric solver against a Ceres model of the same problem (issue
// 6): the same factors (each oslam Factor wrapped as a ceres::CostFunction,
// so both minimise exactly the same function with the same analytic
// Jacobians), the same start (GeometricSlam's initialisation), Levenberg-
// Marquardt with sparse normal Cholesky (SuiteSparse) on one thread, and the
// same tolerances. Reported per size, in one run: thread CPU time of each
// solve, their ratio, iterations and final costs, and oslam's CHOLMOD
// factorisation (+ solve) per iteration as the floor.
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <memory>

#include <benchmark/benchmark.h>
#include <ceres/ceres.h>

#include "calib/hyperbolic_camera.h"
#include "slam/factors.h"
#include "slam/geometric_slam.h"
#include "tests/slam/synthetic_scene.h"

namespace oslam {
namespace {

double ThreadSeconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

testing::SyntheticScene Scene(int k) {
  static const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  return testing::MakeSyntheticScene(camera, testing::GrownLpaLoop(k));
}

// The graph GeometricSlam solves, at its initial values (a solve with no
// iteration and no final step leaves the values at the start).
std::unique_ptr<FactorGraph> BuildGraph(const CameraModel& camera,
                                        const GeometricSlamProblem& problem,
                                        const GeometricSlamOptions& base_options) {
  GeometricSlamOptions options = base_options;
  options.solver.max_iterations = 0;
  options.solver.apply_final_step = false;
  options.compute_object_covariances = false;
  GeometricSlam slam(camera, options);
  const GeometricSlamResult start = slam.Solve(problem);
  auto graph = std::make_unique<FactorGraph>();
  std::vector<int> pose_keys;
  for (size_t i = 0; i < start.trajectory.size(); ++i) {
    const Pose2& pose = start.trajectory[i];
    pose_keys.push_back(graph->AddPose(pose.x, pose.y, pose.theta, i == 0));
  }
  std::map<int, std::pair<int, int>> keys;
  for (const MappedObject& object : start.objects) {
    const ClassPrior& prior = problem.classes[object.class_index];
    const int base = graph->AddVariable(object.geometry.base_world);
    const int size =
        graph->AddVariable(Eigen::Vector2d(object.geometry.diameter_m, object.geometry.height_m));
    graph->Add(MakeLocationPrior(base, prior.location_mean_m, prior.location_std_m));
    graph->Add(MakeSizePrior(size, prior.size_mean_m, prior.size_std_m));
    keys[object.id] = {base, size};
  }
  for (size_t i = 1; i < pose_keys.size(); ++i)
    graph->Emplace<OdometryFactor>(pose_keys[i - 1], pose_keys[i], problem.increments[i],
                                   options.motion);
  for (const SliceObservation& o : problem.observations)
    graph->Emplace<BoundingSliceFactor>(&camera, pose_keys[o.frame], keys[o.object_id].first,
                                        keys[o.object_id].second, o.slice, options.pixel_std_px);
  return graph;
}

// An oslam Factor as a Ceres cost function. The factor reads its variables
// from a Values; the parameters are copied into a shared scratch copy
// (Ceres evaluates on one thread here).
class FactorCost final : public ceres::CostFunction {
 public:
  FactorCost(const Factor* factor, Values* scratch) : factor_(factor), scratch_(scratch) {
    set_num_residuals(factor->Dimension());
    int column = 0;
    for (int key : factor->keys()) {
      mutable_parameter_block_sizes()->push_back(scratch->Dim(key));
      columns_.push_back(column);
      column += scratch->Dim(key);
    }
    jacobian_.resize(factor->Dimension(), column);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const auto& keys = factor_->keys();
    for (size_t i = 0; i < keys.size(); ++i)
      std::copy(parameters[i], parameters[i] + scratch_->Dim(keys[i]),
                scratch_->MutableData(keys[i]));
    Eigen::Map<Eigen::VectorXd> error(residuals, num_residuals());
    if (!jacobians) return factor_->Linearize(*scratch_, error, nullptr);
    if (!factor_->Linearize(*scratch_, error, &jacobian_)) return false;
    for (size_t i = 0; i < keys.size(); ++i)
      if (jacobians[i])
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            jacobians[i], num_residuals(), scratch_->Dim(keys[i])) =
            jacobian_.middleCols(columns_[i], scratch_->Dim(keys[i]));
    return true;
  }

 private:
  const Factor* factor_;
  Values* scratch_;
  std::vector<int> columns_;
  mutable Eigen::MatrixXd jacobian_;
};

void BM_OslamVsCeres(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const testing::SyntheticScene scene = Scene(k);
  GeometricSlamOptions options;
  // Second argument: oslam's SolverOptions::max_step_extrapolation (0: off).
  options.solver.max_step_extrapolation = static_cast<double>(state.range(1));
  double oslam_s = 0, ceres_s = 0, floor_s = 0;
  int oslam_iterations = 0, ceres_iterations = 0, runs = 0;
  double oslam_cost = 0, ceres_cost = 0;
  for (auto _ : state) {
    // oslam: a fresh solver (its analysis is part of the time, as Ceres's is).
    std::unique_ptr<FactorGraph> graph = BuildGraph(camera, scene.problem, options);
    SolverOptions solver_options = options.solver;
    solver_options.compute_evidence = false;
    solver_options.apply_final_step = false;
    SparseSolver solver(solver_options);
    double t = ThreadSeconds();
    const SolveResult result = solver.Solve(graph.get());
    oslam_s += ThreadSeconds() - t;
    oslam_iterations = result.summary.iterations;
    oslam_cost = result.summary.final_cost;
    floor_s += result.summary.factorize_time_s / std::max(1, result.summary.iterations);

    // Ceres on the same factors from the same start.
    std::unique_ptr<FactorGraph> start = BuildGraph(camera, scene.problem, options);
    Values scratch = start->values();
    Values parameters = start->values();
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    for (const auto& factor : start->factors()) {
      std::vector<double*> blocks;
      for (int key : factor->keys()) blocks.push_back(parameters.MutableData(key));
      problem.AddResidualBlock(new FactorCost(factor.get(), &scratch), nullptr, blocks);
    }
    for (int key = 0; key < start->num_variables(); ++key)
      if (start->IsFixed(key)) problem.SetParameterBlockConstant(parameters.MutableData(key));
    ceres::Solver::Options ceres_options;
    ceres_options.minimizer_type = ceres::TRUST_REGION;
    ceres_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    ceres_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    ceres_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
    ceres_options.num_threads = 1;
    ceres_options.max_num_iterations = options.solver.max_iterations;
    ceres_options.function_tolerance = options.solver.function_tolerance;
    ceres_options.gradient_tolerance = options.solver.gradient_tolerance;
    ceres_options.parameter_tolerance = 1e-8;
    ceres_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    t = ThreadSeconds();
    ceres::Solve(ceres_options, &problem, &summary);
    ceres_s += ThreadSeconds() - t;
    ceres_iterations = static_cast<int>(summary.iterations.size()) - 1;
    ceres_cost = summary.final_cost;
    ++runs;
  }
  state.counters["poses"] = scene.problem.increments.size();
  state.counters["detections"] = scene.problem.observations.size();
  state.counters["oslam_ms"] = 1e3 * oslam_s / runs;
  state.counters["ceres_ms"] = 1e3 * ceres_s / runs;
  state.counters["oslam_over_ceres"] = oslam_s / ceres_s;
  state.counters["floor_ms_per_iter"] = 1e3 * floor_s / runs;
  state.counters["oslam_iters"] = oslam_iterations;
  state.counters["ceres_iters"] = ceres_iterations;
  state.counters["oslam_cost"] = oslam_cost;
  state.counters["ceres_cost"] = ceres_cost;
  char label[96];
  std::snprintf(label, sizeof(label), "final cost oslam %.6f ceres %.6f", oslam_cost, ceres_cost);
  state.SetLabel(label);
}
BENCHMARK(BM_OslamVsCeres)
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({4, 0})
    ->Args({8, 0})
    ->Args({8, 16})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

}  // namespace
}  // namespace oslam

// Geometric solver speed (issue 6): a cold solve from raw odometry at LPA
// scale and at 10,000 poses, a warm re-solve after a small association
// change, and CHOLMOD's numeric factorisation per iteration as the floor.
// Problems come from tests/mapping/synthetic_scene.h (thesis noise levels).
#include <benchmark/benchmark.h>

#include "calib/hyperbolic_camera.h"
#include "mapping/geometric_slam.h"
#include "tests/mapping/synthetic_scene.h"

namespace oslam {
namespace {

testing::SyntheticScene Scene(int poses, int objects, double length, double width, double range) {
  static const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  testing::SyntheticSceneOptions options;
  options.num_poses = poses;
  options.num_objects = objects;
  options.loop_length_m = length;
  options.loop_width_m = width;
  options.max_range_m = range;
  options.pixel_std_px = 30.0;
  options.odometry_noise = true;
  return testing::MakeSyntheticScene(camera, options);
}

void Report(benchmark::State& state, const testing::SyntheticScene& scene,
            const GeometricSlamResult& result) {
  state.counters["poses"] = scene.problem.increments.size();
  state.counters["detections"] = scene.problem.observations.size();
  state.counters["iterations"] = result.summary.iterations;
  state.counters["converged"] = result.summary.termination == TerminationType::kConverged;
  state.counters["final_cost"] = result.summary.final_cost;
  state.counters["factorize_ms_per_iter"] =
      1e3 * result.summary.factorize_time_s / std::max(1, result.summary.iterations);
  state.counters["linearize_ms"] = 1e3 * result.summary.linearize_time_s;
  state.counters["analyze_ms"] = 1e3 * result.summary.analyze_time_s;
  state.counters["evidence_ms"] = 1e3 * result.summary.evidence_time_s;
  state.counters["solver_ms"] = 1e3 * result.summary.total_time_s;
}

// `extrapolation`: SolverOptions::max_step_extrapolation (0: off, the default).
void ColdSolve(benchmark::State& state, const testing::SyntheticScene& scene,
               double extrapolation = 0.0) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  options.solver.max_step_extrapolation = extrapolation;
  GeometricSlamResult result;
  for (auto _ : state) {
    GeometricSlam slam(camera, options);  // fresh: no cached analysis
    result = slam.Solve(scene.problem);
    benchmark::DoNotOptimize(result.evidence.log_evidence);
  }
  Report(state, scene, result);
}

void BM_LpaScaleFromOdometry(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(300, 10, 6.0, 4.0, 5.0);
  ColdSolve(state, scene);
}
BENCHMARK(BM_LpaScaleFromOdometry)->Unit(benchmark::kMillisecond);

void BM_LargeFromOdometry(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(10000, 200, 60.0, 40.0, 3.5);
  ColdSolve(state, scene);
}
BENCHMARK(BM_LargeFromOdometry)->Unit(benchmark::kMillisecond)->Iterations(2);

// The same with the line search beyond steps whose gain ratio shows J^T J
// overstating the curvature (SolverOptions::max_step_extrapolation = 16).
void BM_LargeFromOdometryExtrapolated(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(10000, 200, 60.0, 40.0, 3.5);
  ColdSolve(state, scene, 16.0);
}
BENCHMARK(BM_LargeFromOdometryExtrapolated)->Unit(benchmark::kMillisecond)->Iterations(2);

// Time growth with size: poses x 1..8 of the LPA loop, objects alike.
void BM_GrowthFromOdometry(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const testing::SyntheticScene scene = Scene(300 * k, 10 * k, 6.0 * k, 4.0 * k, 5.0);
  ColdSolve(state, scene);
}
BENCHMARK(BM_GrowthFromOdometry)->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Unit(benchmark::kMillisecond);

void BM_GrowthFromOdometryExtrapolated(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const testing::SyntheticScene scene = Scene(300 * k, 10 * k, 6.0 * k, 4.0 * k, 5.0);
  ColdSolve(state, scene, 16.0);
}
BENCHMARK(BM_GrowthFromOdometryExtrapolated)->Arg(4)->Arg(6)->Arg(8)->Unit(benchmark::kMillisecond);

// Times re-solves of `problem` by one solver (its symbolic analysis kept
// between iterations, as in the MCMC), warm-started from `warm`.
// Times re-solves of `problem` by one solver (its symbolic analysis kept
// between iterations, as in the MCMC), warm-started from `warm`.
// `forget_linearizations`: every solve starts without kept linearisations
// (the first proposal from a newly accepted state).
void TimeWarmSolves(benchmark::State& state, const testing::SyntheticScene& scene,
                    GeometricSlam* slam, const GeometricSlamProblem& problem,
                    const GeometricSlamResult& warm, bool forget_linearizations = false) {
  GeometricSlamResult result;
  for (auto _ : state) {
    if (forget_linearizations) slam->solver().ClearLinearizations();
    result = slam->Solve(problem, &warm);
    benchmark::DoNotOptimize(result.evidence.log_evidence);
  }
  Report(state, scene, result);
  state.counters["reused_linearizations"] = result.summary.reused_linearizations;
  state.counters["computed_linearizations"] = result.summary.computed_linearizations;
}

// The problem after a split (what an MCMC proposal does): the last
// detection of object `from` becomes a new object `to` of the same class.
GeometricSlamProblem SplitLastDetection(const GeometricSlamProblem& problem, int from, int to) {
  GeometricSlamProblem changed = problem;
  for (auto it = changed.observations.rbegin(); it != changed.observations.rend(); ++it)
    if (it->object_id == from) {
      it->object_id = to;
      break;
    }
  changed.object_class[to] = changed.object_class[from];
  return changed;
}

// What the MCMC does per proposal: re-solve after moving one detection to a
// new object, warm-started from the previous state's solution.
void BM_LpaWarmResolveAfterSplit(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(300, 10, 6.0, 4.0, 5.0);
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  GeometricSlam slam(camera, options);
  const GeometricSlamResult base = slam.Solve(scene.problem);
  const GeometricSlamProblem changed = SplitLastDetection(scene.problem, 3, 99);
  TimeWarmSolves(state, scene, &slam, changed, base);
}
BENCHMARK(BM_LpaWarmResolveAfterSplit)->Unit(benchmark::kMillisecond);

// The thesis's proposal evaluation (spec §9.6): after the split the new
// object takes the originating object's linearisation point, and the state
// is solved with one linearised step (max_iterations = 0: the undamped
// Gauss-Newton step of the system the evidence comes from).
// Arg: 0 = every factor linearised afresh; 1 = linearisations kept from
// the previous proposal (SolverOptions::reuse_linearizations: all proposals
// from one state but the first); 2 = kept, but forgotten before each solve
// (the first proposal from a state: the cost of keeping them).
void BM_LpaWarmOneLinearStepAfterSplit(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(300, 10, 6.0, 4.0, 5.0);
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  GeometricSlam full(camera, options);
  const GeometricSlamResult base = full.Solve(scene.problem);
  const GeometricSlamProblem changed = SplitLastDetection(scene.problem, 3, 99);
  GeometricSlamResult warm = base;
  for (const MappedObject& object : base.objects)
    if (object.id == 3) {
      MappedObject copy = object;
      copy.id = 99;
      warm.objects.push_back(copy);
    }
  options.solver.max_iterations = 0;
  options.solver.reuse_linearizations = state.range(0) > 0;
  GeometricSlam step(camera, options);
  TimeWarmSolves(state, scene, &step, changed, warm, state.range(0) == 2);
}
BENCHMARK(BM_LpaWarmOneLinearStepAfterSplit)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);
// Fixed counts: their difference in `perf stat -e instructions:u` is the
// cost of 400 proposals without the set-up (machine-speed independent).
BENCHMARK(BM_LpaWarmOneLinearStepAfterSplit)
    ->DenseRange(0, 2)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(100);
BENCHMARK(BM_LpaWarmOneLinearStepAfterSplit)
    ->DenseRange(0, 2)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(500);

// What O-SLAM's sampler does between two accepted moves: different
// proposals from one state, each solved with one linearised step from that
// state's solution (the sampler's options: results independent of the
// solves before, so each new block pattern gets its own symbolic analysis).
// The proposals cycle through splitting off the last detection of each of
// the 10 objects. Arg: SolverOptions::reuse_linearizations.
void BM_LpaProposalsFromOneState(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(300, 10, 6.0, 4.0, 5.0);
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  GeometricSlam full(camera, options);
  const GeometricSlamResult base = full.Solve(scene.problem);
  std::vector<GeometricSlamProblem> proposals;
  std::vector<GeometricSlamResult> starts;
  constexpr int kNewId = 99;
  for (const MappedObject& object : base.objects) {
    proposals.push_back(SplitLastDetection(scene.problem, object.id, kNewId));
    GeometricSlamResult warm = base;
    MappedObject copy = object;
    copy.id = kNewId;
    warm.objects.push_back(copy);
    starts.push_back(warm);
  }
  options.solver.max_iterations = 0;
  options.solver.independent_of_history = true;
  options.solver.reuse_linearizations = state.range(0) > 0;
  if (state.range(0) == 2) options.solver.ordering = OrderingType::kAmd;
  GeometricSlam step(camera, options);
  GeometricSlamResult result;
  size_t next = 0;
  int analyses = 0;
  for (auto _ : state) {
    result = step.Solve(proposals[next], &starts[next]);
    next = (next + 1) % proposals.size();
    analyses += !result.summary.reused_symbolic_analysis;
    benchmark::DoNotOptimize(result.evidence.log_evidence);
  }
  Report(state, scene, result);
  state.counters["analyses_per_solve"] = static_cast<double>(analyses) / state.iterations();
  state.counters["reused_linearizations"] = result.summary.reused_linearizations;
  state.counters["computed_linearizations"] = result.summary.computed_linearizations;
}
BENCHMARK(BM_LpaProposalsFromOneState)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LpaProposalsFromOneState)
    ->DenseRange(0, 2)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(100);
BENCHMARK(BM_LpaProposalsFromOneState)
    ->DenseRange(0, 2)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(500);

// The large problem started at the truth: the time per iteration without
// the convergence trouble of a start from 2 km of raw odometry.
// Arg: SolverOptions::max_step_extrapolation (0: off, the default; 16).
void BM_LargeFromTruth(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(10000, 200, 60.0, 40.0, 3.5);
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  options.solver.max_step_extrapolation = static_cast<double>(state.range(0));
  GeometricSlamResult truth;
  truth.trajectory = scene.true_trajectory;
  for (size_t j = 0; j < scene.true_objects.size(); ++j) {
    MappedObject object;
    object.id = static_cast<int>(j);
    object.class_index = scene.problem.object_class.at(object.id);
    object.geometry = scene.true_objects[j];
    truth.objects.push_back(object);
  }
  GeometricSlamResult result;
  for (auto _ : state) {
    GeometricSlam slam(camera, options);
    result = slam.Solve(scene.problem, &truth);
    benchmark::DoNotOptimize(result.evidence.log_evidence);
  }
  Report(state, scene, result);
}
BENCHMARK(BM_LargeFromTruth)->Arg(0)->Arg(16)->Unit(benchmark::kMillisecond)->Iterations(2);

// Same association, warm: the symbolic analysis is reused.
void BM_LpaWarmResolveSameAssociation(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(300, 10, 6.0, 4.0, 5.0);
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  GeometricSlam slam(camera, options);
  const GeometricSlamResult base = slam.Solve(scene.problem);
  TimeWarmSolves(state, scene, &slam, scene.problem, base);
}
BENCHMARK(BM_LpaWarmResolveSameAssociation)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace oslam

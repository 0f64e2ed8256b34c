// Geometric solver speed: a cold solve from raw odometry at LPA
// scale and at 10,000 poses, a warm re-solve after a small association
// change, and CHOLMOD's numeric factorisation per iteration as the floor.
// Problems come from tests/slam/synthetic_scene.h (thesis noise levels).
#include <benchmark/benchmark.h>

#include "calib/hyperbolic_camera.h"
#include "slam/geometric_slam.h"
#include "tests/slam/synthetic_scene.h"

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

testing::SyntheticScene LargeScene(unsigned seed = 1) {
  static const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  return testing::MakeSyntheticScene(camera, testing::LargeLoop(seed));
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
  if (result.keyframe_start.used) {
    state.counters["start_ms"] = 1e3 * result.keyframe_start.time_s;
    state.counters["start_stage_solves"] = result.keyframe_start.stage_solves;
    state.counters["start_closures"] = result.keyframe_start.closures;
    state.counters["start_iterations"] =
        result.keyframe_start.stage_iterations + result.keyframe_start.final_iterations;
  }
}

// `extrapolation`: SolverOptions::max_step_extrapolation (0: off, the default).
// `keyframe_start`: off starts every solve from raw odometry.
void ColdSolve(benchmark::State& state, const testing::SyntheticScene& scene,
               double extrapolation = 0.0, bool keyframe_start = true) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  options.solver.max_step_extrapolation = extrapolation;
  if (!keyframe_start) options.keyframe_start.min_poses = 0;
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

// 10 laps of a 60 m x 40 m loop; Arg: the scene's seed. From raw odometry
// through the keyframe start (GeometricSlamOptions::keyframe_start).
void BM_LargeFromOdometry(benchmark::State& state) {
  const testing::SyntheticScene scene = LargeScene(static_cast<unsigned>(state.range(0)));
  ColdSolve(state, scene);
}
BENCHMARK(BM_LargeFromOdometry)->DenseRange(1, 5)->Unit(benchmark::kMillisecond)->Iterations(2);

// Seed 1 with the batch started at raw odometry itself (the keyframe start
// off): it does not converge in 50 iterations.
void BM_LargeFromRawOdometry(benchmark::State& state) {
  static const testing::SyntheticScene scene = LargeScene();
  ColdSolve(state, scene, 0.0, /*keyframe_start=*/false);
}
BENCHMARK(BM_LargeFromRawOdometry)->Unit(benchmark::kMillisecond)->Iterations(2);

// The same with the line search beyond steps whose gain ratio shows J^T J
// overstating the curvature (SolverOptions::max_step_extrapolation = 16).
void BM_LargeFromOdometryExtrapolated(benchmark::State& state) {
  static const testing::SyntheticScene scene = LargeScene();
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

// What the MCMC does per proposal: re-solve after moving one detection to a
// new object, warm-started from the previous state's solution.
void BM_LpaWarmResolveAfterSplit(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(300, 10, 6.0, 4.0, 5.0);
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  GeometricSlam slam(camera, options);
  const GeometricSlamResult base = slam.Solve(scene.problem);
  const GeometricSlamProblem changed = testing::SplitLastDetection(scene.problem, 3, 99);
  TimeWarmSolves(state, scene, &slam, changed, base);
}
BENCHMARK(BM_LpaWarmResolveAfterSplit)->Unit(benchmark::kMillisecond);

// The state after splitting off the last detection of object `from` as a
// new object `to`, and its start as the thesis linearises it (docs/method.md §9.6):
// the solved `base`, with the new object at `from`'s point.
struct SplitProposal {
  GeometricSlamProblem problem;
  GeometricSlamResult start;
};
SplitProposal MakeSplitProposal(const GeometricSlamProblem& problem,
                                const GeometricSlamResult& base, int from, int to) {
  SplitProposal proposal{testing::SplitLastDetection(problem, from, to), base};
  for (const MappedObject& object : base.objects)
    if (object.id == from) {
      MappedObject copy = object;
      copy.id = to;
      proposal.start.objects.push_back(copy);
    }
  return proposal;
}

// Registers `function` for args 0..last_arg, timed, and again at fixed
// counts of 100 and 500 iterations: their difference in `perf stat -e
// instructions:u` is the cost of 400 solves without the set-up
// (independent of the machine's speed).
bool RegisterWithFixedCounts(const char* name, void (*function)(benchmark::State&), int last_arg) {
  benchmark::RegisterBenchmark(name, function)
      ->DenseRange(0, last_arg)
      ->Unit(benchmark::kMillisecond);
  for (int count : {100, 500})
    benchmark::RegisterBenchmark(name, function)
        ->DenseRange(0, last_arg)
        ->Unit(benchmark::kMillisecond)
        ->Iterations(count);
  return true;
}

// The thesis's proposal evaluation (docs/method.md §9.6): after the split the new
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
  const GeometricSlamResult base = GeometricSlam(camera, options).Solve(scene.problem);
  const SplitProposal proposal = MakeSplitProposal(scene.problem, base, 3, 99);
  options.solver.max_iterations = 0;
  options.solver.reuse_linearizations = state.range(0) > 0;
  GeometricSlam step(camera, options);
  TimeWarmSolves(state, scene, &step, proposal.problem, proposal.start, state.range(0) == 2);
}
const bool kOneLinearStepRegistered = RegisterWithFixedCounts("BM_LpaWarmOneLinearStepAfterSplit",
                                                              BM_LpaWarmOneLinearStepAfterSplit, 2);

// What O-SLAM's sampler does between two accepted moves: different
// proposals from one state, each solved with one linearised step from that
// state's solution, results independent of the solves before (so each new
// block pattern gets its own symbolic analysis). The proposals cycle
// through splitting off the last detection of each of the 10 objects.
// Arg: 0 = automatic ordering, every factor linearised afresh; 1 = with
// reused linearisations; 2 = reused linearisations and AMD, the sampler's
// settings (association/slam_target.cpp).
void BM_LpaProposalsFromOneState(benchmark::State& state) {
  static const testing::SyntheticScene scene = Scene(300, 10, 6.0, 4.0, 5.0);
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  const GeometricSlamResult base = GeometricSlam(camera, options).Solve(scene.problem);
  std::vector<SplitProposal> proposals;
  for (const MappedObject& object : base.objects)
    proposals.push_back(MakeSplitProposal(scene.problem, base, object.id, 99));
  options.solver.max_iterations = 0;
  options.solver.independent_of_history = true;
  options.solver.reuse_linearizations = state.range(0) > 0;
  if (state.range(0) == 2) options.solver.ordering = OrderingType::kAmd;
  GeometricSlam step(camera, options);
  GeometricSlamResult result;
  size_t next = 0;
  int analyses = 0;
  for (auto _ : state) {
    result = step.Solve(proposals[next].problem, &proposals[next].start);
    next = (next + 1) % proposals.size();
    analyses += !result.summary.reused_symbolic_analysis;
    benchmark::DoNotOptimize(result.evidence.log_evidence);
  }
  Report(state, scene, result);
  state.counters["analyses_per_solve"] = static_cast<double>(analyses) / state.iterations();
  state.counters["reused_linearizations"] = result.summary.reused_linearizations;
  state.counters["computed_linearizations"] = result.summary.computed_linearizations;
}
const bool kProposalsRegistered =
    RegisterWithFixedCounts("BM_LpaProposalsFromOneState", BM_LpaProposalsFromOneState, 2);

// The large problem started at the truth: the time per iteration without
// the convergence trouble of a start from 2 km of raw odometry.
// Arg: SolverOptions::max_step_extrapolation (0: off, the default; 16).
void BM_LargeFromTruth(benchmark::State& state) {
  static const testing::SyntheticScene scene = LargeScene();
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  GeometricSlamOptions options;
  options.compute_object_covariances = false;
  options.solver.max_step_extrapolation = static_cast<double>(state.range(0));
  const GeometricSlamResult truth = testing::TruthAsResult(scene);
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

// O-SLAM sampler speed: MC3 over the tracks of a synthetic LPA-like
// loop (tests/slam/synthetic_scene.h, E = 30 px, noisy odometry) grown k
// times (300 k poses, 10 k objects), started from the true association so
// that every size samples around its posterior. Reports time per proposal and
// per solve, and MC3 with the chains on threads (running ahead of the swaps)
// against one after another. Wall time (the chains run on other threads).
#include <algorithm>
#include <memory>
#include <vector>

#include <benchmark/benchmark.h>

#include "calib/hyperbolic_camera.h"
#include "association/sampler.h"
#include "association/slam_target.h"
#include "tests/slam/synthetic_scene.h"

namespace oslam {
namespace {

constexpr int kTrackLength = 8;  // detections per track (long_loop's median is about 6)

struct Problem {
  HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  testing::SyntheticScene scene;
  SlamTargetData data;
  AssociationState truth;
  std::vector<int> track_class;
};

// Each object's detections, in frame order, cut into tracks of kTrackLength.
std::unique_ptr<Problem> MakeProblem(int k) {
  auto p = std::make_unique<Problem>();
  const testing::SyntheticSceneOptions options = testing::GrownLpaLoop(k);
  p->scene = testing::MakeSyntheticScene(p->camera, options);
  const GeometricSlamProblem& problem = p->scene.problem;
  p->data.camera = &p->camera;
  p->data.increments = problem.increments;
  p->data.first_pose = problem.first_pose;
  p->data.classes = problem.classes;
  std::vector<std::vector<int>> by_object(options.num_objects);
  for (const auto& o : problem.observations) {
    by_object[o.object_id].push_back(static_cast<int>(p->data.detections.size()));
    p->data.detections.push_back({o.frame, problem.object_class.at(o.object_id), o.slice});
  }
  for (int j = 0; j < options.num_objects; ++j) {
    std::vector<int> block;
    for (size_t first = 0; first + kTrackLength <= by_object[j].size(); first += kTrackLength) {
      Track track;
      track.id = static_cast<int>(p->data.tracks.size());
      track.class_index = problem.object_class.at(j);
      track.detections.assign(by_object[j].begin() + first,
                              by_object[j].begin() + first + kTrackLength);
      block.push_back(track.id);
      p->track_class.push_back(track.class_index);
      p->data.tracks.push_back(track);
    }
    if (block.empty()) continue;
    p->truth.blocks.push_back(block);
    p->truth.classes.push_back(problem.object_class.at(j));
  }
  p->truth.Canonicalize();
  return p;
}

// range(0) = k (size), range(1) = 1: chains on threads, 0: one after another.
void BM_Mc3FromTrueAssociation(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const std::unique_ptr<Problem> p = MakeProblem(k);
  const ClassConfusionModel model = ClassConfusionModel::Identity(
      2, 1e-3, p->track_class, std::vector<int>(p->track_class.size(), 1));
  SlamTargetOptions target;
  SamplerOptions options;
  options.hill_climb_steps = 0;
  options.num_iterations = 200;
  options.burn_in = 20;
  options.parallel_chains = state.range(1) != 0;
  SamplerSummary summary;
  for (auto _ : state) {
    Sampler sampler(
        model, [&] { return std::make_unique<SlamEvaluator>(p->data, model, target); }, options);
    summary = sampler.Run(p->truth).summary;
  }
  long proposals = 0;
  double evaluation_s = 0;
  for (const MoveStatistics& m : summary.sampling) {
    proposals += m.evaluated();
    evaluation_s += m.time_s;
  }
  state.counters["poses"] = static_cast<double>(p->data.increments.size());
  state.counters["tracks"] = static_cast<double>(p->data.tracks.size());
  state.counters["objects"] = static_cast<double>(p->truth.blocks.size());
  state.counters["solves"] = static_cast<double>(summary.num_solves);
  state.counters["mc3_s"] = summary.sampling_time_s;
  // The cold chain's proposals other than self-transitions: screened, cached or solved.
  state.counters["ms_per_proposal"] = 1e3 * evaluation_s / std::max(1L, proposals);
}
BENCHMARK(BM_Mc3FromTrueAssociation)
    ->ArgsProduct({{1, 2, 4}, {0, 1}})
    ->ArgNames({"k", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace
}  // namespace oslam

// Cost of one O-SLAM proposal on the real Victoria Park data
// (docs/method.md §16.2): prefixes of 1k, 2k, 4k and all 6,969 poses, sightings grouped into
// tracks, the all-separate state solved in full (the reference), then merge
// proposals of two nearby landmarks (within 5 m) evaluated by each mode:
// marginal (closed form from the pair's joint marginal covariance), local
// (poses held, the merged landmark solved alone) and exact (warm re-solve of
// the whole problem, 5 LM iterations). Every iteration is a different
// proposal (no cache hits). Skips with a message when ../shared/data is absent.
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "association/landmark_evaluator.h"
#include "association/landmark_tracks.h"
#include "bench/victoria_park_data.h"

namespace oslam {
namespace {

constexpr int kProposals = 30;

void BM_VictoriaParkProposal(benchmark::State& state) {
  if (!VictoriaPark()) {
    state.SkipWithError("../shared/data/victoria_park absent");
    return;
  }
  const LandmarkDataset data = PosePrefix(*VictoriaPark(), static_cast<int>(state.range(0)));
  LandmarkTargetData target{&data, BuildLandmarkTracks(data, data.dead_reckoning, {})};
  LandmarkTargetOptions options;
  options.mode = static_cast<LandmarkEvaluationMode>(state.range(1));
  options.max_cache_entries = 1;  // no revisits: every proposal is evaluated
  LandmarkEvaluator evaluator(target, options);
  AssociationState separate;
  for (size_t t = 0; t < target.tracks.size(); ++t) {
    separate.blocks.push_back({static_cast<int>(t)});
    separate.classes.push_back(0);
  }
  const EvaluationPtr reference = evaluator.Refine(separate, nullptr);
  std::vector<AssociationState> proposals;
  for (size_t a = 0; a < separate.blocks.size() && proposals.size() < kProposals; ++a)
    for (size_t b = a + 1; b < separate.blocks.size() && proposals.size() < kProposals; ++b)
      if ((reference->locations[a] - reference->locations[b]).norm() < 5.0) {
        proposals.push_back(separate.WithBlocksMerged(static_cast<int>(a), static_cast<int>(b)));
      }
  size_t i = 0;
  for (auto _ : state) {
    const EvaluationPtr e = evaluator.Evaluate(proposals[i++ % proposals.size()], reference.get());
    benchmark::DoNotOptimize(e->log_target);
  }
  state.counters["poses"] = data.num_poses;
  state.counters["tracks"] = target.tracks.size();
  state.counters["reference_solve_ms"] = 1e3 * reference->evaluation_time_s;
}

void Arguments(benchmark::internal::Benchmark* b) {
  for (int mode : {static_cast<int>(LandmarkEvaluationMode::kMarginal),
                   static_cast<int>(LandmarkEvaluationMode::kLocal),
                   static_cast<int>(LandmarkEvaluationMode::kExact)})
    for (int poses : {1000, 2000, 4000, 6969}) b->Args({poses, mode});
  b->ArgNames({"poses", "mode"});
  b->Iterations(kProposals);
  b->Unit(benchmark::kMillisecond);
}
BENCHMARK(BM_VictoriaParkProposal)->Apply(Arguments);

}  // namespace
}  // namespace oslam

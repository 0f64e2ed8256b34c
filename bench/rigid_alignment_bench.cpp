// RANSAC rigid alignment (association/rigid_alignment.h) at the size of the
// joint re-entry merges on a park drive (pipeline/landmark_association.h,
// docs/method.md §16.2): old landmarks scattered over a 300 m square, the
// recent ones a part of them seen again under a drift (a rotation and a
// shift) plus clutter, with the joint merges' default RANSAC options.
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "association/rigid_alignment.h"
#include "pipeline/landmark_association.h"

namespace oslam {
namespace {

struct Scene {
  std::vector<Eigen::Vector2d> recent, old;
};

Scene ParkScene(int num_old, int num_recent, int num_clutter) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> where(0.0, 300.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  Scene scene;
  for (int i = 0; i < num_old; ++i) scene.old.emplace_back(where(rng), where(rng));
  Rigid2 drift;
  drift.angle = 0.1;
  drift.t = Eigen::Vector2d(6.0, -4.0);
  // The recent landmarks: those of the old ones in a 120 m square, drifted.
  for (const Eigen::Vector2d& p : scene.old)
    if (p.x() < 120 && p.y() < 120 && static_cast<int>(scene.recent.size()) < num_recent)
      scene.recent.push_back(drift(p) + Eigen::Vector2d(noise(rng), noise(rng)));
  std::uniform_real_distribution<double> near(0.0, 120.0);
  for (int i = 0; i < num_clutter; ++i) scene.recent.emplace_back(near(rng), near(rng));
  return scene;
}

// Arguments: old landmarks, recent ones, recent clutter.
void BM_MatchRigidlyBothWays(benchmark::State& state) {
  const Scene scene = ParkScene(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)),
                                static_cast<int>(state.range(2)));
  const RigidRansacOptions options = JointRansacOptions(UnknownAssociationOptions{});
  int pairs = 0;
  for (auto _ : state) {
    std::mt19937_64 rng(1);
    const RigidMatches matches = MatchRigidlyBothWays(scene.recent, scene.old, options, rng);
    pairs = matches.most_pairs ? static_cast<int>(matches.most_pairs->pairs.size()) : 0;
    benchmark::DoNotOptimize(pairs);
  }
  state.counters["pairs"] = pairs;
}
BENCHMARK(BM_MatchRigidlyBothWays)
    ->Args({200, 40, 40})
    ->Args({700, 60, 200})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace oslam

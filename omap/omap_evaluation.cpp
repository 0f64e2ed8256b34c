#include "omap/omap_evaluation.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace oslam {
namespace {

double Rmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  const size_t n = std::min(a.size(), b.size());
  double sum = 0;
  for (size_t i = 0; i < n; ++i) sum += std::pow(a[i].x - b[i].x, 2) + std::pow(a[i].y - b[i].y, 2);
  return n ? std::sqrt(sum / n) : 0.0;
}

}  // namespace

OMapScore ScoreOMap(const OMap& map, const std::vector<Pose2>& odometry, const GroundTruth& truth,
                    const OMapScoreOptions& options) {
  OMapScore score;
  score.trajectory_rmse_m = Rmse(map.trajectory, truth.trajectory);
  score.odometry_rmse_m = Rmse(odometry, truth.trajectory);
  std::vector<int> kept;
  for (size_t m = 0; m < map.objects.size(); ++m)
    if (map.objects[m].existence_probability > options.existence_threshold)
      kept.push_back(static_cast<int>(m));
  // Greedy one-to-one matching, closest pairs first.
  std::vector<std::tuple<double, int, int>> pairs;
  std::vector<int> real;
  for (size_t o = 0; o < truth.objects.size(); ++o) {
    if (truth.objects[o].class_name.empty()) continue;
    real.push_back(static_cast<int>(o));
    for (int m : kept) {
      const double d =
          (map.objects[m].base_world.head<2>() - truth.objects[o].base_world.head<2>()).norm();
      if (d < options.match_distance_m) pairs.push_back({d, static_cast<int>(o), m});
    }
  }
  score.true_objects = static_cast<int>(real.size());
  std::sort(pairs.begin(), pairs.end());
  std::vector<bool> truth_used(truth.objects.size()), map_used(map.objects.size());
  std::vector<double> errors;
  for (const auto& [d, o, m] : pairs) {
    if (truth_used[o] || map_used[m]) continue;
    truth_used[o] = map_used[m] = true;
    ++score.found;
    errors.push_back(d);
    if (map.objects[m].class_name == truth.objects[o].class_name) ++score.class_correct;
  }
  for (int m : kept) score.spurious += !map_used[m];
  for (int o : real)
    if (!truth_used[o]) score.missed.push_back(truth.objects[o].class_name);
  if (!errors.empty()) {
    std::sort(errors.begin(), errors.end());
    const size_t k = errors.size();
    score.position_median_m = k % 2 ? errors[k / 2] : 0.5 * (errors[k / 2 - 1] + errors[k / 2]);
    score.position_max_m = errors.back();
  }
  return score;
}

}  // namespace oslam

#include "association/association_metrics.h"

#include <cmath>
#include <map>
#include <string>
#include <utility>

#include "association/rigid_alignment.h"
#include "core/error.h"

namespace oslam {

PairwiseAgreement ComparePairwise(const std::vector<int>& estimate, const std::vector<int>& truth) {
  if (estimate.size() != truth.size())
    throw Error("pairwise comparison: " + std::to_string(estimate.size()) + " vs " +
                std::to_string(truth.size()) + " sightings");
  // -1 becomes a label of its own per sighting.
  const long long n = static_cast<long long>(estimate.size());
  auto label = [](int id, long long k) { return id >= 0 ? static_cast<long long>(id) : -1 - k; };
  std::map<long long, long long> count_e, count_t;
  std::map<std::pair<long long, long long>, long long> count_both;
  for (long long k = 0; k < n; ++k) {
    const long long e = label(estimate[k], k), t = label(truth[k], k);
    ++count_e[e];
    ++count_t[t];
    ++count_both[{e, t}];
  }
  auto pairs = [](long long c) { return c * (c - 1) / 2; };
  PairwiseAgreement a;
  a.pairs = pairs(n);
  for (const auto& [key, c] : count_e) a.same_estimate += pairs(c);
  for (const auto& [key, c] : count_t) a.same_truth += pairs(c);
  for (const auto& [key, c] : count_both) a.same_both += pairs(c);
  const long long disagree = a.same_estimate + a.same_truth - 2 * a.same_both;
  a.agreement = a.pairs > 0 ? 1.0 - double(disagree) / double(a.pairs) : 1.0;
  a.precision = a.same_estimate > 0 ? double(a.same_both) / double(a.same_estimate) : 1.0;
  a.recall = a.same_truth > 0 ? double(a.same_both) / double(a.same_truth) : 1.0;
  return a;
}

double TrajectoryRmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  if (a.size() != b.size() || a.empty())
    throw Error("trajectory RMSE: " + std::to_string(a.size()) + " vs " + std::to_string(b.size()) +
                " poses");
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i)
    sum += (a[i].x - b[i].x) * (a[i].x - b[i].x) + (a[i].y - b[i].y) * (a[i].y - b[i].y);
  return std::sqrt(sum / double(a.size()));
}

double AlignedTrajectoryRmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  TrajectoryRmse(a, b);  // the size checks
  std::vector<Eigen::Vector2d> from, to;
  for (size_t i = 0; i < a.size(); ++i) {
    from.emplace_back(a[i].x, a[i].y);
    to.emplace_back(b[i].x, b[i].y);
  }
  const Rigid2 motion = FitRigid(from, to);
  double sum = 0;
  for (size_t i = 0; i < from.size(); ++i) sum += (motion(from[i]) - to[i]).squaredNorm();
  return std::sqrt(sum / double(from.size()));
}

}  // namespace oslam

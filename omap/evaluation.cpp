#include "omap/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/angles.h"
#include "core/error.h"
#include "core/statistics.h"

namespace oslam {

bool MapMetricsOptions::Validate(std::string* why) const {
  if (!(existence_threshold >= 0 && existence_threshold < 1)) {
    if (why) *why = "existence threshold must be in [0, 1)";
    return false;
  }
  if (!(match_gate_m > 0)) {
    if (why) *why = "match gate must be positive";
    return false;
  }
  return true;
}

std::vector<int> MinCostAssignment(const std::vector<std::vector<double>>& cost, double forbidden) {
  // Square the problem with dummy rows/columns of cost `forbidden`, then run
  // the O(n^3) shortest-augmenting-path form of the Hungarian method.
  const int rows = static_cast<int>(cost.size());
  const int cols = rows ? static_cast<int>(cost[0].size()) : 0;
  const int n = std::max(rows, cols);
  auto at = [&](int r, int c) {
    return (r < rows && c < cols) ? std::min(cost[r][c], forbidden) : forbidden;
  };
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> u(n + 1, 0), v(n + 1, 0);
  std::vector<int> match_of_col(n + 1, 0), way(n + 1, 0);
  for (int r = 1; r <= n; ++r) {
    match_of_col[0] = r;
    int col0 = 0;
    std::vector<double> min_to(n + 1, inf);
    std::vector<bool> used(n + 1, false);
    do {
      used[col0] = true;
      const int row0 = match_of_col[col0];
      double delta = inf;
      int col1 = 0;
      for (int c = 1; c <= n; ++c) {
        if (used[c]) continue;
        const double reduced = at(row0 - 1, c - 1) - u[row0] - v[c];
        if (reduced < min_to[c]) {
          min_to[c] = reduced;
          way[c] = col0;
        }
        if (min_to[c] < delta) {
          delta = min_to[c];
          col1 = c;
        }
      }
      for (int c = 0; c <= n; ++c) {
        if (used[c]) {
          u[match_of_col[c]] += delta;
          v[c] -= delta;
        } else {
          min_to[c] -= delta;
        }
      }
      col0 = col1;
    } while (match_of_col[col0] != 0);
    do {
      const int col1 = way[col0];
      match_of_col[col0] = match_of_col[col1];
      col0 = col1;
    } while (col0);
  }
  std::vector<int> column_of_row(rows, -1);
  for (int c = 1; c <= n; ++c) {
    const int r = match_of_col[c] - 1;
    if (r < rows && c - 1 < cols && cost[r][c - 1] < forbidden) column_of_row[r] = c - 1;
  }
  return column_of_row;
}

namespace {

TrajectoryMetrics TrajectoryErrors(const std::vector<Pose2>& estimate,
                                   const std::vector<Pose2>& truth) {
  TrajectoryMetrics m;
  double ate = 0, rpe_t = 0, rpe_r = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    ate += std::pow(estimate[i].x - truth[i].x, 2) + std::pow(estimate[i].y - truth[i].y, 2);
    if (i == 0) continue;
    // Frame-to-frame motion in the earlier frame's robot frame.
    const Eigen::Vector3d d_est = estimate[i - 1].WorldToRobot({estimate[i].x, estimate[i].y, 0});
    const Eigen::Vector3d d_true = truth[i - 1].WorldToRobot({truth[i].x, truth[i].y, 0});
    rpe_t += (d_est - d_true).squaredNorm();
    const double turn_est = WrapAngle(estimate[i].theta - estimate[i - 1].theta);
    const double turn_true = WrapAngle(truth[i].theta - truth[i - 1].theta);
    rpe_r += std::pow(WrapAngle(turn_est - turn_true), 2);
  }
  const double n = static_cast<double>(truth.size());
  m.ate_rmse_m = std::sqrt(ate / n);
  if (truth.size() > 1) {
    m.rpe_translation_rmse_m = std::sqrt(rpe_t / (n - 1));
    m.rpe_rotation_rmse_rad = std::sqrt(rpe_r / (n - 1));
  }
  return m;
}

}  // namespace

MapMetrics EvaluateMap(const OMap& map, const std::vector<Pose2>& odometry,
                       const GroundTruth& truth, const MapMetricsOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("evaluation: " + why);
  if (truth.trajectory.empty()) throw Error("evaluation: the ground truth has no trajectory");
  if (map.trajectory.size() != truth.trajectory.size())
    throw Error("evaluation: the map's trajectory has " + std::to_string(map.trajectory.size()) +
                " poses, the ground truth " + std::to_string(truth.trajectory.size()));
  if (odometry.size() != truth.trajectory.size())
    throw Error("evaluation: odometry has " + std::to_string(odometry.size()) +
                " poses, the ground truth " + std::to_string(truth.trajectory.size()));
  MapMetrics metrics;
  metrics.estimate = TrajectoryErrors(map.trajectory, truth.trajectory);
  metrics.odometry = TrajectoryErrors(odometry, truth.trajectory);

  std::vector<const GroundTruthObject*> true_objects;
  for (const GroundTruthObject& o : truth.objects)
    if (!o.class_name.empty()) true_objects.push_back(&o);
  std::vector<const OMapObject*> map_objects;
  for (const OMapObject& o : map.objects)
    if (o.existence_probability > options.existence_threshold) map_objects.push_back(&o);
  metrics.true_objects_total = static_cast<int>(true_objects.size());

  auto horizontal = [](const GroundTruthObject& t, const OMapObject& m) {
    return (t.base_world.head<2>() - m.base_world.head<2>()).norm();
  };
  // The map object of every true object, or -1.
  std::vector<int> assignment(true_objects.size(), -1);
  if (options.matching == ObjectMatching::kById) {
    std::map<int, int> by_id;
    for (size_t m = 0; m < map_objects.size(); ++m)
      by_id.emplace(map_objects[m]->id, static_cast<int>(m));
    for (size_t t = 0; t < true_objects.size(); ++t) {
      const auto found = by_id.find(true_objects[t]->id);
      if (found != by_id.end()) assignment[t] = found->second;
    }
  } else {
    const double forbidden = 1e9;
    std::vector<std::vector<double>> cost(true_objects.size(),
                                          std::vector<double>(map_objects.size(), forbidden));
    for (size_t t = 0; t < true_objects.size(); ++t)
      for (size_t m = 0; m < map_objects.size(); ++m) {
        const double distance = horizontal(*true_objects[t], *map_objects[m]);
        if (distance <= options.match_gate_m) cost[t][m] = distance;
      }
    assignment = MinCostAssignment(cost, forbidden);
  }

  std::vector<double> position, flat, diameter, height;
  for (size_t t = 0; t < true_objects.size(); ++t) {
    const GroundTruthObject& truth_object = *true_objects[t];
    if (assignment[t] < 0) {
      metrics.missed_classes.push_back(truth_object.class_name);
      continue;
    }
    const OMapObject& map_object = *map_objects[assignment[t]];
    ObjectMatch match{truth_object.id,
                      map_object.id,
                      truth_object.class_name,
                      map_object.class_name,
                      (truth_object.base_world - map_object.base_world).norm(),
                      horizontal(truth_object, map_object),
                      map_object.diameter_m - truth_object.diameter_m,
                      map_object.height_m - truth_object.height_m};
    position.push_back(match.position_error_m);
    flat.push_back(match.horizontal_error_m);
    diameter.push_back(std::abs(match.diameter_error_m));
    height.push_back(std::abs(match.height_error_m));
    metrics.class_correct += match.true_class == match.map_class;
    metrics.matches.push_back(match);
  }
  metrics.true_objects_found = static_cast<int>(metrics.matches.size());
  metrics.spurious_objects = static_cast<int>(map_objects.size()) - metrics.true_objects_found;
  metrics.object_position_error_median_m = Median(position);
  metrics.object_horizontal_error_median_m = Median(flat);
  auto max = [](const std::vector<double>& v) {
    return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
  };
  metrics.object_position_error_max_m = max(position);
  metrics.object_horizontal_error_max_m = max(flat);
  auto mean = [](const std::vector<double>& v) {
    double sum = 0;
    for (double x : v) sum += x;
    return v.empty() ? 0.0 : sum / v.size();
  };
  metrics.diameter_error_mean_m = mean(diameter);
  metrics.height_error_mean_m = mean(height);
  metrics.class_accuracy =
      metrics.matches.empty() ? 0.0 : double(metrics.class_correct) / metrics.matches.size();
  return metrics;
}

std::string MapMetrics::Table() const {
  // Every name says what it measures: trajectory errors are horizontal (the
  // poses are planar), object position errors are given in 3D and on the
  // floor, because the base point's height is estimated too.
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof(line), "%-10s %14s %18s %15s\n", "trajectory", "ATE m (x, y)",
                "RPE step m (x, y)", "RPE yaw deg");
  out << line;
  for (const auto& [name, m] :
       {std::pair<const char*, const TrajectoryMetrics&>{"estimate", estimate},
        {"odometry", odometry}}) {
    std::snprintf(line, sizeof(line), "%-10s %14.3f %18.4f %15.3f\n", name, m.ate_rmse_m,
                  m.rpe_translation_rmse_m, RadToDeg(m.rpe_rotation_rmse_rad));
    out << line;
  }
  std::snprintf(line, sizeof(line),
                "objects: %d of %d true objects found, %d spurious; class accuracy %.3f\n"
                "object base-point error: median %.3f m 3D, %.3f m horizontal; max %.3f m 3D, "
                "%.3f m horizontal\nsize error: mean |diameter| %.3f m, mean |height| %.3f m\n",
                true_objects_found, true_objects_total, spurious_objects, class_accuracy,
                object_position_error_median_m, object_horizontal_error_median_m,
                object_position_error_max_m, object_horizontal_error_max_m, diameter_error_mean_m,
                height_error_mean_m);
  out << line;
  for (const ObjectMatch& m : matches) {
    std::snprintf(line, sizeof(line),
                  "  %-16s -> map %-4d %-16s 3D %.3f m  horizontal %.3f m  d %+.3f  h %+.3f\n",
                  m.true_class.c_str(), m.map_id, m.map_class.c_str(), m.position_error_m,
                  m.horizontal_error_m, m.diameter_error_m, m.height_error_m);
    out << line;
  }
  return out.str();
}

std::string MapMetrics::Json() const {
  nlohmann::ordered_json j;
  j["ate_rmse_m"] = estimate.ate_rmse_m;
  j["odometry_ate_rmse_m"] = odometry.ate_rmse_m;
  j["rpe_translation_rmse_m"] = estimate.rpe_translation_rmse_m;
  j["odometry_rpe_translation_rmse_m"] = odometry.rpe_translation_rmse_m;
  j["rpe_rotation_rmse_rad"] = estimate.rpe_rotation_rmse_rad;
  j["odometry_rpe_rotation_rmse_rad"] = odometry.rpe_rotation_rmse_rad;
  j["object_position_error_median_m"] = object_position_error_median_m;  // 3D
  j["object_position_error_max_m"] = object_position_error_max_m;
  j["object_horizontal_error_median_m"] = object_horizontal_error_median_m;  // x, y
  j["object_horizontal_error_max_m"] = object_horizontal_error_max_m;
  j["diameter_error_mean_m"] = diameter_error_mean_m;
  j["height_error_mean_m"] = height_error_mean_m;
  j["class_accuracy"] = class_accuracy;
  j["true_objects_found"] = true_objects_found;
  j["true_objects_total"] = true_objects_total;
  j["spurious_objects"] = spurious_objects;
  j["matches"] = nlohmann::ordered_json::array();
  for (const ObjectMatch& m : matches) {
    j["matches"].push_back({{"true_id", m.true_id},
                            {"map_id", m.map_id},
                            {"true_class", m.true_class},
                            {"map_class", m.map_class},
                            {"position_error_m", m.position_error_m},
                            {"horizontal_error_m", m.horizontal_error_m},
                            {"diameter_error_m", m.diameter_error_m},
                            {"height_error_m", m.height_error_m}});
  }
  return j.dump(2) + "\n";
}

}  // namespace oslam

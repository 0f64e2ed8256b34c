#include "slam/landmark_noise.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.h"
#include "slam/landmark_factors.h"
#include "solver/values.h"

namespace oslam {

bool NoiseCalibrationOptions::Validate(std::string* why) const {
  if (iterations < 1 || !(outlier_gate > 0) || !(min_redundancy >= 0) || !(min_scale > 0) ||
      !(max_scale > min_scale) || !std::isfinite(max_scale) || redundancy_samples < 1) {
    if (why)
      *why =
          "noise calibration: need >= 1 iteration and draw, an outlier gate > 0, redundancy "
          ">= 0 and 0 < min scale < max scale < inf";
    return false;
  }
  return true;
}

LandmarkDataset WithNoiseScales(const LandmarkDataset& data, const NoiseScales& scales) {
  LandmarkDataset scaled = data;
  const double r = std::sqrt(scales.range), b = std::sqrt(scales.bearing);
  for (LandmarkSighting& s : scaled.sightings) {
    s.range_std_m *= r;
    s.bearing_std_rad *= b;
    s.xy_covariance *= scales.point;
  }
  const Eigen::Vector3d d(std::sqrt(scales.odometry_translation),
                          std::sqrt(scales.odometry_translation),
                          std::sqrt(scales.odometry_heading));
  for (RelativePoseMeasurement& e : scaled.odometry)
    e.covariance = d.asDiagonal() * e.covariance * d.asDiagonal();
  return scaled;
}

namespace {

enum Group { kRange, kBearing, kPoint, kTranslation, kHeading, kGroups };

struct Sums {
  double squared[kGroups] = {0, 0, 0, 0, 0};
  double redundancy[kGroups] = {0, 0, 0, 0, 0};
  int outliers = 0;
  std::vector<int> outlier_sightings;
};

// Adds a factor's rows: the squared whitened errors and the redundancy
// 1 - (J Sigma J^T)_ii of each row, Sigma the joint covariance of its
// variables at the solution, estimated from draws Y of them (columns) as
// (J Y)(J Y)^T / count.
// False when the factor is gated out as an outlier.
bool AddRows(const Factor& factor, const Values& values, const Eigen::MatrixXd& draws,
             const int* groups, double gate, Sums* sums) {
  const int m = factor.Dimension();
  Eigen::VectorXd error(m);
  Eigen::MatrixXd jacobian(m, draws.rows());
  if (!factor.Linearize(values, error, &jacobian)) return true;
  if (error.squaredNorm() > gate) {
    ++sums->outliers;
    return false;
  }
  const Eigen::MatrixXd projected = jacobian * draws;
  const double count = static_cast<double>(draws.cols());
  for (int i = 0; i < m; ++i) {
    sums->squared[groups[i]] += error[i] * error[i];
    sums->redundancy[groups[i]] += 1.0 - projected.row(i).squaredNorm() / count;
  }
  return true;
}

// Draws of (pose, other) where a fixed pose (the gauge) was left out: zero
// rows for it.
Eigen::MatrixXd WithFixedPose(const Eigen::MatrixXd& draws, int fixed_dim, bool first_fixed) {
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(draws.rows() + fixed_dim, draws.cols());
  if (first_fixed)
    full.bottomRows(draws.rows()) = draws;
  else
    full.topRows(draws.rows()) = draws;
  return full;
}

Sums ResidualSums(const LandmarkDataset& data, const std::vector<int>& association,
                  LandmarkSlam* slam, const LandmarkSlamResult& result,
                  const NoiseCalibrationOptions& options, unsigned long seed) {
  // Pose i has key i (LandmarkSlam adds the poses first); pose 0 is fixed.
  std::vector<int> landmark_key;  // by sighting, -1 unused
  std::vector<const MappedLandmark*> landmark;
  landmark_key.reserve(data.sightings.size());
  for (size_t k = 0; k < data.sightings.size(); ++k) {
    const MappedLandmark* found =
        association[k] >= 0 ? result.FindLandmark(association[k]) : nullptr;
    landmark_key.push_back(found ? result.landmark_position_keys[found - result.landmarks.data()]
                                 : -1);
    landmark.push_back(found);
  }
  std::vector<std::vector<int>> groups;
  std::vector<int> sighting_group(data.sightings.size(), -1);
  for (size_t k = 0; k < data.sightings.size(); ++k) {
    if (landmark_key[k] < 0) continue;
    const int pose = data.sightings[k].pose;
    sighting_group[k] = static_cast<int>(groups.size());
    groups.push_back(pose == 0 ? std::vector<int>{landmark_key[k]}
                               : std::vector<int>{pose, landmark_key[k]});
  }
  std::vector<int> edge_group(data.odometry.size(), -1);
  for (size_t e = 0; e < data.odometry.size(); ++e) {
    const RelativePoseMeasurement& edge = data.odometry[e];
    std::vector<int> keys;
    if (edge.from != 0) keys.push_back(edge.from);
    if (edge.to != 0) keys.push_back(edge.to);
    edge_group[e] = static_cast<int>(groups.size());
    groups.push_back(keys);
  }
  CovarianceDraws draws;  // of every variable once; each factor gathers its rows
  std::string why;
  if (!slam->solver().CovarianceSamples(groups, options.redundancy_samples, seed, &draws, &why))
    throw Error("noise calibration: no covariance draws (" + why + ")");
  Eigen::MatrixXd gathered;
  const double gate = options.outlier_gate;
  Sums sums;
  for (size_t k = 0; k < data.sightings.size(); ++k) {
    if (sighting_group[k] < 0) continue;
    const LandmarkSighting& s = data.sightings[k];
    const Pose2& p = result.trajectory[s.pose];
    Values values;
    values.AddPose(p.x, p.y, p.theta);
    values.Add(landmark[k]->position_m);
    draws.Gather(sighting_group[k], &gathered);
    if (s.pose == 0) gathered = WithFixedPose(gathered, 3, true);
    if (s.cartesian) {
      const Eigen::Vector2d z(s.range_m * std::cos(s.bearing_rad),
                              s.range_m * std::sin(s.bearing_rad));
      const PointSightingFactor factor(0, 1, z, s.xy_covariance, data.sensor_offset_m);
      const int rows[2] = {kPoint, kPoint};
      if (!AddRows(factor, values, gathered, rows, gate, &sums))
        sums.outlier_sightings.push_back(static_cast<int>(k));
    } else {
      const RangeBearingFactor factor(0, 1, s.range_m, s.bearing_rad, s.range_std_m,
                                      s.bearing_std_rad, data.sensor_offset_m);
      const int rows[2] = {kRange, kBearing};
      if (!AddRows(factor, values, gathered, rows, gate, &sums))
        sums.outlier_sightings.push_back(static_cast<int>(k));
    }
  }
  for (size_t e = 0; e < data.odometry.size(); ++e) {
    const RelativePoseMeasurement& edge = data.odometry[e];
    const Pose2& a = result.trajectory[edge.from];
    const Pose2& b = result.trajectory[edge.to];
    Values values;
    values.AddPose(a.x, a.y, a.theta);
    values.AddPose(b.x, b.y, b.theta);
    draws.Gather(edge_group[e], &gathered);
    if (edge.from == 0) gathered = WithFixedPose(gathered, 3, true);
    if (edge.to == 0) gathered = WithFixedPose(gathered, 3, false);
    const RelativePoseFactor factor(0, 1, edge.delta, edge.covariance);
    const int rows[3] = {kTranslation, kTranslation, kHeading};
    AddRows(factor, values, gathered, rows, gate, &sums);
  }
  return sums;
}

}  // namespace

NoiseCalibrationResult CalibrateNoise(const LandmarkDataset& data,
                                      const std::vector<int>& association,
                                      const LandmarkSlamOptions& slam_options,
                                      const NoiseCalibrationOptions& options,
                                      const LandmarkSlamResult* warm_start) {
  const auto start = std::chrono::steady_clock::now();
  std::string why;
  if (!options.Validate(&why)) throw Error(why);
  LandmarkSlamOptions solve = slam_options;
  solve.compute_landmark_covariances = false;
  solve.compute_pose_covariances = false;
  NoiseCalibrationResult out;
  LandmarkSlamResult previous;
  if (warm_start) previous = *warm_start;
  bool warm = warm_start != nullptr;
  // Sightings gated out leave the solves too (they would bend the solution
  // the other groups' residuals are measured at); odometry edges cannot.
  std::vector<int> used = association;
  const int solves = options.final_solve ? options.iterations + 1 : options.iterations;
  for (int it = 0; it < solves; ++it) {
    const LandmarkDataset scaled = WithNoiseScales(data, out.scales);
    // The last solve, under the final scales, is the result: with the
    // covariances the caller asked for.
    LandmarkSlamOptions this_solve = solve;
    if (it == options.iterations) {
      this_solve.compute_landmark_covariances = slam_options.compute_landmark_covariances;
      this_solve.compute_pose_covariances = slam_options.compute_pose_covariances;
    }
    LandmarkSlam slam(this_solve);
    LandmarkSlamResult result = slam.Solve(scaled, used, warm ? &previous : nullptr);
    if (!result.summary.IsUsable())
      throw Error::InFile(data.path,
                          "noise calibration: the solve failed (" + result.summary.message + ")");
    previous = std::move(result);
    warm = true;
    if (it == options.iterations) break;  // the last solve is under the final scales
    const Sums sums = ResidualSums(scaled, used, &slam, previous, options, options.seed + it);
    double* scale[kGroups] = {&out.scales.range, &out.scales.bearing, &out.scales.point,
                              &out.scales.odometry_translation, &out.scales.odometry_heading};
    for (int g = 0; g < kGroups; ++g) {
      out.redundancy[g] = sums.redundancy[g];
      if (sums.redundancy[g] < options.min_redundancy) continue;
      *scale[g] = std::clamp(*scale[g] * sums.squared[g] / sums.redundancy[g], options.min_scale,
                             options.max_scale);
    }
    for (int k : sums.outlier_sightings) used[k] = -1;
    int removed = 0;
    for (size_t k = 0; k < used.size(); ++k) removed += association[k] >= 0 && used[k] < 0;
    out.outliers = removed + sums.outliers - static_cast<int>(sums.outlier_sightings.size());
  }
  out.solution = std::move(previous);
  out.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace oslam

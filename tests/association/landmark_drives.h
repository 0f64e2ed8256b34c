// Simulated planar landmark drives for the tests of the landmark
// association: trees beside a path driven with noisy odometry, sightings
// with the true landmark ids (hidden from the solves, used to score them).
#pragma once

#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "association/landmark_evaluator.h"
#include "core/angles.h"
#include "core/pose2.h"
#include "slam/landmark_data.h"
#include "slam/landmark_factors.h"

namespace oslam::testing {

// Two laps (2 m steps) around a 36 m x 24 m block with 14 trees at least
// 5 m apart; trees seen within 14 m ahead of the sensor (|bearing| < 80 deg),
// so each lap sees each tree as a separate stretch of scans.
inline LandmarkDataset SimulateDrive(unsigned seed, std::vector<Pose2>* true_poses) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Eigen::Vector2d> trees;
  while (trees.size() < 14) {
    const Eigen::Vector2d t(-4 + 44 * uniform(rng), -4 + 32 * uniform(rng));
    if (t.x() > 2 && t.x() < 34 && t.y() > 2 && t.y() < 22) continue;  // inside the path
    bool far = true;
    for (const auto& o : trees) far = far && (o - t).norm() > 5.0;
    if (far) trees.push_back(t);
  }
  LandmarkDataset data;
  data.path = "simulated";
  data.format = "simulated";
  data.has_landmark_ids = true;
  std::vector<Pose2> poses{{0, 0, 0}};
  const int sides[4] = {18, 12, 18, 12};
  for (int lap = 0; lap < 2; ++lap)
    for (int side = 0; side < 4; ++side)
      for (int k = 0; k < sides[side]; ++k) {
        const double turn = k == sides[side] - 1 ? kPi / 2 : 0.0;
        poses.push_back(ComposePose(poses.back(), {2.0, 0.0, turn}));
      }
  data.num_poses = static_cast<int>(poses.size());
  for (int i = 0; i < data.num_poses; ++i) data.pose_ids.push_back(i);
  const Eigen::Vector3d odometry_std(0.03, 0.02, 0.01);
  data.dead_reckoning.push_back(poses.front());
  for (int i = 1; i < data.num_poses; ++i) {
    const Pose2& a = poses[i - 1];
    const Pose2& b = poses[i];
    const Eigen::Vector3d d = a.WorldToRobot(Eigen::Vector3d(b.x, b.y, 0));
    RelativePoseMeasurement edge;
    edge.from = i - 1;
    edge.to = i;
    edge.delta = {d.x() + odometry_std.x() * normal(rng), d.y() + odometry_std.y() * normal(rng),
                  WrapAngle(b.theta - a.theta + odometry_std.z() * normal(rng))};
    edge.covariance = odometry_std.cwiseAbs2().asDiagonal();
    data.odometry.push_back(edge);
    data.dead_reckoning.push_back(ComposePose(data.dead_reckoning.back(), edge.delta));
  }
  for (int i = 0; i < data.num_poses; ++i)
    for (size_t id = 0; id < trees.size(); ++id) {
      const Eigen::Vector2d d = trees[id] - Eigen::Vector2d(poses[i].x, poses[i].y);
      const double bearing = WrapAngle(std::atan2(d.y(), d.x()) - poses[i].theta);
      if (d.norm() > 14.0 || std::abs(bearing) > 1.4) continue;
      LandmarkSighting s;
      s.pose = i;
      s.landmark = static_cast<int>(id);
      s.range_std_m = 0.1;
      s.bearing_std_rad = 0.01;
      s.range_m = d.norm() + s.range_std_m * normal(rng);
      s.bearing_rad = WrapAngle(bearing + s.bearing_std_rad * normal(rng));
      data.sightings.push_back(s);
    }
  if (true_poses) *true_poses = poses;
  return data;
}

// A lap of a 40 m x 30 m block A (trees around it), then a 420 m excursion
// through new trees (south 80 m, east 150 m, north 80 m, then west 150 m,
// entering A along its south side) and on around A (west and north sides).
// The odometry turns left `heading_bias_rad` per step more than the car did,
// far beyond its stated noise, so the car re-enters A tens of metres and
// degrees off: one re-seen tree cannot pay for bending the excursion, all of
// them together can.
inline LandmarkDataset SimulateExcursion(unsigned seed, double heading_bias_rad,
                                         double tree_spacing_m = 6.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  // The path as (length in 2 m steps, turn at its end) legs from (0, 0) east.
  const std::vector<std::pair<int, double>> legs = {
      {20, kPi / 2},  {15, kPi / 2},  {20, kPi / 2}, {15, kPi / 2},  // lap of A
      {0, -kPi / 2},  {40, kPi / 2},  {75, kPi / 2}, {40, kPi / 2},  // excursion
      {75, -kPi / 2}, {15, -kPi / 2}, {20, 0.0}};                    // back around A
  std::vector<Pose2> poses{{0, 0, 0}};
  for (const auto& [steps, turn] : legs) {
    for (int k = 0; k < steps; ++k) poses.push_back(ComposePose(poses.back(), {2.0, 0.0, 0.0}));
    if (turn != 0) {
      Pose2& last = poses.back();
      last.theta = WrapAngle(last.theta + turn);
    }
  }
  // Trees 4-7 m beside the path, at least tree_spacing_m apart.
  const size_t max_trees = static_cast<size_t>(70 * 36 / (tree_spacing_m * tree_spacing_m));
  std::vector<Eigen::Vector2d> trees;
  for (int attempt = 0; attempt < 20000 && trees.size() < max_trees; ++attempt) {
    const Pose2& p = poses[std::uniform_int_distribution<size_t>(0, poses.size() - 1)(rng)];
    const double side = uniform(rng) < 0.5 ? -1 : 1, offset = side * (4 + 3 * uniform(rng));
    const Eigen::Vector2d t(p.x - offset * std::sin(p.theta), p.y + offset * std::cos(p.theta));
    bool clear = true;
    for (const auto& o : trees) clear = clear && (o - t).norm() > tree_spacing_m;
    for (const auto& q : poses) clear = clear && (Eigen::Vector2d(q.x, q.y) - t).norm() > 3.0;
    if (clear) trees.push_back(t);
  }
  LandmarkDataset data;
  data.path = "simulated";
  data.format = "simulated";
  data.has_landmark_ids = true;
  data.num_poses = static_cast<int>(poses.size());
  for (int i = 0; i < data.num_poses; ++i) data.pose_ids.push_back(i);
  const Eigen::Vector3d odometry_std(0.02, 0.01, 0.002);
  data.dead_reckoning.push_back(poses.front());
  for (int i = 1; i < data.num_poses; ++i) {
    const Pose2& a = poses[i - 1];
    const Pose2& b = poses[i];
    const Eigen::Vector3d d = a.WorldToRobot(Eigen::Vector3d(b.x, b.y, 0));
    RelativePoseMeasurement edge;
    edge.from = i - 1;
    edge.to = i;
    edge.delta = {d.x() + odometry_std.x() * normal(rng), d.y() + odometry_std.y() * normal(rng),
                  WrapAngle(b.theta - a.theta + heading_bias_rad + odometry_std.z() * normal(rng))};
    edge.covariance = odometry_std.cwiseAbs2().asDiagonal();
    data.odometry.push_back(edge);
    data.dead_reckoning.push_back(ComposePose(data.dead_reckoning.back(), edge.delta));
  }
  for (int i = 0; i < data.num_poses; ++i)
    for (size_t id = 0; id < trees.size(); ++id) {
      const Eigen::Vector2d d = trees[id] - Eigen::Vector2d(poses[i].x, poses[i].y);
      const double bearing = WrapAngle(std::atan2(d.y(), d.x()) - poses[i].theta);
      if (d.norm() > 14.0 || std::abs(bearing) > 1.4) continue;
      LandmarkSighting s;
      s.pose = i;
      s.landmark = static_cast<int>(id);
      s.range_std_m = 0.1;
      s.bearing_std_rad = 0.01;
      s.range_m = d.norm() + s.range_std_m * normal(rng);
      s.bearing_rad = WrapAngle(bearing + s.bearing_std_rad * normal(rng));
      data.sightings.push_back(s);
    }
  return data;
}

// Target options for these drives: the default location prior (a density)
// or a Gaussian one centred on the block, and converged re-solves for the
// exact evaluation.
enum class DrivePrior { kDensity, kGaussian };
inline LandmarkTargetOptions DriveTargetOptions(LandmarkEvaluationMode mode,
                                                DrivePrior prior = DrivePrior::kDensity) {
  LandmarkTargetOptions options;
  options.mode = mode;
  if (prior == DrivePrior::kGaussian) {
    options.slam.landmark_density_per_m2 = 0;
    options.slam.landmark_prior_std_m = 50.0;
    options.slam.landmark_prior_mean_m = Eigen::Vector2d(18, 12);
  }
  options.proposal_iterations = 50;  // "exact": converged re-solves
  return options;
}

}  // namespace oslam::testing

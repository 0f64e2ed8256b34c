#include "slam/landmark_slam.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <unordered_map>

#include <Eigen/Cholesky>

#include "core/angles.h"
#include "core/error.h"
#include "slam/factors.h"
#include "slam/landmark_factors.h"
#include "solver/factor_graph.h"

namespace oslam {

std::vector<Pose2> ExtendByOdometry(const std::vector<Pose2>& solved,
                                    const std::vector<Pose2>& dead_reckoning) {
  std::vector<Pose2> poses = solved;
  if (solved.empty()) return dead_reckoning;
  const size_t k = solved.size() - 1;
  const Pose2& anchor = dead_reckoning[k];
  for (size_t j = solved.size(); j < dead_reckoning.size(); ++j)
    poses.push_back(ComposePose(solved[k], BetweenPoses(anchor, dead_reckoning[j])));
  return poses;
}

const MappedLandmark* LandmarkSlamResult::FindLandmark(int id) const {
  const auto it = std::lower_bound(landmarks.begin(), landmarks.end(), id,
                                   [](const MappedLandmark& l, int v) { return l.id < v; });
  return it != landmarks.end() && it->id == id ? &*it : nullptr;
}

double LandmarkSlamOptions::LogLandmarkDensity() const {
  return landmark_density_per_m2 > 0 ? std::log(landmark_density_per_m2) : 0.0;
}

bool LandmarkSlamOptions::Validate(std::string* why) const {
  if (!(diameter_std_m > 0) || !std::isfinite(diameter_std_m)) {
    if (why) *why = "the diameter noise must be > 0 and finite";
    return false;
  }
  if (!(landmark_prior_std_m >= 0) || !std::isfinite(landmark_prior_std_m) ||
      !landmark_prior_mean_m.allFinite()) {
    if (why) *why = "the landmark prior std must be >= 0 and the mean finite";
    return false;
  }
  if (!(landmark_density_per_m2 >= 0) || !std::isfinite(landmark_density_per_m2)) {
    if (why) *why = "the landmark density must be >= 0 and finite";
    return false;
  }
  if (landmark_density_per_m2 > 0 && landmark_prior_std_m > 0) {
    if (why) *why = "give either a Gaussian landmark prior (std) or a landmark density, not both";
    return false;
  }
  if (held_poses < 0) {
    if (why) *why = "the held poses must be >= 0";
    return false;
  }
  if (initialisation_window_poses < 0 || !(initialisation_gate >= 0)) {
    if (why) *why = "the initialisation window (poses) and gate must be >= 0";
    return false;
  }
  return solver.Validate(why);
}

LandmarkSlam::LandmarkSlam(const LandmarkSlamOptions& options)
    : options_(options), solver_(options.solver) {}

namespace {

double SecondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Sightings per landmark id, in pose order (the first one initialises the
// landmark). Throws oslam::Error on ids < -1 and poses outside the data set.
std::map<int, std::vector<int>> SightingsByLandmark(const LandmarkDataset& data,
                                                    const std::vector<int>& association) {
  std::map<int, std::vector<int>> by_landmark;
  for (size_t k = 0; k < association.size(); ++k) {
    if (association[k] < -1)
      throw Error("landmark SLAM: sighting " + std::to_string(k) + " has landmark id " +
                  std::to_string(association[k]) + " (ids are >= 0, -1 = none)");
    const LandmarkSighting& s = data.sightings[k];
    if (s.pose < 0 || s.pose >= data.num_poses)
      throw Error("landmark SLAM: sighting " + std::to_string(k) + " refers to pose " +
                  std::to_string(s.pose) + " of " + std::to_string(data.num_poses));
    if (association[k] >= 0) by_landmark[association[k]].push_back(static_cast<int>(k));
  }
  for (auto& [id, list] : by_landmark)
    std::stable_sort(list.begin(), list.end(),
                     [&](int a, int b) { return data.sightings[a].pose < data.sightings[b].pose; });
  return by_landmark;
}

// A landmark's variables in the graph.
struct LandmarkKeys {
  int id, position, diameter;  // diameter -1: none measured
  int count;
};

// Adds every landmark's position (and measured diameter) variable, started
// where `warm_start` has it, else at its first sighting with a range.
std::vector<LandmarkKeys> AddLandmarkVariables(const LandmarkDataset& data,
                                               const std::map<int, std::vector<int>>& by_landmark,
                                               const std::vector<Pose2>& initial,
                                               const LandmarkSlamResult* warm_start,
                                               FactorGraph* graph) {
  std::map<int, const MappedLandmark*> previous;
  if (warm_start)
    for (const auto& landmark : warm_start->landmarks) previous[landmark.id] = &landmark;
  std::vector<LandmarkKeys> landmarks;
  landmarks.reserve(by_landmark.size());
  for (const auto& [id, list] : by_landmark) {
    // The first sighting with a bearing (range > 0) places the landmark.
    const auto with_range = std::find_if(list.begin(), list.end(),
                                         [&](int k) { return data.sightings[k].range_m > 0; });
    if (with_range == list.end())
      throw Error("landmark SLAM: every sighting of landmark " + std::to_string(id) +
                  " has range 0 (no bearing)");
    const LandmarkSighting& first = data.sightings[*with_range];
    const auto found = previous.find(id);
    const Eigen::Vector2d start =
        found != previous.end() ? found->second->position_m
                                : LandmarkFromRangeBearing(initial[first.pose], first.range_m,
                                                           first.bearing_rad, data.sensor_offset_m);
    LandmarkKeys keys{id, graph->AddVariable(start), -1, static_cast<int>(list.size())};
    if (const std::optional<double> measured = MeanMeasuredDiameter(data.sightings, list)) {
      const double d = found != previous.end() && std::isfinite(found->second->diameter_m)
                           ? found->second->diameter_m
                           : *measured;
      keys.diameter = graph->AddVariable(Eigen::Matrix<double, 1, 1>(d));
    }
    landmarks.push_back(keys);
  }
  return landmarks;
}

void AddOdometryFactors(const LandmarkDataset& data, const std::vector<int>& pose_keys,
                        FactorGraph* graph) {
  for (const RelativePoseMeasurement& edge : data.odometry) {
    if (edge.from < 0 || edge.from >= data.num_poses || edge.to < 0 || edge.to >= data.num_poses)
      throw Error("landmark SLAM: odometry between poses " + std::to_string(edge.from) + " and " +
                  std::to_string(edge.to) + " outside the data set");
    graph->Emplace<RelativePoseFactor>(pose_keys[edge.from], pose_keys[edge.to], edge.delta,
                                       edge.covariance);
  }
}

// The location prior, range-bearing and diameter factors of every landmark;
// returns the number of sightings used.
int AddLandmarkFactors(const LandmarkDataset& data, const LandmarkSlamOptions& options,
                       const std::map<int, std::vector<int>>& by_landmark,
                       const std::vector<LandmarkKeys>& landmarks,
                       const std::vector<int>& pose_keys, FactorGraph* graph) {
  const Eigen::Matrix<double, 1, 1> diameter_variance(options.diameter_std_m *
                                                      options.diameter_std_m);
  int used = 0;
  for (const LandmarkKeys& landmark : landmarks) {
    if (options.landmark_prior_std_m > 0)
      graph->Emplace<PriorFactor>(
          landmark.position, Eigen::VectorXd(options.landmark_prior_mean_m),
          Eigen::MatrixXd(Eigen::Matrix2d::Identity() * options.landmark_prior_std_m *
                          options.landmark_prior_std_m),
          "landmark prior");
    for (int k : by_landmark.at(landmark.id)) {
      const LandmarkSighting& s = data.sightings[k];
      AddSightingFactor(graph, pose_keys[s.pose], landmark.position, s, data.sensor_offset_m);
      if (landmark.diameter >= 0 && std::isfinite(s.diameter_m))
        graph->Emplace<PriorFactor>(landmark.diameter, Eigen::Matrix<double, 1, 1>(s.diameter_m),
                                    diameter_variance, "diameter");
      ++used;
    }
  }
  return used;
}

// The solved trajectory and landmarks read out of the graph's values.
void ReadSolution(const Values& values, const std::vector<int>& pose_keys,
                  const std::vector<LandmarkKeys>& landmarks, LandmarkSlamResult* result) {
  result->trajectory.reserve(pose_keys.size());
  result->pose_keys = pose_keys;
  for (int key : pose_keys) {
    const double* p = values.Data(key);
    result->trajectory.push_back({p[0], p[1], p[2]});
  }
  for (const LandmarkKeys& landmark : landmarks) {
    MappedLandmark mapped;
    mapped.id = landmark.id;
    mapped.position_m = values.Get(landmark.position);
    if (landmark.diameter >= 0) mapped.diameter_m = values.Data(landmark.diameter)[0];
    mapped.num_sightings = landmark.count;
    result->landmarks.push_back(mapped);
    result->landmark_position_keys.push_back(landmark.position);
  }
}

}  // namespace

LandmarkSlamResult LandmarkSlam::Solve(const LandmarkDataset& data,
                                       const std::vector<int>& association,
                                       const LandmarkSlamResult* warm_start) {
  const auto start_time = std::chrono::steady_clock::now();
  std::string why;
  if (!options_.Validate(&why)) throw Error("landmark SLAM options: " + why);
  if (data.num_poses < 1) throw Error("landmark SLAM: no poses");
  if (association.size() != data.sightings.size())
    throw Error("landmark SLAM: the association has " + std::to_string(association.size()) +
                " entries for " + std::to_string(data.sightings.size()) + " sightings");
  const std::map<int, std::vector<int>> by_landmark = SightingsByLandmark(data, association);

  LandmarkSlamResult staged;
  if (!warm_start &&
      (options_.initialisation_gate > 0 || options_.initialisation_window_poses > 0)) {
    staged = StagedInitialisation(data, association);
    if (!staged.trajectory.empty()) warm_start = &staged;
  }
  const double initialisation_time_s = SecondsSince(start_time);

  FactorGraph graph;
  const bool warm_poses =
      warm_start && static_cast<int>(warm_start->trajectory.size()) == data.num_poses;
  const std::vector<Pose2>& initial = warm_poses ? warm_start->trajectory : data.dead_reckoning;
  if (static_cast<int>(initial.size()) != data.num_poses)
    throw Error("landmark SLAM: the data set's dead reckoning does not cover its poses");
  std::vector<int> pose_keys(data.num_poses);
  for (int i = 0; i < data.num_poses; ++i)
    pose_keys[i] = graph.AddPose(initial[i].x, initial[i].y, initial[i].theta,
                                 /*fixed=*/i == 0 || i < options_.held_poses);  // gauge
  const std::vector<LandmarkKeys> landmarks =
      AddLandmarkVariables(data, by_landmark, initial, warm_start, &graph);
  AddOdometryFactors(data, pose_keys, &graph);
  const int used = AddLandmarkFactors(data, options_, by_landmark, landmarks, pose_keys, &graph);

  solver_.set_options(options_.solver);
  const SolveResult solved = solver_.Solve(&graph);
  LandmarkSlamResult result;
  result.summary = solved.summary;
  result.evidence = solved.evidence;
  result.evidence.log_evidence += double(landmarks.size()) * options_.LogLandmarkDensity();
  result.num_sightings_used = used;
  result.initialisation_time_s = initialisation_time_s;
  result.initialisation_stages = staged.initialisation_stages;
  ReadSolution(graph.values(), pose_keys, landmarks, &result);
  if (result.summary.IsUsable()) {
    std::vector<std::vector<int>> groups;
    for (const LandmarkKeys& landmark : landmarks) {
      groups.push_back({landmark.position});
      if (landmark.diameter >= 0) groups.back().push_back(landmark.diameter);
    }
    Covariances(groups, pose_keys, &result);
  }
  result.total_time_s = SecondsSince(start_time);
  return result;
}

void LandmarkSlam::Covariances(const std::vector<std::vector<int>>& landmark_groups,
                               const std::vector<int>& pose_keys, LandmarkSlamResult* result) {
  if (options_.compute_landmark_covariances && !landmark_groups.empty()) {
    std::vector<Eigen::MatrixXd> blocks;
    if (solver_.MarginalCovariances(landmark_groups, &blocks, &result->covariance_message))
      for (size_t j = 0; j < landmark_groups.size(); ++j) {
        const int n = static_cast<int>(blocks[j].rows());
        result->landmarks[j].covariance.topLeftCorner(n, n) = blocks[j];
      }
  }
  if (options_.compute_pose_covariances) {
    std::vector<std::vector<int>> groups;
    for (size_t i = 1; i < pose_keys.size(); ++i) groups.push_back({pose_keys[i]});
    std::vector<Eigen::MatrixXd> blocks;
    result->pose_covariances.assign(pose_keys.size(), Eigen::Matrix3d::Zero());
    if (groups.empty() || solver_.MarginalCovariances(groups, &blocks, &result->covariance_message))
      for (size_t i = 0; i < blocks.size(); ++i) result->pose_covariances[i + 1] = blocks[i];
  }
}

namespace {

// The gate's errors are whitened by the stated noise floored at what LM
// corrects from anywhere in its linear regime (3 degrees of bearing or
// heading, 5 % of a range or of an edge's length): with a precise sensor a
// few centimetres of drift are many sigmas, yet no reason for a stage
// (method.md §16.1).
constexpr double kGateAngleFloor = 0.05, kGateLengthFloor = 0.05;

double EdgeGateError(const RelativePoseMeasurement& edge, const std::vector<Pose2>& poses) {
  const Pose2 d = BetweenPoses(poses[edge.from], poses[edge.to]);
  const Eigen::Vector3d r(d.x - edge.delta.x, d.y - edge.delta.y,
                          WrapAngle(d.theta - edge.delta.theta));
  const double length_floor = kGateLengthFloor * (std::hypot(edge.delta.x, edge.delta.y) + 1.0);
  const Eigen::Vector3d floor(length_floor, length_floor, kGateAngleFloor);
  const Eigen::Vector3d std = edge.covariance.diagonal().cwiseSqrt().cwiseMax(floor);
  return r.cwiseQuotient(std).squaredNorm();
}

double SightingGateError(const LandmarkSighting& z, const Pose2& pose,
                         const Eigen::Vector2d& landmark_m, const Eigen::Vector2d& mount_m) {
  const Eigen::Vector3d sensor = pose.RobotToWorld(Eigen::Vector3d(mount_m.x(), mount_m.y(), 0.0));
  const Eigen::Vector2d d = landmark_m - sensor.head<2>();
  const double range_error =
      (d.norm() - z.range_m) / std::max(z.range_std_m, kGateLengthFloor * std::max(z.range_m, 1.0));
  const double bearing_error = WrapAngle(std::atan2(d.y(), d.x()) - pose.theta - z.bearing_rad) /
                               std::max(z.bearing_std_rad, kGateAngleFloor);
  return range_error * range_error + bearing_error * bearing_error;
}

// Where the next stage of the staged initialisation ends (a pose count):
// poses [0, solved) are solved in `previous`. Walking on from `solved` along
// the trajectory extended by odometry, with the landmarks of `previous` where
// it has them and the others at their first sighting, the stage ends after
// the first pose with a sighting or an odometry edge back to an earlier pose
// whose gate error exceeds the gate (a loop closing), or after
// `window` poses; data.num_poses when neither happens.
int NextStageEnd(const LandmarkDataset& data, const std::vector<int>& association,
                 const std::vector<std::vector<int>>& sightings_at,
                 const std::vector<std::vector<int>>& edges_at, const LandmarkSlamResult& previous,
                 int solved, double gate, int window) {
  const std::vector<Pose2> poses = ExtendByOdometry(previous.trajectory, data.dead_reckoning);
  std::unordered_map<int, Eigen::Vector2d> placed;
  for (const MappedLandmark& landmark : previous.landmarks)
    placed[landmark.id] = landmark.position_m;
  for (int i = solved; i < data.num_poses; ++i) {
    if (window > 0 && i - solved >= window) return i;
    if (gate <= 0) continue;
    double worst = 0;
    for (int k : sightings_at[i]) {
      const LandmarkSighting& z = data.sightings[k];
      const auto found = placed.find(association[k]);
      if (found == placed.end()) {
        placed[association[k]] =
            LandmarkFromRangeBearing(poses[i], z.range_m, z.bearing_rad, data.sensor_offset_m);
        continue;
      }
      worst = std::max(worst, SightingGateError(z, poses[i], found->second, data.sensor_offset_m));
    }
    for (int e : edges_at[i]) worst = std::max(worst, EdgeGateError(data.odometry[e], poses));
    if (worst > gate) return i + 1;
  }
  return data.num_poses;
}

}  // namespace

LandmarkSlamResult LandmarkSlam::StagedInitialisation(const LandmarkDataset& data,
                                                      const std::vector<int>& association) const {
  LandmarkSlamOptions inner = options_;
  inner.initialisation_window_poses = 0;
  inner.initialisation_gate = 0;
  inner.compute_landmark_covariances = false;
  inner.compute_pose_covariances = false;
  inner.solver.compute_evidence = false;
  // Every stage is a new problem analysed afresh; AMD costs a fraction of
  // METIS to compute, and a stage's loose solve does not repay METIS's
  // smaller fill (Victoria Park: 1.48 -> 1.21 s; a 20,000-pose graph with
  // 275 stages 24 -> 18 s; the same optima).
  inner.solver.ordering = OrderingType::kAmd;
  // A stage only has to bring the next closure into the full solve's basin;
  // the full solve converges tightly.
  inner.solver.function_tolerance = std::max(inner.solver.function_tolerance, 1e-5);
  inner.solver.step_tolerance = std::max(inner.solver.step_tolerance, 1e-2);
  inner.solver.absolute_function_tolerance =
      std::max(inner.solver.absolute_function_tolerance, 1.0);
  LandmarkSlam stage(inner);
  // Per pose: the sightings used (range > 0) and the odometry edges to an
  // earlier pose (loop closures and the chain; the chain's error is 0 on the
  // extended trajectory).
  std::vector<std::vector<int>> sightings_at(data.num_poses), edges_at(data.num_poses);
  for (size_t k = 0; k < data.sightings.size(); ++k)
    if (association[k] >= 0 && data.sightings[k].range_m > 0)
      sightings_at[data.sightings[k].pose].push_back(static_cast<int>(k));
  for (size_t e = 0; e < data.odometry.size(); ++e) {
    const RelativePoseMeasurement& edge = data.odometry[e];
    edges_at[std::max(edge.from, edge.to)].push_back(static_cast<int>(e));
  }
  LandmarkSlamResult previous;
  int solved = 0, stages = 0;
  while (true) {
    const int n = NextStageEnd(data, association, sightings_at, edges_at, previous, solved,
                               options_.initialisation_gate, options_.initialisation_window_poses);
    if (n >= data.num_poses) break;  // the rest is the full solve's
    std::vector<int> kept;
    const LandmarkDataset prefix = PosePrefix(data, n, &kept);
    std::vector<int> prefix_association;
    prefix_association.reserve(kept.size());
    for (int k : kept) prefix_association.push_back(association[k]);
    LandmarkSlamResult start;
    start.landmarks = previous.landmarks;
    start.trajectory = ExtendByOdometry(previous.trajectory, prefix.dead_reckoning);
    LandmarkSlamResult solved_stage = stage.Solve(prefix, prefix_association, &start);
    if (!solved_stage.summary.IsUsable()) return {};  // fall back to dead reckoning
    previous = std::move(solved_stage);
    solved = n;
    ++stages;
  }
  if (stages == 0) return {};
  LandmarkSlamResult start;
  start.landmarks = std::move(previous.landmarks);
  start.trajectory = ExtendByOdometry(previous.trajectory, data.dead_reckoning);
  start.initialisation_stages = stages;
  return start;
}

LandmarkDataset PosePrefix(const LandmarkDataset& data, int num_poses,
                           std::vector<int>* kept_sightings) {
  LandmarkDataset prefix = data;
  const int n = std::max(0, std::min(num_poses, data.num_poses));
  prefix.num_poses = n;
  prefix.pose_ids.resize(std::min(prefix.pose_ids.size(), static_cast<size_t>(n)));
  if (!prefix.pose_times.empty()) prefix.pose_times.resize(n);
  prefix.dead_reckoning.resize(n);
  prefix.odometry.clear();
  for (const auto& edge : data.odometry)
    if (edge.from < n && edge.to < n) prefix.odometry.push_back(edge);
  prefix.sightings.clear();
  if (kept_sightings) kept_sightings->clear();
  for (size_t k = 0; k < data.sightings.size(); ++k)
    if (data.sightings[k].pose < n) {
      prefix.sightings.push_back(data.sightings[k]);
      if (kept_sightings) kept_sightings->push_back(static_cast<int>(k));
    }
  return prefix;
}

double TrajectoryLength(const std::vector<Pose2>& trajectory) {
  double length = 0;
  for (size_t i = 1; i < trajectory.size(); ++i)
    length +=
        std::hypot(trajectory[i].x - trajectory[i - 1].x, trajectory[i].y - trajectory[i - 1].y);
  return length;
}

}  // namespace oslam

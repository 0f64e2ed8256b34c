// Planar landmark SLAM with a given association (docs/method.md §16.1): poses linked by
// relative-pose odometry, point landmarks (trees) seen by range and bearing,
// trunk diameters as the objects' size when measured. Built on the same
// factor graph and SparseSolver as geometric O-SLAM, so the result carries
// the Laplace log-evidence (docs/method.md §8.2) and marginal covariances.
//
// The association comes from anywhere: a vector with one landmark id per
// sighting (-1: the sighting is left out, e.g. clutter). The file's ids give
// known-association SLAM; an MCMC sampler passes its own vector and may
// warm-start from a previous result and reuse the solver's symbolic
// analysis, as GeometricSlam does.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/pose2.h"
#include "slam/geometric_slam.h"
#include "slam/landmark_data.h"
#include "solver/sparse_solver.h"

namespace oslam {

struct LandmarkSlamOptions {
  // LM starts with little damping (1e-8 instead of 1e-4): the damping is
  // relative to diag(J^T J), and on a long, stiff odometry chain even 1e-4
  // of it blocks the slow whole-trajectory corrections (Victoria Park: no
  // convergence in 100 iterations, against 11 at 1e-8).
  LandmarkSlamOptions() { solver.initial_damping = 1e-8; }

  SolverOptions solver;
  // Std of one trunk-diameter measurement (PriorFactor "diameter" on the
  // landmark's diameter variable).
  double diameter_std_m = 0.05;
  // Location prior of every landmark, N(landmark_prior_mean_m,
  // landmark_prior_std_m^2 I) (the class location prior of docs/method.md §5.1). 0:
  // none (flat), which is fine for a fixed association but makes the
  // evidence improper across associations with different landmark counts:
  // without it a split of one sighting off a landmark can raise the
  // evidence (Victoria Park, 1k poses: +2.1). Samplers should set it.
  double landmark_prior_std_m = 0.0;
  Eigen::Vector2d landmark_prior_mean_m = Eigen::Vector2d::Zero();
  // Location prior of constant density (landmarks a spatial Poisson process
  // of this many per square metre, docs/method.md §16.2): every landmark adds
  // log(landmark_density_per_m2) to the evidence and nothing to the
  // geometry. The Gaussian prior above pulls every landmark toward its mean,
  // and on a map wider than its std the pull bends the trajectory (the first
  // 4,000 poses of the 20,000-pose world with the true association: 205 m
  // from the true trajectory under a 100 m prior, 21 m without). 0: none.
  // Not with landmark_prior_std_m.
  double landmark_density_per_m2 = 0.0;
  // The evidence's location-prior term of a landmark, log(density), or 0.
  double LogLandmarkDensity() const;
  // Staged initialisation (no warm start; docs/method.md §16.1): the poses
  // are solved in growing prefixes, each stage starting from the previous
  // one's estimate extended by the odometry, and the full solve starts from
  // the last stage. A batch LM from plain dead reckoning stops in a false
  // minimum (or crawls) when the drive has drifted far before a loop closes.
  //
  // Adaptive stages (initialisation_gate > 0): a stage ends at the first
  // pose whose sighting of a landmark placed before, or whose odometry edge
  // to an earlier pose, is off its prediction at the extended start by more
  // than the gate, in squared errors whitened by the stated noise floored at
  // 3 degrees and 5 % of a length (LM's linear regime): a loop closes there,
  // and it is solved before the drive goes on. Stretches without such a
  // closure are only dead-reckoned, so the stages follow the data (Victoria
  // Park: 51 stages; every gate from 25 to 3,000 reaches the optimum,
  // 10,000 does not).
  double initialisation_gate = 100;
  // Fixed stages of this many poses (0: none); with the gate on, the
  // longest a stage may be.
  int initialisation_window_poses = 0;
  // Poses 0..held_poses-1 are held at their start values (pose 0 always is):
  // a windowed solve of the recent drive, its evidence conditional on the
  // held poses (for comparing associations within one window).
  int held_poses = 0;
  bool compute_landmark_covariances = true;
  bool compute_pose_covariances = false;

  bool Validate(std::string* why) const;
};

struct MappedLandmark {
  int id = 0;
  Eigen::Vector2d position_m = Eigen::Vector2d::Zero();
  double diameter_m = std::numeric_limits<double>::quiet_NaN();  // NaN: never measured
  // Joint covariance of (x, y, diameter); the diameter row/column is zero
  // when it was not measured, everything zero when not computed.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int num_sightings = 0;
};

struct LandmarkSlamResult {
  std::vector<Pose2> trajectory;                  // one per pose of the data set
  std::vector<Eigen::Matrix3d> pose_covariances;  // empty unless asked; pose 0 is zero
  std::vector<MappedLandmark> landmarks;          // sorted by id
  // The solver's variable key of each landmark's position (parallel to
  // landmarks), for MarginalCovariances on solver() after this solve.
  std::vector<int> landmark_position_keys;
  std::vector<int> pose_keys;  // the solver's key of each pose (LandmarkSlam::solver())
  SolverSummary summary;
  Evidence evidence;
  std::string covariance_message;  // why covariances are missing, if they are
  int num_sightings_used = 0;
  // Wall time of Solve (s): staged initialisation, final solve, covariances.
  double total_time_s = 0;
  double initialisation_time_s = 0;  // the staged initialisation's part
  int initialisation_stages = 0;     // prefixes solved before the full solve

  // The landmark of this id (binary search: landmarks are sorted by id), or
  // nullptr.
  const MappedLandmark* FindLandmark(int id) const;
};

class LandmarkSlam {
 public:
  explicit LandmarkSlam(const LandmarkSlamOptions& options = LandmarkSlamOptions());

  // association[k] is the landmark id of data.sightings[k] (>= 0) or -1.
  // Pose 0 is held at the origin (the gauge); the other poses start from the
  // dead reckoning, or from warm_start's trajectory when it has as many
  // poses; a landmark starts where warm_start has it, else at its first
  // sighting (lowest pose index) with a range > 0. Throws oslam::Error for
  // invalid input (options, association size, ids < -1, a landmark seen only
  // at range 0); numerical trouble is reported in the summary.
  LandmarkSlamResult Solve(const LandmarkDataset& data, const std::vector<int>& association,
                           const LandmarkSlamResult* warm_start = nullptr);

  SparseSolver& solver() { return solver_; }
  const LandmarkSlamOptions& options() const { return options_; }

 private:
  LandmarkSlamResult StagedInitialisation(const LandmarkDataset& data,
                                          const std::vector<int>& association) const;
  // Marginal covariances of the landmarks (their variable groups, parallel
  // to result->landmarks) and, when asked, of every pose but the first.
  void Covariances(const std::vector<std::vector<int>>& landmark_groups,
                   const std::vector<int>& pose_keys, LandmarkSlamResult* result);

  LandmarkSlamOptions options_;
  SparseSolver solver_;
};

// The data set cut to its first `num_poses` poses: odometry and sightings
// touching later poses are dropped (for benchmarks and windowed solves).
// Returns the indices of the kept sightings in `kept_sightings` if given.
LandmarkDataset PosePrefix(const LandmarkDataset& data, int num_poses,
                           std::vector<int>* kept_sightings = nullptr);

// `solved` (the first poses) followed by the later poses of `dead_reckoning`
// moved rigidly so that they continue from the last solved pose.
std::vector<Pose2> ExtendByOdometry(const std::vector<Pose2>& solved,
                                    const std::vector<Pose2>& dead_reckoning);

// Sum of the distances between consecutive poses (m).
double TrajectoryLength(const std::vector<Pose2>& trajectory);

}  // namespace oslam

// Geometric O-SLAM with known classes and association (docs/method.md §5, setup 1):
// builds the factor graph from odometry and bounding slices, initialises it
// (poses from odometry, objects from their first detection), solves it, and
// returns the MAP map, covariances and the Laplace log-evidence (docs/method.md §8.2).
//
// The same object serves the MCMC (docs/method.md §9): Solve() with a `warm_start`
// reuses the previous estimate for every pose and every object id still
// present, and the solver keeps its symbolic analysis when the new block
// pattern fits in the old one.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/camera_model.h"
#include "calib/observation_model.h"
#include "core/bounding_slice.h"
#include "core/motion_model.h"
#include "core/pose2.h"
#include "solver/sparse_solver.h"

namespace oslam {

// One detection with its association J(i, k) = object_id.
struct SliceObservation {
  long frame = 0;
  int object_id = 0;
  BoundingSlice slice;
  // The detection's index in the caller's data (>= 0), the same in every
  // problem one GeometricSlam solves: with the solver's
  // reuse_linearizations, its linearisation is kept across solves under
  // this id. -1: none.
  int detection_id = -1;
};

// Class priors (docs/method.md §5.1): size g ~ N(size_mean, diag(size_std^2)),
// location l ~ N(location_mean, diag(location_std^2)).
struct ClassPrior {
  std::string name;
  Eigen::Vector2d size_mean_m{0.3, 0.3};  // (diameter, height)
  Eigen::Vector2d size_std_m{0.1, 0.1};
  Eigen::Vector3d location_mean_m = Eigen::Vector3d::Zero();  // gamma(c): 0 (docs/method.md §5.1)
  Eigen::Vector3d location_std_m{10.0, 10.0, 2.0};            // Gamma(c), docs/method.md §5.1 [G]
  // How the class's detections relate to its geometry (silhouette,
  // censored slice ends; docs/method.md §4.2). Default: the thesis' section.
  SliceModel slice_model{};
};

struct GeometricSlamProblem {
  // increments[i] takes pose i-1 to pose i; increments[0] is ignored. Its
  // size is the number of poses T.
  std::vector<OdometryIncrement> increments;
  std::vector<SliceObservation> observations;
  std::vector<ClassPrior> classes;
  std::map<int, int> object_class;  // object id -> index into classes
  Pose2 first_pose;                 // x_1, clamped (docs/method.md §3.4)
};

// The initial estimate of a long run (GeometricSlam::KeyframeStart): a batch
// solve from raw odometry cannot undo laps of drift, so the run is first
// solved as it grows, on every `spacing`-th pose.
struct KeyframeStartOptions {
  // Used without a warm start for runs of more poses than this (0: never).
  long min_poses = 2000;
  int spacing = 10;  // poses per keyframe
  int stage = 10;    // keyframes added per stage
  int window = 20;   // the latest keyframes free in a stage (>= stage)
  // A stage whose reduced chi-square ||e||^2 / (rows - free parameters)
  // stays above this (a loop closed after a long drift) is solved again with
  // all keyframes free. Raised to 1.1 times what such a solve reaches, when
  // that is more (a model that fits real data no better).
  double max_reduced_chi_square = 1.5;
  int stage_iterations = 10;     // LM iterations of a stage
  int resolve_iterations = 30;   // ... of a stage solved again
  int final_iterations = 50;     // ... of the last solve, all keyframes free
  double stage_tolerance = 0.1;  // nats: the stages need not fit finely
  // An object joins the stages once detected from this many keyframes.
  int min_detections = 3;
  // LM's initial damping (at most) in the stages and the solve from their result:
  // Marquardt damping of 1e-4 diag(J'J) holds back the slow whole-map
  // corrections of a long run for ~10 iterations (as in LandmarkSlamOptions).
  double initial_damping = 1e-8;
  // SolverOptions::max_step_extrapolation (at least) of the stages and of
  // the solve from their result: weakly seen objects crawl without it
  // (10,000 poses, seed 2: 42 iterations instead of 24).
  double step_extrapolation = 16.0;

  bool Validate(std::string* why) const;
  // `solver` with the damping and line search above, for the stages and the
  // solve from their result.
  SolverOptions ForSolver(SolverOptions solver) const;
};

// What the keyframe start did (GeometricSlamResult::keyframe_start).
struct KeyframeStartSummary {
  bool used = false;
  int num_keyframes = 0;
  int stage_solves = 0;      // including stages solved again
  int closures = 0;          // stages solved again with every keyframe free
  int stage_iterations = 0;  // LM iterations over all stage solves
  int final_iterations = 0;  // of the last keyframe solve
  double time_s = 0.0;
};

struct GeometricSlamOptions {
  MotionNoiseOptions motion;
  double pixel_std_px = 30.0;  // E of docs/method.md §4.2 (thesis: 30 px)
  SolverOptions solver;
  // A new object (not in the warm start) starts from its first detection
  // and is then refined, alone and with the poses held, on up to this many
  // of its first detections (0: no refinement).
  int initial_refinement_detections = 20;
  KeyframeStartOptions keyframe_start;
  bool compute_object_covariances = true;
  bool compute_pose_covariances = false;

  bool Validate(std::string* why) const;
};

struct MappedObject {
  int id = 0;
  int class_index = 0;
  CylinderGeometry geometry;
  bool oriented = false;  // geometry.yaw_rad was estimated (a panel, docs/method.md §4.2)
  // Joint covariance of (x, y, z, d, h); zero when not computed.
  Eigen::Matrix<double, 5, 5> covariance = Eigen::Matrix<double, 5, 5>::Zero();
  int num_observations = 0;
  // Sum of the whitened squared errors of its detections at the solution
  // (r^2(j) of eq. 5.2, R = diag(E^2, (E/u_r)^2), W = 2R).
  double squared_residual = 0;
};

struct GeometricSlamResult {
  std::vector<Pose2> trajectory;
  std::vector<Eigen::Matrix3d> pose_covariances;  // empty unless asked; pose 0 is zero
  std::vector<MappedObject> objects;              // sorted by id
  SolverSummary summary;
  Evidence evidence;
  std::string covariance_message;       // why covariances are missing, if they are
  bool has_object_covariances = false;  // objects[].covariance were computed
  KeyframeStartSummary keyframe_start;
};

// Objects' initial geometry from a first detection (docs/method.md §5.4): bearing from
// u_phi (through the camera), range from the class's diameter prior and the
// angular width, height above the floor chosen so that the base point lies
// on the ray of u_r, size = prior mean. False when the slice has no ray.
bool InitialObjectFromDetection(const CameraModel& camera, const Pose2& pose,
                                const BoundingSlice& slice, const ClassPrior& prior,
                                CylinderGeometry* object);

// Least-squares refinement of one object's geometry from its detections
// (each with its pose in `poses`, indexed by frame) and its class priors,
// the poses held fixed; `object` holds the start and receives the result.
// False (object unchanged) when no step lowered the cost.
bool RefineObjectFromDetections(const CameraModel& camera, const std::vector<Pose2>& poses,
                                const std::vector<const SliceObservation*>& detections,
                                const ClassPrior& prior, double pixel_std_px,
                                CylinderGeometry* object);

// The Laplace log-evidence (docs/method.md §8.2) of one object's detections and class
// priors with the poses held at `poses`: the object's 5 parameters are solved
// by Levenberg-Marquardt from `object` (which receives the result), then
//   -1/2 ||r||^2 - 1/2 log|noise| - 1/2 log det(J'J) + 1/2 (5 - m) log 2 pi.
// Summed over the objects a proposal changes, it approximates the change of
// the whole problem's evidence without solving it (the poses' share is
// missing). `detections_squared_residual` (may be null) receives the
// detections' share of ||r||^2 (r^2(j) of eq. 5.2). False when a detection
// cannot be predicted or J'J is singular.
bool ObjectLogEvidenceWithPosesHeld(const CameraModel& camera, const std::vector<Pose2>& poses,
                                    const std::vector<const SliceObservation*>& detections,
                                    const ClassPrior& prior, double pixel_std_px,
                                    CylinderGeometry* object, double* log_evidence,
                                    double* detections_squared_residual = nullptr);

class GeometricSlam {
 public:
  // The camera must outlive this object.
  GeometricSlam(const CameraModel& camera, const GeometricSlamOptions& options);

  // Throws oslam::Error for invalid input (options, unknown classes, frames
  // out of range); numerical trouble is reported in the summary.
  GeometricSlamResult Solve(const GeometricSlamProblem& problem,
                            const GeometricSlamResult* warm_start = nullptr);

  SparseSolver& solver() { return solver_; }

 private:
  // Linearisation slots (SolverOptions::reuse_linearizations): odometry
  // factor i gets 2 (i - 1), detection d seen as an object of class c gets
  // 2 (d C + c) + 1 (C classes): the class's silhouette makes it another
  // function of the same variables, so a class switch must not reuse the
  // other class's linearisation (it did, and a proposal's value then
  // depended on which class the slot last saw). A slot must keep its
  // measurement across solves, so the measurements seen are recorded, and
  // the kept linearisations are dropped when a problem changes one. False
  // (no slots for this problem) when it gives one id to two measurements.
  int OdometrySlot(long frame) const { return static_cast<int>(2 * (frame - 1)); }
  int DetectionSlot(int detection_id, int class_index, int num_classes) const {
    return 2 * (detection_id * num_classes + class_index) + 1;
  }
  bool CheckSlotMeasurements(const GeometricSlamProblem& problem);
  // A new object's initial geometry from its (frame-ordered) detections,
  // seen from `poses` (indexed by frame).
  CylinderGeometry InitialObject(const std::vector<Pose2>& poses,
                                 const std::vector<const SliceObservation*>& list,
                                 const ClassPrior& prior) const;
  // The initial trajectory and objects of a long run (keyframe_start.cpp):
  // every spacing-th pose with its composed odometry and its detections,
  // solved as the run grows, then every pose placed from its keyframe by
  // odometry. Objects never in a stage are left out (Solve places them).
  GeometricSlamResult KeyframeStart(
      const GeometricSlamProblem& problem,
      const std::map<int, std::vector<const SliceObservation*>>& by_object) const;

  const CameraModel& camera_;
  GeometricSlamOptions options_;
  SparseSolver solver_;
  std::vector<OdometryIncrement> slotted_increments_;
  struct SlottedDetection {
    long frame = -1;  // -1: no detection with this id yet
    BoundingSlice slice;
    long check = 0;  // the CheckSlotMeasurements call that last saw it
  };
  std::vector<SlottedDetection> slotted_detections_;
  long slot_check_ = 0;
};

// Odometry composed from `first` (the initial trajectory, docs/method.md §5.4).
std::vector<Pose2> ComposeOdometry(const Pose2& first,
                                   const std::vector<OdometryIncrement>& increments);

}  // namespace oslam

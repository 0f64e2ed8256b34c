#include "slam/geometric_slam.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <Eigen/Cholesky>

#include "core/angles.h"
#include "core/error.h"
#include "slam/factors.h"

namespace oslam {

bool KeyframeStartOptions::Validate(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why) *why = message;
    return false;
  };
  if (min_poses < 0) return fail("min_poses must be >= 0");
  if (spacing < 1 || stage < 1 || window < stage)
    return fail("need spacing >= 1, stage >= 1 and window >= stage");
  if (stage_iterations < 1 || resolve_iterations < 1 || final_iterations < 1)
    return fail("the iteration counts must be >= 1");
  if (!(max_reduced_chi_square > 0.0)) return fail("max_reduced_chi_square must be positive");
  if (!(stage_tolerance >= 0.0)) return fail("stage_tolerance must be >= 0");
  if (min_detections < 1) return fail("min_detections must be >= 1");
  if (!(initial_damping > 0.0) || !std::isfinite(initial_damping))
    return fail("initial_damping must be positive and finite");
  if (!(step_extrapolation >= 0.0) || !std::isfinite(step_extrapolation))
    return fail("step_extrapolation must be >= 0 and finite");
  return true;
}

SolverOptions KeyframeStartOptions::ForSolver(SolverOptions solver) const {
  solver.initial_damping = std::min(solver.initial_damping, initial_damping);
  solver.max_step_extrapolation = std::max(solver.max_step_extrapolation, step_extrapolation);
  return solver;
}

bool GeometricSlamOptions::Validate(std::string* why) const {
  if (!motion.Validate(why)) return false;
  if (!(pixel_std_px > 0.0) || !std::isfinite(pixel_std_px)) {
    if (why) *why = "pixel_std_px (E) must be positive";
    return false;
  }
  if (!keyframe_start.Validate(why)) {
    if (why) *why = "keyframe_start: " + *why;
    return false;
  }
  return solver.Validate(why);
}

std::vector<Pose2> ComposeOdometry(const Pose2& first,
                                   const std::vector<OdometryIncrement>& increments) {
  std::vector<Pose2> poses;
  poses.reserve(increments.size());
  for (size_t i = 0; i < increments.size(); ++i)
    poses.push_back(i == 0 ? first : ApplyIncrement(poses.back(), increments[i]));
  return poses;
}

bool InitialObjectFromDetection(const CameraModel& camera, const Pose2& pose,
                                const BoundingSlice& slice, const ClassPrior& prior,
                                CylinderGeometry* object) {
  Ray ray;
  const Eigen::Vector2d pixel = camera.PolarToPixel({slice.u_r_px, slice.u_phi_rad});
  if (!camera.BackProjectPixel(pixel, &ray)) return false;
  const double bearing = std::atan2(ray.direction_robot.y(), ray.direction_robot.x());
  const Eigen::Vector3d direction(std::cos(bearing), std::sin(bearing), 0.0);
  // A panel starts face-on to this view.
  const double yaw = WrapAngle(pose.theta + bearing + 0.5 * kPi);

  // 1-D search on the range (docs/method.md §5.4): the size prior alone gives a range
  // from s_phi; u_r (at the prior height of the base) and s_r add to it. The
  // weights are the measurement noise plus the prior's relative spread, in
  // units that need no camera-specific tuning.
  const double d = std::max(prior.size_mean_m.x(), 1e-3), h = std::max(prior.size_mean_m.y(), 1e-3);
  const double rel_d = prior.size_std_m.x() / d, rel_h = prior.size_std_m.y() / h;
  const double sigma_ur = 30.0;  // px; only the ratio between terms matters here
  auto cost_at = [&](double range, double* cost) {
    CylinderGeometry candidate;
    candidate.base_world =
        pose.RobotToWorld(direction * range + Eigen::Vector3d(0, 0, prior.location_mean_m.z()));
    candidate.diameter_m = d;
    candidate.height_m = h;
    candidate.yaw_rad = yaw;
    BoundingSlice predicted;
    if (!PredictSlice(camera, pose, candidate, &predicted, nullptr, prior.slice_model.silhouette))
      return false;
    const double sigma_sr = std::sqrt(2.0) * sigma_ur + std::abs(slice.s_r_px) * rel_h;
    const double sigma_sphi =
        std::sqrt(2.0) * sigma_ur / slice.u_r_px + std::abs(slice.s_phi_rad) * rel_d;
    *cost = std::pow((predicted.u_r_px - slice.u_r_px) / sigma_ur, 2) +
            std::pow((predicted.s_r_px - slice.s_r_px) / sigma_sr, 2) +
            std::pow((predicted.s_phi_rad - slice.s_phi_rad) / sigma_sphi, 2);
    return std::isfinite(*cost);
  };
  double best_range = -1.0, best_cost = 0.0;
  constexpr int kSteps = 120;
  const double min_range = 0.1, max_range = 100.0;
  for (int s = 0; s <= kSteps; ++s) {
    const double range = min_range * std::pow(max_range / min_range, double(s) / kSteps);
    double cost;
    if (cost_at(range, &cost) && (best_range < 0 || cost < best_cost)) {
      best_range = range;
      best_cost = cost;
    }
  }
  if (best_range < 0) {
    // No range gives an image at the prior height: fall back to the size prior.
    if (!(slice.s_phi_rad > 1e-6)) return false;
    best_range = std::clamp(d / (2.0 * std::tan(0.5 * slice.s_phi_rad)), min_range, max_range);
  }
  object->base_world =
      pose.RobotToWorld(direction * best_range + Eigen::Vector3d(0, 0, prior.location_mean_m.z()));
  object->diameter_m = d;
  object->height_m = h;
  object->yaw_rad = yaw;
  return true;
}

namespace {

// Levenberg-Marquardt on one object's parameters (base, diameter, height, and
// a panel's yaw: 5 or 6) over its detections and class priors, the poses
// held. `object` holds the start and receives the result when a step
// lowered the cost.
struct ObjectFit {
  bool improved = false;
  bool information_valid = false;  // `information` is J'J at the result
  double cost = 0;                 // 1/2 sum of squared whitened errors at the result
  double prior_squared = 0;        // the class priors' share of 2 cost
  int num_parameters = 5;          // 6 for a panel
  // J'J at the result, the leading num_parameters block (else unit).
  Eigen::Matrix<double, 6, 6> information;
  double log_det_noise = 0;  // sum of log|covariance| of the factors
  int num_rows = 0;
};

bool IsPanel(const ClassPrior& prior) {
  return prior.slice_model.silhouette.enabled && prior.slice_model.silhouette.panel;
}

bool FitObjectWithPosesHeld(const CameraModel& camera, const std::vector<Pose2>& poses,
                            const std::vector<const SliceObservation*>& detections,
                            const ClassPrior& prior, double pixel_std_px, int max_iterations,
                            CylinderGeometry* object, ObjectFit* fit) {
  // theta = (base, diameter, height, yaw); the yaw is held unless a panel's.
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  const bool panel = IsPanel(prior);
  const Eigen::Vector3d location_weight = prior.location_std_m.cwiseInverse();
  const Eigen::Vector2d size_weight = prior.size_std_m.cwiseInverse();
  // Whitened errors of the priors: location (3), size (2), a panel's yaw.
  auto prior_error = [&](const Vector6d& theta) {
    Vector6d error;
    error << location_weight.cwiseProduct(theta.head<3>() - prior.location_mean_m),
        size_weight.cwiseProduct(theta.segment<2>(3) - prior.size_mean_m),
        panel ? PanelYawPrior::Error(theta[5]) : 0.0;
    return error;
  };
  std::vector<SliceCensoring> censoring(detections.size());
  if (prior.slice_model.censor_at_image_limits)
    for (size_t k = 0; k < detections.size(); ++k)
      censoring[k] = CensoringOf(camera, detections[k]->slice, prior.slice_model.censor_margin_px);
  // Cost, gradient and Gauss-Newton matrix of the object's own factors.
  auto evaluate = [&](const Vector6d& theta, double* cost, Vector6d* gradient, Matrix6d* hessian) {
    CylinderGeometry candidate;
    candidate.base_world = theta.head<3>();
    candidate.diameter_m = theta[3];
    candidate.height_m = theta[4];
    candidate.yaw_rad = theta[5];
    double sum = 0.0;
    if (gradient) gradient->setZero(), hessian->setZero();
    SliceJacobians jacobians;
    for (size_t k = 0; k < detections.size(); ++k) {
      const BoundingSlice& z = detections[k]->slice;
      BoundingSlice predicted;
      bool beyond = false;
      if (!PredictSlice(camera, poses[detections[k]->frame], candidate, &predicted,
                        gradient ? &jacobians : nullptr, prior.slice_model.silhouette,
                        censoring[k].outer ? &beyond : nullptr))
        return false;
      const Eigen::Vector4d inverse_sigma =
          BoundingSliceFactor::NoiseSigma(z, pixel_std_px, prior.slice_model.bearing_noise_px)
              .cwiseInverse();
      const Eigen::Vector4d error =
          inverse_sigma.cwiseProduct(BoundingSliceFactor::CensoredResidual(
              predicted, z, censoring[k], gradient ? &jacobians : nullptr));
      sum += error.squaredNorm();
      if (gradient) {
        Eigen::Matrix<double, 4, 6> j;
        j << jacobians.wrt_base, jacobians.wrt_size, jacobians.wrt_yaw;
        j = inverse_sigma.asDiagonal() * j;
        *gradient += j.transpose() * error;
        *hessian += j.transpose() * j;
      }
    }
    const Vector6d priors = prior_error(theta);
    sum += priors.squaredNorm();
    if (gradient) {
      gradient->head<3>() += location_weight.cwiseProduct(priors.head<3>());
      gradient->segment<2>(3) += size_weight.cwiseProduct(priors.segment<2>(3));
      hessian->diagonal().head<3>() += location_weight.cwiseAbs2();
      hessian->diagonal().segment<2>(3) += size_weight.cwiseAbs2();
      // A held yaw: a unit diagonal and no gradient, so it never moves.
      (*gradient)[5] += panel ? priors[5] / kPanelYawPriorStd : 0.0;
      (*hessian)(5, 5) += panel ? 1.0 / (kPanelYawPriorStd * kPanelYawPriorStd) : 1.0;
    }
    *cost = 0.5 * sum;
    return std::isfinite(*cost);
  };
  Vector6d theta;
  theta << object->base_world, object->diameter_m, object->height_m, object->yaw_rad;
  double cost;
  Vector6d gradient;
  Matrix6d hessian;
  if (!evaluate(theta, &cost, &gradient, &hessian)) return false;
  fit->information_valid = true;
  double lambda = 1e-3;
  bool improved = false;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    Matrix6d damped = hessian;
    damped.diagonal() *= 1.0 + lambda;
    const Vector6d step = damped.ldlt().solve(-gradient);
    if (!step.allFinite()) break;
    const Vector6d candidate = theta + step;
    // Evaluated with its derivatives at once: most steps are taken, and a
    // second pass over the detections for them cost a third of the fit.
    double new_cost;
    Vector6d new_gradient;
    Matrix6d new_hessian;
    if (candidate[3] > 0 && candidate[4] > 0 &&
        evaluate(candidate, &new_cost, &new_gradient, &new_hessian) && new_cost < cost) {
      const bool small = step.lpNorm<Eigen::Infinity>() < 1e-3 || cost - new_cost < 1e-6 * cost;
      theta = candidate;
      cost = new_cost;
      gradient = new_gradient;
      hessian = new_hessian;
      improved = true;
      lambda = std::max(lambda / 10.0, 1e-9);
      if (small) break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e8) break;
    }
  }
  if (improved) {
    object->base_world = theta.head<3>();
    object->diameter_m = theta[3];
    object->height_m = theta[4];
    object->yaw_rad = WrapAngle(theta[5]);
  }
  fit->improved = improved;
  fit->cost = cost;
  fit->prior_squared = prior_error(theta).squaredNorm();
  fit->information = hessian;
  fit->num_parameters = panel ? 6 : 5;
  fit->num_rows = 4 * static_cast<int>(detections.size()) + fit->num_parameters;
  fit->log_det_noise =
      2.0 * (prior.location_std_m.array().log().sum() + prior.size_std_m.array().log().sum()) +
      (panel ? PanelYawPrior::kLogDet : 0.0);
  for (const SliceObservation* detection : detections)
    fit->log_det_noise += 2.0 * BoundingSliceFactor::NoiseSigma(detection->slice, pixel_std_px,
                                                                prior.slice_model.bearing_noise_px)
                                    .array()
                                    .log()
                                    .sum();
  return true;
}

}  // namespace

bool RefineObjectFromDetections(const CameraModel& camera, const std::vector<Pose2>& poses,
                                const std::vector<const SliceObservation*>& detections,
                                const ClassPrior& prior, double pixel_std_px,
                                CylinderGeometry* object) {
  if (!IsPanel(prior)) {
    ObjectFit fit;
    return FitObjectWithPosesHeld(camera, poses, detections, prior, pixel_std_px, 20, object,
                                  &fit) &&
           fit.improved;
  }
  // A panel's views determine its yaw only up to mirror images about the
  // lines of sight (|cos|, |sin|): start from yaws spread over its period pi
  // and keep the best fit.
  constexpr int kYawStarts = 6;
  bool found = false;
  double best_cost = 0.0;
  CylinderGeometry best;
  for (int start = 0; start < kYawStarts; ++start) {
    CylinderGeometry candidate = *object;
    candidate.yaw_rad = WrapAngle(object->yaw_rad + start * kPi / kYawStarts);
    ObjectFit fit;
    if (!FitObjectWithPosesHeld(camera, poses, detections, prior, pixel_std_px, 20, &candidate,
                                &fit))
      continue;
    if (!found || fit.cost < best_cost) {
      found = true;
      best_cost = fit.cost;
      best = candidate;
    }
  }
  if (found) *object = best;
  return found;
}

bool ObjectLogEvidenceWithPosesHeld(const CameraModel& camera, const std::vector<Pose2>& poses,
                                    const std::vector<const SliceObservation*>& detections,
                                    const ClassPrior& prior, double pixel_std_px,
                                    CylinderGeometry* object, double* log_evidence,
                                    double* detections_squared_residual) {
  constexpr double kLog2Pi = 1.8378770664093454836;
  ObjectFit fit;
  if (!FitObjectWithPosesHeld(camera, poses, detections, prior, pixel_std_px, 20, object, &fit) ||
      !fit.information_valid)
    return false;
  const int n = fit.num_parameters;
  const Eigen::LLT<Eigen::MatrixXd> cholesky(fit.information.topLeftCorner(n, n));
  if (cholesky.info() != Eigen::Success) return false;
  const double log_det_information = 2.0 * cholesky.matrixLLT().diagonal().array().log().sum();
  *log_evidence = -fit.cost - 0.5 * fit.log_det_noise - 0.5 * log_det_information +
                  0.5 * (n - fit.num_rows) * kLog2Pi;
  if (detections_squared_residual)
    *detections_squared_residual = std::max(0.0, 2.0 * fit.cost - fit.prior_squared);
  return std::isfinite(*log_evidence);
}

GeometricSlam::GeometricSlam(const CameraModel& camera, const GeometricSlamOptions& options)
    : camera_(camera), options_(options), solver_(options.solver) {}

bool GeometricSlam::CheckSlotMeasurements(const GeometricSlamProblem& problem) {
  static_assert(sizeof(OdometryIncrement) == 2 * sizeof(double), "compared bitwise");
  static_assert(sizeof(BoundingSlice) == 4 * sizeof(double), "compared bitwise");
  auto same_bits = [](const auto& a, const auto& b) { return std::memcmp(&a, &b, sizeof(a)) == 0; };
  auto same = [&](const SlottedDetection& seen, const SliceObservation& observation) {
    return seen.frame == observation.frame && same_bits(seen.slice, observation.slice);
  };
  bool changed = slotted_increments_.size() != problem.increments.size();
  for (size_t i = 0; !changed && i < problem.increments.size(); ++i)
    changed = !same_bits(slotted_increments_[i], problem.increments[i]);
  for (const SliceObservation& observation : problem.observations) {
    if (changed) break;
    const int id = observation.detection_id;
    if (id >= 0 && id < static_cast<int>(slotted_detections_.size()) &&
        slotted_detections_[id].frame >= 0)
      changed = !same(slotted_detections_[id], observation);
  }
  if (changed) {
    solver_.ClearLinearizations();
    slotted_increments_ = problem.increments;
    slotted_detections_.clear();
  }
  ++slot_check_;
  for (const SliceObservation& observation : problem.observations) {
    const int id = observation.detection_id;
    if (id < 0) continue;
    if (id >= static_cast<int>(slotted_detections_.size())) slotted_detections_.resize(id + 1);
    SlottedDetection& seen = slotted_detections_[id];
    if (seen.check == slot_check_ && !same(seen, observation)) {
      // One id for two measurements in this problem: no reuse.
      solver_.ClearLinearizations();
      slotted_detections_.clear();
      return false;
    }
    seen = {observation.frame, observation.slice, slot_check_};
  }
  return true;
}

// A new object's start (docs/method.md §5.4 leaves it open): candidates start at the
// first detection, then at detections spread over the object's track; the
// first one from which every detection of the object can be predicted wins
// (else the one with the fewest failures), so the solve never starts where a
// factor cannot be evaluated (e.g. the robot inside the cylinder).
CylinderGeometry GeometricSlam::InitialObject(const std::vector<Pose2>& poses,
                                              const std::vector<const SliceObservation*>& list,
                                              const ClassPrior& prior) const {
  CylinderGeometry initial;
  auto unpredictable = [&](const CylinderGeometry& candidate) {
    int failures = 0;
    BoundingSlice predicted;
    for (const SliceObservation* observation : list) {
      const SliceModel& model = prior.slice_model;
      bool beyond = false;
      const bool censored = model.censor_at_image_limits &&
                            CensoringOf(camera_, observation->slice, model.censor_margin_px).outer;
      if (!PredictSlice(camera_, poses[observation->frame], candidate, &predicted, nullptr,
                        model.silhouette, censored ? &beyond : nullptr))
        ++failures;
    }
    return failures;
  };
  int best_failures = -1;
  constexpr int kStarts = 5;
  for (int attempt = 0; attempt < kStarts && best_failures != 0; ++attempt) {
    const size_t start = attempt * list.size() / kStarts;
    if (attempt > 0 && start == (attempt - 1) * list.size() / kStarts) continue;
    const SliceObservation& first = *list[start];
    CylinderGeometry candidate;
    if (!InitialObjectFromDetection(camera_, poses[first.frame], first.slice, prior, &candidate)) {
      // A slice with no ray: start at the prior, the solver will report.
      candidate.base_world = prior.location_mean_m;
      candidate.diameter_m = prior.size_mean_m.x();
      candidate.height_m = prior.size_mean_m.y();
    }
    // Refine with the detections from there on, the poses held: a single
    // detection fixes the range only through s_phi and u_r, both noisy at
    // E = 30 px, and a far-off start costs the joint solve many steps.
    if (options_.initial_refinement_detections > 0) {
      const size_t count = std::min(list.size() - start,
                                    static_cast<size_t>(options_.initial_refinement_detections));
      const std::vector<const SliceObservation*> detections(list.begin() + start,
                                                            list.begin() + start + count);
      RefineObjectFromDetections(camera_, poses, detections, prior, options_.pixel_std_px,
                                 &candidate);
    }
    const int failures = unpredictable(candidate);
    if (best_failures < 0 || failures < best_failures) {
      best_failures = failures;
      initial = candidate;
    }
  }
  return initial;
}

GeometricSlamResult GeometricSlam::Solve(const GeometricSlamProblem& problem,
                                         const GeometricSlamResult* warm_start) {
  std::string why;
  if (!options_.Validate(&why)) throw Error("geometric SLAM options: " + why);
  const long num_poses = static_cast<long>(problem.increments.size());
  if (num_poses < 1) throw Error("geometric SLAM: no poses (odometry is empty)");
  for (const auto& [id, class_index] : problem.object_class)
    if (class_index < 0 || class_index >= static_cast<int>(problem.classes.size()))
      throw Error("geometric SLAM: object " + std::to_string(id) + " has an unknown class");

  // Observations per object, in frame order (the first one initialises it).
  std::map<int, std::vector<const SliceObservation*>> by_object;
  for (const auto& observation : problem.observations) {
    if (observation.frame < 0 || observation.frame >= num_poses)
      throw Error("geometric SLAM: detection in frame " + std::to_string(observation.frame) +
                  " outside the " + std::to_string(num_poses) + " odometry frames");
    if (!problem.object_class.count(observation.object_id))
      throw Error("geometric SLAM: object " + std::to_string(observation.object_id) +
                  " has no class");
    by_object[observation.object_id].push_back(&observation);
  }
  for (auto& [id, list] : by_object)
    std::stable_sort(list.begin(), list.end(),
                     [](const auto* a, const auto* b) { return a->frame < b->frame; });

  GeometricSlamResult keyframe_start;
  SolverOptions solver_options = options_.solver;
  const KeyframeStartOptions& keyframe_options = options_.keyframe_start;
  if (!warm_start && keyframe_options.min_poses > 0 && num_poses > keyframe_options.min_poses) {
    keyframe_start = KeyframeStart(problem, by_object);
    warm_start = &keyframe_start;
    solver_options = keyframe_options.ForSolver(solver_options);
  }

  // ---- variables and initial values ----
  FactorGraph graph;
  const int num_objects = static_cast<int>(by_object.size());
  graph.Reserve(static_cast<int>(num_poses) + 2 * num_objects, 3 * num_poses + 5 * num_objects,
                static_cast<int>(num_poses - 1 + problem.observations.size()) + 2 * num_objects);
  std::vector<Pose2> initial_poses =
      (warm_start && warm_start->trajectory.size() == problem.increments.size())
          ? warm_start->trajectory
          : ComposeOdometry(problem.first_pose, problem.increments);
  initial_poses[0] = problem.first_pose;
  std::vector<int> pose_keys(num_poses);
  for (long i = 0; i < num_poses; ++i)
    pose_keys[i] = graph.AddPose(initial_poses[i].x, initial_poses[i].y, initial_poses[i].theta,
                                 /*fixed=*/i == 0);  // gauge: x_1 excluded (docs/method.md §14)

  std::map<int, const MappedObject*> previous;
  if (warm_start)
    for (const auto& object : warm_start->objects) previous[object.id] = &object;
  struct ObjectKeys {
    int id, class_index, base, size, yaw, count;  // yaw: a panel's, else -1
    size_t first_factor = 0, end_factor = 0;      // its detections' factors
  };
  std::vector<ObjectKeys> objects;
  for (const auto& [id, list] : by_object) {
    const int class_index = problem.object_class.at(id);
    const ClassPrior& prior = problem.classes[class_index];
    CylinderGeometry initial;
    const auto found = previous.find(id);
    if (found != previous.end() && found->second->class_index == class_index) {
      initial = found->second->geometry;
    } else {
      initial = InitialObject(initial_poses, list, prior);
    }
    const int base = graph.AddVariable(initial.base_world);
    const int size = graph.AddVariable(Eigen::Vector2d(initial.diameter_m, initial.height_m));
    const int yaw =
        IsPanel(prior) ? graph.AddVariable(Eigen::Matrix<double, 1, 1>(initial.yaw_rad), 0) : -1;
    objects.push_back({id, class_index, base, size, yaw, static_cast<int>(list.size())});
  }

  // ---- factors ----
  const bool slots = options_.solver.reuse_linearizations && CheckSlotMeasurements(problem);
  for (long i = 1; i < num_poses; ++i) {
    Factor* odometry = graph.Emplace<OdometryFactor>(pose_keys[i - 1], pose_keys[i],
                                                     problem.increments[i], options_.motion);
    if (slots) odometry->set_linearization_slot(OdometrySlot(i));
  }
  // Detections first and the priors last: the factors of two similar
  // problems (an O-SLAM proposal and its parent) then have the same sizes at
  // the same positions, so the solver's per-factor buffers are not
  // reallocated.
  for (auto& object : objects) {
    object.first_factor = graph.factors().size();
    for (const SliceObservation* observation : by_object[object.id]) {
      Factor* slice = graph.Emplace<BoundingSliceFactor>(
          &camera_, pose_keys[observation->frame], object.base, object.size, observation->slice,
          options_.pixel_std_px, problem.classes[object.class_index].slice_model, object.yaw);
      if (slots && observation->detection_id >= 0)
        slice->set_linearization_slot(DetectionSlot(observation->detection_id, object.class_index,
                                                    static_cast<int>(problem.classes.size())));
    }
    object.end_factor = graph.factors().size();
  }
  for (const auto& object : objects) {
    const ClassPrior& prior = problem.classes[object.class_index];
    graph.Add(MakeLocationPrior(object.base, prior.location_mean_m, prior.location_std_m));
    graph.Add(MakeSizePrior(object.size, prior.size_mean_m, prior.size_std_m));
    if (object.yaw >= 0) graph.Emplace<PanelYawPrior>(object.yaw);
  }

  // ---- solve and read out ----
  solver_.set_options(solver_options);
  const SolveResult solved = solver_.Solve(&graph);
  GeometricSlamResult result;
  result.keyframe_start = keyframe_start.keyframe_start;
  result.summary = solved.summary;
  result.evidence = solved.evidence;
  const Values& values = graph.values();
  result.trajectory.reserve(num_poses);
  for (int key : pose_keys) {
    const double* p = values.Data(key);
    result.trajectory.push_back({p[0], p[1], p[2]});
  }
  for (const auto& object : objects) {
    MappedObject mapped;
    mapped.id = object.id;
    mapped.class_index = object.class_index;
    mapped.geometry.base_world = values.Get(object.base);
    mapped.geometry.diameter_m = values.Data(object.size)[0];
    mapped.geometry.height_m = values.Data(object.size)[1];
    if (object.yaw >= 0) mapped.geometry.yaw_rad = values.Data(object.yaw)[0];
    mapped.oriented = object.yaw >= 0;
    mapped.num_observations = object.count;
    if (!solved.squared_errors.empty())
      for (size_t f = object.first_factor; f < object.end_factor; ++f)
        mapped.squared_residual += solved.squared_errors[f];
    result.objects.push_back(mapped);
  }
  if (!result.summary.IsUsable()) return result;

  if (options_.compute_object_covariances && !objects.empty()) {
    std::vector<std::vector<int>> groups;
    for (const auto& object : objects) groups.push_back({object.base, object.size});
    std::vector<Eigen::MatrixXd> blocks;
    if (solver_.MarginalCovariances(groups, &blocks, &result.covariance_message)) {
      for (size_t j = 0; j < objects.size(); ++j) result.objects[j].covariance = blocks[j];
      result.has_object_covariances = true;
    }
  }
  if (options_.compute_pose_covariances) {
    std::vector<std::vector<int>> groups;
    for (long i = 1; i < num_poses; ++i) groups.push_back({pose_keys[i]});
    std::vector<Eigen::MatrixXd> blocks;
    result.pose_covariances.assign(num_poses, Eigen::Matrix3d::Zero());
    if (groups.empty() || solver_.MarginalCovariances(groups, &blocks, &result.covariance_message))
      for (size_t i = 0; i < blocks.size(); ++i) result.pose_covariances[i + 1] = blocks[i];
  }
  return result;
}

}  // namespace oslam

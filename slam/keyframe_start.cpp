// GeometricSlam::KeyframeStart: the initial estimate of a long run (docs/method.md
// §5.4 leaves the initialisation open). A batch solve from raw odometry
// cannot undo laps of drift: the first re-observation of an object puts it
// tens of metres from where its first detections placed it, and
// Levenberg-Marquardt then wanders (10,000 poses, 10 laps: not converged
// after 50 iterations). Here the run is solved as it grows, so each
// re-observation corrects the drift of one short stage only:
// - a problem ten times smaller: every `spacing`-th pose, linked by
//   its composed odometry with the propagated covariance, and only the
//   keyframes' detections;
// - each stage adds a few keyframes by odometry and solves the recent ones
//   with the objects they see, earlier keyframes held (a fixed-lag smoother,
//   so a stage costs the same at the end of the run as at its start);
// - a stage whose fit stays poor (a loop closed after a long drift) is
//   solved again with all keyframes free;
// - a last solve with every keyframe free gives the later laps their say in
//   the map's shape.
// On the 10,000-pose benchmark scene (seeds 1-5) the solve from this start
// ends at a cost no higher than the solve started at the truth.
#include <algorithm>
#include <chrono>
#include <functional>
#include <map>

#include "slam/factors.h"
#include "slam/geometric_slam.h"
#include "slam/keyframe_start.h"
#include "slam/landmark_factors.h"
#include "solver/factor_graph.h"

namespace oslam {
namespace {

// The run reduced to keyframes.
struct KeyframeProblem {
  std::vector<long> frames;                                       // keyframe -> frame
  std::vector<KeyframeLink> links;                                // links[j]: keyframe j-1 -> j
  std::vector<SliceObservation> detections;                       // frame = keyframe index
  std::map<int, std::vector<const SliceObservation*>> by_object;  // in keyframe order
};

// Keyframes every `spacing` frames and at the last frame.
void BuildKeyframes(const GeometricSlamProblem& problem,
                    const std::map<int, std::vector<const SliceObservation*>>& by_object,
                    long spacing, const MotionNoiseOptions& motion, KeyframeProblem* keyframes) {
  const long num_poses = static_cast<long>(problem.increments.size());
  std::vector<long>& frames = keyframes->frames;
  for (long frame = 0; frame < num_poses; frame += spacing) frames.push_back(frame);
  if (frames.back() != num_poses - 1) frames.push_back(num_poses - 1);
  keyframes->links.resize(frames.size());
  for (size_t j = 1; j < frames.size(); ++j)
    keyframes->links[j] =
        ComposeOdometrySteps(problem.increments, frames[j - 1], frames[j], motion);
  for (const auto& [id, list] : by_object)
    for (const SliceObservation* observation : list) {
      const auto keyframe = std::lower_bound(frames.begin(), frames.end(), observation->frame);
      if (*keyframe != observation->frame) continue;
      SliceObservation copy = *observation;
      copy.frame = static_cast<long>(keyframe - frames.begin());
      copy.detection_id = -1;
      keyframes->detections.push_back(copy);
    }
  for (const SliceObservation& observation : keyframes->detections)
    keyframes->by_object[observation.object_id].push_back(&observation);
}

struct StageFit {
  bool usable = false;
  // ||e||^2 / (rows - free parameters): ~1 where the model fits.
  double reduced_chi_square = 0.0;
  int iterations = 0;
};

using InitialObjectFunction = std::function<CylinderGeometry(
    const std::vector<Pose2>&, const std::vector<const SliceObservation*>&, const ClassPrior&)>;

struct StageContext {
  const GeometricSlamProblem& problem;
  const KeyframeProblem& keyframes;
  const CameraModel& camera;
  double pixel_std_px;
  int min_detections;
  InitialObjectFunction initial_object;
};

// One stage: keyframes [first_free, end) free, the objects they see (once
// seen from min_detections keyframes) with all their detections so far,
// every other keyframe held. Updates `poses` and `objects` when usable.
StageFit SolveStage(const StageContext& context, int first_free, int end, SparseSolver* solver,
                    std::vector<Pose2>* poses, std::map<int, CylinderGeometry>* objects) {
  FactorGraph graph;
  std::map<int, int> pose_keys;
  auto key_of = [&](int j) {
    const auto found = pose_keys.find(j);
    if (found != pose_keys.end()) return found->second;
    const Pose2& pose = (*poses)[j];
    return pose_keys[j] = graph.AddPose(pose.x, pose.y, pose.theta, /*fixed=*/j < first_free);
  };
  for (int j = first_free; j < end; ++j)
    graph.Emplace<RelativePoseFactor>(key_of(j - 1), key_of(j), context.keyframes.links[j].relative,
                                      context.keyframes.links[j].covariance);
  struct StageObject {
    int id, base, size, yaw;  // yaw: a panel's, else -1
  };
  std::vector<StageObject> stage_objects;
  for (const auto& [id, list] : context.keyframes.by_object) {
    const auto seen_end =
        std::find_if(list.begin(), list.end(), [&](const auto* o) { return o->frame >= end; });
    const bool in_stage =
        std::any_of(list.begin(), seen_end, [&](const auto* o) { return o->frame >= first_free; });
    // From fewer keyframes the range rests on the size prior alone, and a
    // stage's steps throw the object far along its viewing ray.
    if (!in_stage || seen_end - list.begin() < context.min_detections) continue;
    const std::vector<const SliceObservation*> seen(list.begin(), seen_end);
    const ClassPrior& prior = context.problem.classes[context.problem.object_class.at(id)];
    if (!objects->count(id)) (*objects)[id] = context.initial_object(*poses, seen, prior);
    const CylinderGeometry& geometry = objects->at(id);
    const int base = graph.AddVariable(geometry.base_world);
    const int size = graph.AddVariable(Eigen::Vector2d(geometry.diameter_m, geometry.height_m));
    const bool panel = prior.slice_model.silhouette.enabled && prior.slice_model.silhouette.panel;
    const int yaw =
        panel ? graph.AddVariable(Eigen::Matrix<double, 1, 1>(geometry.yaw_rad), 0) : -1;
    stage_objects.push_back({id, base, size, yaw});
    for (const SliceObservation* observation : seen)
      graph.Emplace<BoundingSliceFactor>(&context.camera, key_of(observation->frame), base, size,
                                         observation->slice, context.pixel_std_px,
                                         prior.slice_model, yaw);
    graph.Add(MakeLocationPrior(base, prior.location_mean_m, prior.location_std_m));
    graph.Add(MakeSizePrior(size, prior.size_mean_m, prior.size_std_m));
    if (panel) graph.Emplace<PanelYawPrior>(yaw);
  }

  const SolveResult solved = solver->Solve(&graph);
  StageFit fit;
  fit.usable = solved.summary.IsUsable();
  fit.iterations = solved.summary.iterations;
  if (!fit.usable) return fit;
  fit.reduced_chi_square =
      2.0 * solved.summary.final_cost /
      std::max(1, solved.summary.num_residuals - solved.summary.num_parameters);
  for (int j = first_free; j < end; ++j) {
    const double* p = graph.values().Data(pose_keys.at(j));
    (*poses)[j] = {p[0], p[1], p[2]};
  }
  for (const StageObject& object : stage_objects) {
    CylinderGeometry& geometry = (*objects)[object.id];
    geometry.base_world = graph.values().Get(object.base);
    geometry.diameter_m = graph.values().Data(object.size)[0];
    geometry.height_m = graph.values().Data(object.size)[1];
    if (object.yaw >= 0) geometry.yaw_rad = graph.values().Data(object.yaw)[0];
  }
  return fit;
}

}  // namespace

KeyframeLink ComposeOdometrySteps(const std::vector<OdometryIncrement>& increments, long first,
                                  long last, const MotionNoiseOptions& motion) {
  KeyframeLink link;
  for (long i = first + 1; i <= last; ++i) {
    Eigen::Matrix3d jacobian;
    const Pose2 next = ApplyIncrement(link.relative, increments[i], &jacobian);
    link.covariance = jacobian * link.covariance * jacobian.transpose() +
                      MotionCovariance(link.relative.theta, increments[i], motion);
    link.relative = next;
  }
  return link;
}

GeometricSlamResult GeometricSlam::KeyframeStart(
    const GeometricSlamProblem& problem,
    const std::map<int, std::vector<const SliceObservation*>>& by_object) const {
  const auto t_start = std::chrono::steady_clock::now();
  const KeyframeStartOptions& options = options_.keyframe_start;
  const long num_poses = static_cast<long>(problem.increments.size());
  KeyframeProblem keyframes;
  BuildKeyframes(problem, by_object, options.spacing, options_.motion, &keyframes);
  const int num_keyframes = static_cast<int>(keyframes.frames.size());

  SolverOptions stage_options = options.ForSolver(options_.solver);
  stage_options.compute_evidence = false;
  stage_options.reuse_linearizations = false;
  stage_options.absolute_function_tolerance =
      std::max(stage_options.absolute_function_tolerance, options.stage_tolerance);
  SolverOptions resolve_options = stage_options;
  resolve_options.max_iterations = options.resolve_iterations;
  stage_options.max_iterations = options.stage_iterations;
  SparseSolver solver(stage_options);

  const StageContext context{
      problem,
      keyframes,
      camera_,
      options_.pixel_std_px,
      options.min_detections,
      [this](const std::vector<Pose2>& poses, const std::vector<const SliceObservation*>& list,
             const ClassPrior& prior) { return InitialObject(poses, list, prior); }};
  GeometricSlamResult start;
  KeyframeStartSummary& summary = start.keyframe_start;
  summary.used = true;
  summary.num_keyframes = num_keyframes;
  std::vector<Pose2> poses(num_keyframes);  // keyframe estimates
  poses[0] = problem.first_pose;
  std::map<int, CylinderGeometry> objects;
  double max_reduced_chi_square = options.max_reduced_chi_square;
  for (int begin = 1; begin < num_keyframes;) {
    const int end = std::min(num_keyframes, begin + options.stage);
    for (int j = begin; j < end; ++j)
      poses[j] = ComposePose(poses[j - 1], keyframes.links[j].relative);
    // A stage that cannot fit its detections with the recent keyframes free
    // (a loop closed after a long drift) is solved with all of them free, so
    // the closure spreads over the whole loop, as the odometry's covariance
    // says. Doubling the free span instead left kinks that ended the final
    // solve in worse minima (10,000 poses, seed 3: 138.4 k against 135.5 k).
    StageFit fit =
        SolveStage(context, std::max(1, end - options.window), end, &solver, &poses, &objects);
    ++summary.stage_solves;
    summary.stage_iterations += fit.iterations;
    if (end - options.window > 1 &&
        !(fit.usable && fit.reduced_chi_square <= max_reduced_chi_square)) {
      solver.set_options(resolve_options);
      fit = SolveStage(context, 1, end, &solver, &poses, &objects);
      solver.set_options(stage_options);
      ++summary.stage_solves;
      ++summary.closures;
      summary.stage_iterations += fit.iterations;
      // Where the model fits no better with everything free (real data),
      // the threshold follows, or every later stage would be solved whole.
      if (fit.usable)
        max_reduced_chi_square = std::max(max_reduced_chi_square, 1.1 * fit.reduced_chi_square);
    }
    begin = end;
  }
  // The stages held the older keyframes, so the map's shape is still the
  // first lap's: one solve with every keyframe free spreads the later laps'
  // evidence over it, on a problem a tenth of the size of the final one.
  SolverOptions final_options = stage_options;
  final_options.max_iterations = options.final_iterations;
  solver.set_options(final_options);
  summary.final_iterations =
      SolveStage(context, 1, num_keyframes, &solver, &poses, &objects).iterations;

  // Every pose from its keyframe and the dead reckoning since.
  const std::vector<Pose2> dead_reckoning = ComposeOdometry(problem.first_pose, problem.increments);
  start.trajectory.resize(num_poses);
  for (long i = 0; i < num_poses; ++i) {
    const long j = i / options.spacing;
    start.trajectory[i] =
        ComposePose(poses[j], BetweenPoses(dead_reckoning[keyframes.frames[j]], dead_reckoning[i]));
  }
  start.trajectory[0] = problem.first_pose;
  for (const auto& [id, geometry] : objects) {
    MappedObject object;
    object.id = id;
    object.class_index = problem.object_class.at(id);
    object.geometry = geometry;
    start.objects.push_back(object);
  }
  summary.time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return start;
}

}  // namespace oslam

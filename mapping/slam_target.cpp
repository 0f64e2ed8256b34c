#include "mapping/slam_target.h"

#include <chrono>
#include <cmath>
#include <map>

#include "core/angles.h"
#include "core/error.h"
#include "mapping/observation_model.h"

namespace oslam {
namespace {

GeometricSlamOptions StepOptions(const SlamTargetOptions& options) {
  GeometricSlamOptions step = options.slam;
  step.solver.max_iterations = options.proposal_iterations;
  return step;
}

const MappedObject* FindObject(const GeometricSlamResult& result, int id) {
  for (const MappedObject& object : result.objects)
    if (object.id == id) return &object;
  return nullptr;
}

}  // namespace

bool SlamTargetOptions::Validate(std::string* why) const {
  if (proposal_iterations < 1) {
    if (why) *why = "the solver iterations per proposal must be >= 1";
    return false;
  }
  if (max_cache_entries < 1) {
    if (why) *why = "the state cache needs room for at least one entry";
    return false;
  }
  return slam.Validate(why);
}

SlamEvaluator::SlamEvaluator(const SlamTargetData& data, const ClassConfusionModel& model,
                             const SlamTargetOptions& options)
    : data_(data),
      model_(model),
      options_(options),
      full_(*data.camera, options.slam),
      step_(*data.camera, StepOptions(options)) {
  std::string why;
  if (!options.Validate(&why)) throw Error("O-SLAM target options: " + why);
}

GeometricSlamProblem SlamEvaluator::BuildProblem(const AssociationState& state) const {
  GeometricSlamProblem problem;
  problem.increments = data_.increments;
  problem.first_pose = data_.first_pose;
  problem.classes = data_.classes;
  for (size_t j = 0; j < state.blocks.size(); ++j) {
    const int id = state.blocks[j].front();
    problem.object_class[id] = state.classes[j];
    for (int t : state.blocks[j])
      for (int d : data_.tracks[t].detections)
        problem.observations.push_back({data_.detections[d].frame, id, data_.detections[d].slice});
  }
  return problem;
}

// The linearisation point of a proposed state (spec §9.6): the current
// solution; a merged object keeps its earliest part's point (its id), a split
// half and a switched object keep the originating object's point.
GeometricSlamResult SlamEvaluator::WarmStart(const AssociationState& state,
                                             const StateEvaluation& from) const {
  GeometricSlamResult start;
  start.trajectory = from.solution->trajectory;
  for (size_t j = 0; j < state.blocks.size(); ++j) {
    const int id = state.blocks[j].front();
    const int old_block = from.state.BlockOf(id);
    if (old_block < 0) continue;
    const MappedObject* old = FindObject(*from.solution, from.state.blocks[old_block].front());
    if (!old) continue;
    MappedObject object = *old;
    object.id = id;
    object.class_index = state.classes[j];
    start.objects.push_back(object);
  }
  return start;
}

// r^2(j) of eq. 5.2: whitened squared measurement residuals of each object
// at the solution (R = diag(E^2, (E/u_r)^2), W = 2R, as the factor uses).
std::vector<double> SlamEvaluator::ObjectResiduals(const AssociationState& state,
                                                   const GeometricSlamResult& solution) const {
  const double e = options_.slam.pixel_std_px;
  std::vector<double> residual2(state.blocks.size(), 0.0);
  for (size_t j = 0; j < state.blocks.size(); ++j) {
    const MappedObject* object = FindObject(solution, state.blocks[j].front());
    if (!object) continue;
    for (int t : state.blocks[j])
      for (int d : data_.tracks[t].detections) {
        const ClassedSlice& z = data_.detections[d];
        BoundingSlice predicted;
        if (!PredictSlice(*data_.camera, solution.trajectory[z.frame], object->geometry,
                          &predicted))
          continue;
        const double angular = e / z.slice.u_r_px;
        residual2[j] +=
            std::pow((predicted.u_r_px - z.slice.u_r_px) / e, 2) +
            std::pow(WrapAngle(predicted.u_phi_rad - z.slice.u_phi_rad) / angular, 2) +
            std::pow(predicted.s_r_px - z.slice.s_r_px, 2) / (2 * e * e) +
            std::pow(predicted.s_phi_rad - z.slice.s_phi_rad, 2) / (2 * angular * angular);
      }
  }
  return residual2;
}

EvaluationPtr SlamEvaluator::Solve(const AssociationState& state, const StateEvaluation* from,
                                   bool full) {
  const auto start_time = std::chrono::steady_clock::now();
  const GeometricSlamProblem problem = BuildProblem(state);
  GeometricSlamResult warm;
  const bool warm_start = from && from->solution;
  if (warm_start) warm = WarmStart(state, *from);
  GeometricSlam& slam = full ? full_ : step_;
  auto solution =
      std::make_shared<GeometricSlamResult>(slam.Solve(problem, warm_start ? &warm : nullptr));
  ++solves_;
  auto evaluation = std::make_shared<StateEvaluation>();
  evaluation->state = state;
  evaluation->valid = solution->summary.IsUsable() && solution->evidence.valid &&
                      std::isfinite(solution->evidence.log_evidence);
  double log_target = solution->evidence.log_evidence;
  for (size_t j = 0; j < state.blocks.size(); ++j) {
    log_target += model_.BlockLogLikelihood(state.blocks[j], state.classes[j]);
    if (options_.class_prior_per_object) log_target -= std::log(double(model_.num_classes()));
    const MappedObject* object = FindObject(*solution, state.blocks[j].front());
    evaluation->locations.push_back(object ? object->geometry.base_world : Eigen::Vector3d::Zero());
  }
  evaluation->log_target = log_target;
  evaluation->residual2 = ObjectResiduals(state, *solution);
  evaluation->solution = std::move(solution);
  evaluation->evaluation_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return evaluation;
}

void SlamEvaluator::Store(const EvaluationPtr& evaluation) {
  if (cache_.size() >= options_.max_cache_entries) cache_.clear();
  cache_[evaluation->state] = evaluation;
}

EvaluationPtr SlamEvaluator::Evaluate(const AssociationState& state, const StateEvaluation* from) {
  const auto found = cache_.find(state);
  if (found != cache_.end()) {
    ++hits_;
    return found->second;
  }
  EvaluationPtr evaluation = Solve(state, from, false);
  Store(evaluation);
  return evaluation;
}

EvaluationPtr SlamEvaluator::Refine(const AssociationState& state, const StateEvaluation* from) {
  EvaluationPtr evaluation = Solve(state, from, true);
  Store(evaluation);
  return evaluation;
}

void SlamEvaluator::Remember(const EvaluationPtr& evaluation) {
  Store(evaluation);
}

}  // namespace oslam

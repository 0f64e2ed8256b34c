#include "association/slam_target.h"

#include <chrono>
#include <cmath>
#include <map>

#include "core/error.h"

namespace oslam {
namespace {

GeometricSlamOptions StepOptions(const SlamTargetOptions& options) {
  GeometricSlamOptions step = options.slam;
  step.solver.max_iterations = options.proposal_iterations - 1;
  step.solver.apply_final_step = true;      // the Gauss-Newton step of the last linear system
  step.compute_object_covariances = false;  // added by Complete() to recorded samples only
  step.compute_pose_covariances = false;
  // A proposal's value is then a function of (state, from) alone, so a
  // speculative chain can undo evaluations and redo them (SupportsRollBack).
  step.solver.independent_of_history = true;
  // Proposals from one state share its solution as their linearisation
  // point: all but the first reuse most factors' Jacobians (docs/method.md §9.6).
  step.solver.reuse_linearizations = true;
  // Every proposal changes the block pattern, so each is analysed afresh;
  // comparing AMD with objects-last orderings each time cost 10 % of a
  // proposal (LPA scale), while AMD's factorisation flops were within 5 %
  // of the better one in 99 % of long_loop's proposals.
  step.solver.ordering = OrderingType::kAmd;
  return step;
}

// Covariances at a given solution: no iteration, no step, no evidence.
GeometricSlamOptions CovarianceOptions(const SlamTargetOptions& options) {
  GeometricSlamOptions covariances = options.slam;
  covariances.solver.max_iterations = 0;
  covariances.solver.apply_final_step = false;
  covariances.solver.compute_evidence = false;
  covariances.compute_object_covariances = true;
  covariances.compute_pose_covariances = false;
  return covariances;
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
      step_(*data.camera, StepOptions(options)),
      covariances_(*data.camera, CovarianceOptions(options)),
      cache_(options.max_cache_entries) {
  std::string why;
  if (!options.Validate(&why)) throw Error("O-SLAM target options: " + why);
}

GeometricSlamProblem SlamEvaluator::BuildProblem(const AssociationState& state) const {
  GeometricSlamProblem problem;
  problem.increments = data_.increments;
  problem.first_pose = data_.first_pose;
  problem.classes = data_.classes;
  for (size_t j = 0; j < state.blocks.size(); ++j) {
    problem.object_class[state.blocks[j].front()] = state.classes[j];
    AddObservations(state.blocks[j], &problem.observations);
  }
  return problem;
}

void SlamEvaluator::AddObservations(const std::vector<int>& block,
                                    std::vector<SliceObservation>* observations) const {
  const int id = block.front();
  for (int t : block)
    for (int d : data_.tracks[t].detections)
      observations->push_back({data_.detections[d].frame, id, data_.detections[d].slice, d});
}

double SlamEvaluator::ClassTerm(const std::vector<int>& block, int class_index) const {
  double term = model_.BlockLogLikelihood(block, class_index);
  if (options_.class_prior_per_object) term -= std::log(double(model_.num_classes()));
  return term;
}

// The linearisation point of a proposed state (docs/method.md §9.6): the current
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

EvaluationPtr SlamEvaluator::Solve(const AssociationState& state, const StateEvaluation* from,
                                   bool full) {
  const auto start_time = std::chrono::steady_clock::now();
  const GeometricSlamProblem problem = BuildProblem(state);
  GeometricSlamResult warm;
  // A full solve converges from wherever it starts; a proposal's few steps
  // start at the reference when there is one.
  const StateEvaluation* start = !full && reference_ ? reference_.get() : from;
  const bool warm_start = start && start->solution;
  if (warm_start) warm = WarmStart(state, *start);
  GeometricSlam& slam = full ? full_ : step_;
  auto solution =
      std::make_shared<GeometricSlamResult>(slam.Solve(problem, warm_start ? &warm : nullptr));
  cache_.CountSolve();
  auto evaluation = std::make_shared<StateEvaluation>();
  evaluation->state = state;
  evaluation->valid = solution->summary.IsUsable() && solution->evidence.valid &&
                      std::isfinite(solution->evidence.log_evidence);
  double log_target = solution->evidence.log_evidence;
  for (size_t j = 0; j < state.blocks.size(); ++j) {
    log_target += ClassTerm(state.blocks[j], state.classes[j]);
    const MappedObject* object = FindObject(*solution, state.blocks[j].front());
    evaluation->locations.push_back(object ? object->geometry.base_world : Eigen::Vector3d::Zero());
  }
  evaluation->log_target = log_target;
  for (size_t j = 0; j < state.blocks.size(); ++j) {
    const MappedObject* object = FindObject(*solution, state.blocks[j].front());
    evaluation->residual2.push_back(object ? object->squared_residual : 0.0);
  }
  evaluation->solution = std::move(solution);
  evaluation->evaluation_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return evaluation;
}

bool SlamEvaluator::LocalObjectLogTarget(const std::vector<int>& block, int class_index,
                                         const std::vector<Pose2>& poses, CylinderGeometry* object,
                                         double* log_target, double* squared_residual) const {
  std::vector<SliceObservation> observations;
  AddObservations(block, &observations);
  std::vector<const SliceObservation*> detections;
  for (const SliceObservation& observation : observations) detections.push_back(&observation);
  double log_evidence;
  if (!ObjectLogEvidenceWithPosesHeld(*data_.camera, poses, detections, data_.classes[class_index],
                                      options_.slam.pixel_std_px, object, &log_evidence,
                                      squared_residual))
    return false;
  *log_target = log_evidence + ClassTerm(block, class_index);
  return true;
}

const SlamEvaluator::LocalValue& SlamEvaluator::LocalValueFrom(const StateEvaluation& from,
                                                               const std::vector<int>& block,
                                                               int class_index) {
  auto memo = memos_.find(from.solution.get());
  if (memo == memos_.end()) {
    if (memos_.size() >= kMaxMemoSolutions) memos_.clear();
    memo = memos_.emplace(from.solution.get(), SolutionMemo{from.solution, {}}).first;
  }
  // Each value is used before the next call, so a full memo may be dropped here.
  if (memo->second.values.size() >= kMaxMemoValues) memo->second.values.clear();
  auto [entry, added] = memo->second.values.try_emplace({block, class_index});
  LocalValue& value = entry->second;
  if (!added) return value;
  // Started where a solve's warm start would put it (docs/method.md §9.6):
  // at from's object holding the block's earliest track.
  const MappedObject* start =
      FindObject(*from.solution, from.state.blocks[from.state.BlockOf(block.front())].front());
  if (!start) return value;
  CylinderGeometry object = start->geometry;
  value.usable = LocalObjectLogTarget(block, class_index, from.solution->trajectory, &object,
                                      &value.log_target, &value.squared_residual);
  value.location = object.base_world;
  return value;
}

EvaluationPtr SlamEvaluator::Approximate(const AssociationState& to, const StateEvaluation& from) {
  if (!from.solution || !from.valid) return nullptr;
  // from's objects by (tracks, class); the ones `to` keeps cancel.
  std::map<std::vector<int>, size_t> from_index;
  for (size_t j = 0; j < from.state.blocks.size(); ++j) from_index[from.state.blocks[j]] = j;
  auto approximate = std::make_shared<StateEvaluation>();
  approximate->state = to;
  std::vector<char> kept(from.state.blocks.size(), 0);
  double log_target = from.log_target;
  for (size_t j = 0; j < to.blocks.size(); ++j) {
    const auto found = from_index.find(to.blocks[j]);
    if (found != from_index.end() && from.state.classes[found->second] == to.classes[j]) {
      kept[found->second] = 1;
      approximate->locations.push_back(from.locations[found->second]);
      approximate->residual2.push_back(from.residual2[found->second]);
      continue;
    }
    if (from.state.BlockOf(to.blocks[j].front()) < 0) return nullptr;
    const LocalValue& value = LocalValueFrom(from, to.blocks[j], to.classes[j]);
    if (!value.usable) return nullptr;
    log_target += value.log_target;
    approximate->locations.push_back(value.location);
    approximate->residual2.push_back(value.squared_residual);
  }
  for (size_t j = 0; j < from.state.blocks.size(); ++j) {
    if (kept[j]) continue;
    const LocalValue& value = LocalValueFrom(from, from.state.blocks[j], from.state.classes[j]);
    if (!value.usable) return nullptr;
    log_target -= value.log_target;
  }
  approximate->log_target = log_target;
  approximate->valid = std::isfinite(log_target);
  return approximate;
}

EvaluationPtr SlamEvaluator::Evaluate(const AssociationState& state, const StateEvaluation* from) {
  if (EvaluationPtr found = cache_.Find(state)) return found;
  EvaluationPtr evaluation = Solve(state, from, false);
  cache_.Store(evaluation);
  return evaluation;
}

EvaluationPtr SlamEvaluator::Refine(const AssociationState& state, const StateEvaluation* from) {
  EvaluationPtr evaluation = Solve(state, from, true);
  cache_.Store(evaluation);
  return evaluation;
}

void SlamEvaluator::Remember(const EvaluationPtr& evaluation) {
  cache_.Store(evaluation);
}

void SlamEvaluator::LineariseAt(const EvaluationPtr& reference) {
  if (!options_.linearise_at_reference || !reference || !reference->solution) return;
  reference_ = reference;
  // Values cached before were linearised along the path that reached them.
  cache_.Clear();
  cache_.Store(reference);
}

EvaluationPtr SlamEvaluator::Complete(const EvaluationPtr& evaluation) {
  if (!evaluation || !evaluation->solution || evaluation->solution->has_object_covariances)
    return evaluation;
  // Linearised at the solution itself, so the covariances belong to exactly
  // the estimate the sample records.
  GeometricSlamResult at_solution = *evaluation->solution;
  const GeometricSlamResult with =
      covariances_.Solve(BuildProblem(evaluation->state), &at_solution);
  cache_.CountSolve();
  if (!with.has_object_covariances) return evaluation;  // reported by the fusion as zero
  for (MappedObject& object : at_solution.objects)
    for (const MappedObject& solved : with.objects)
      if (solved.id == object.id) object.covariance = solved.covariance;
  at_solution.has_object_covariances = true;
  auto completed = std::make_shared<StateEvaluation>(*evaluation);
  completed->solution = std::make_shared<GeometricSlamResult>(std::move(at_solution));
  cache_.Store(completed);
  return completed;
}

}  // namespace oslam

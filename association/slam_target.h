// The O-SLAM target for the sampler (docs/method.md §8): log P(Z | C, J) by the
// geometric solver's Laplace evidence, plus the class-confusion penalty
// sum log P(a | c) (eq. 4.32) and log P(C, J) (uniform joint by default,
// docs/method.md §13 #37). A state's objects are its blocks of tracks; object id = the
// block's earliest track. Proposed states are solved with few iterations from
// the current state's solution, or after LineariseAt from the reference's
// (docs/method.md §9.6), and every evaluated state is cached by its canonical
// form, so a revisited state keeps one value (§9.3).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "association/association_state.h"
#include "association/tracks.h"
#include "slam/geometric_slam.h"

namespace oslam {

struct SlamTargetOptions {
  GeometricSlamOptions slam;  // E, motion noise, solver (full optimisation)
  // Linear systems solved for a proposed state, linearised at the current
  // state's solution: 1 = the thesis' single Gauss-Newton step with the
  // evidence of that linear system (docs/method.md §9.6, §8.2 notes); k > 1 adds k - 1
  // Levenberg-Marquardt iterations before it.
  int proposal_iterations = 1;
  // After LineariseAt (the sampler calls it with the hill-climbed state before
  // MC3): true = every proposal is solved from that reference solution, so a
  // state's value does not depend on the path that reached it; false = from
  // the current state's solution (the thesis, docs/method.md §9.6).
  bool linearise_at_reference = true;
  // #37: false = P(C, J) uniform (thesis reading); true = prod_j 1/|classes|.
  bool class_prior_per_object = false;
  size_t max_cache_entries = 100000;  // the cache is cleared when it grows beyond this

  bool Validate(std::string* why) const;
};

// Everything the evaluator needs; shared read-only by all chains.
struct SlamTargetData {
  const CameraModel* camera = nullptr;
  std::vector<OdometryIncrement> increments;
  Pose2 first_pose;
  std::vector<ClassPrior> classes;
  std::vector<ClassedSlice> detections;
  std::vector<Track> tracks;
};

class SlamEvaluator : public StateEvaluator {
 public:
  // data and model must outlive the evaluator.
  SlamEvaluator(const SlamTargetData& data, const ClassConfusionModel& model,
                const SlamTargetOptions& options);

  EvaluationPtr Evaluate(const AssociationState& state, const StateEvaluation* from) override;
  EvaluationPtr Refine(const AssociationState& state, const StateEvaluation* from) override;
  void Remember(const EvaluationPtr& evaluation) override;
  void LineariseAt(const EvaluationPtr& reference) override;
  EvaluationPtr Complete(const EvaluationPtr& evaluation) override;
  // The objects that differ between the states, each solved alone with the
  // poses held at from's trajectory (ObjectLogEvidenceWithPosesHeld), change
  // from's log target; objects both states share keep from's values.
  EvaluationPtr Approximate(const AssociationState& to, const StateEvaluation& from) override;
  size_t num_solves() const override { return cache_.solves(); }
  size_t num_cache_hits() const override { return cache_.hits(); }
  bool SupportsRollBack() const override { return true; }
  size_t Mark() override { return cache_.Mark(); }
  void RollBack(size_t mark) override { cache_.RollBack(mark); }
  void Release(size_t mark) override { cache_.Release(mark); }

  GeometricSlamProblem BuildProblem(const AssociationState& state) const;

 private:
  EvaluationPtr Solve(const AssociationState& state, const StateEvaluation* from, bool full);
  GeometricSlamResult WarmStart(const AssociationState& state, const StateEvaluation& from) const;
  // The detections of a block's tracks, as observations of object block.front().
  void AddObservations(const std::vector<int>& block,
                       std::vector<SliceObservation>* observations) const;
  // An object's class terms: log P(a | c) of its tracks and its share of log P(C, J).
  double ClassTerm(const std::vector<int>& block, int class_index) const;
  // An object's log-evidence with the poses held plus its class terms, solved
  // from `start` (which receives the result), and r^2 of its detections;
  // false when it cannot be evaluated.
  bool LocalObjectLogTarget(const std::vector<int>& block, int class_index,
                            const std::vector<Pose2>& poses, CylinderGeometry* object,
                            double* log_target, double* squared_residual) const;

  // An object's local log target (LocalObjectLogTarget) with from's poses,
  // started at from's object holding its earliest track; a function of
  // (from, block, class) alone, so it is kept while Approximate is called
  // from one state: a chain proposes from one state many times, and each
  // proposal re-solved the objects it takes away.
  struct LocalValue {
    bool usable = false;
    double log_target = 0, squared_residual = 0;
    Eigen::Vector3d location = Eigen::Vector3d::Zero();
  };
  const LocalValue& LocalValueFrom(const StateEvaluation& from, const std::vector<int>& block,
                                   int class_index);

  const SlamTargetData& data_;
  const ClassConfusionModel& model_;
  SlamTargetOptions options_;
  GeometricSlam full_, step_, covariances_;
  EvaluationCache cache_;
  EvaluationPtr reference_;  // LineariseAt's state; null: linearise at `from`
  // LocalValueFrom's values per solution (held, so that its address is not
  // reused while its values are kept): a chain proposes from one state many
  // times and returns to the few states it moves between, whose solutions
  // are the cached ones.
  struct SolutionMemo {
    std::shared_ptr<const GeometricSlamResult> solution;
    std::map<std::pair<std::vector<int>, int>, LocalValue> values;
  };
  static constexpr size_t kMaxMemoSolutions = 4096;  // all dropped when full
  static constexpr size_t kMaxMemoValues = 100000;   // per solution, likewise
  std::unordered_map<const GeometricSlamResult*, SolutionMemo> memos_;
};

}  // namespace oslam

// A 4-track, 2-class association problem small enough to enumerate (94
// states), shared by the state, move and sampler tests. The target and the
// per-object quantities the moves use (locations, residuals) are fixed
// functions of the state, as exact Metropolis-Hastings needs.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "association/association_state.h"
#include "core/error.h"

namespace oslam::testing {

inline const std::vector<Eigen::Vector3d> kTrackPositions = {
    {0.0, 0.0, 0.0}, {0.3, 0.0, 0.0}, {0.2, 0.4, 0.0}, {1.0, 0.1, 0.0}};
inline const std::vector<int> kTrackClass = {0, 0, 1, 0};
inline const std::vector<int> kTrackSize = {3, 2, 3, 2};

inline ClassConfusionModel TestModel() {
  return ClassConfusionModel({{0.8, 0.2}, {0.3, 0.7}}, 1e-3, kTrackClass, kTrackSize);
}

// An arbitrary but fixed target: class penalty, a price per object and a
// pseudo-random term per state (seeded by the state's hash).
inline double TestLogTarget(const AssociationState& s, const ClassConfusionModel& model) {
  std::mt19937_64 rng(AssociationStateHash()(s));
  double target = std::uniform_real_distribution<double>(-1.5, 1.5)(rng);
  for (size_t j = 0; j < s.blocks.size(); ++j)
    target += model.BlockLogLikelihood(s.blocks[j], s.classes[j]) - 0.7;
  return target;
}

// The evaluation of `state`: the test target, each object at the mean of its
// tracks' positions, its residual their spread (plus 0.2, so never zero).
inline EvaluationPtr TestEvaluation(const AssociationState& state,
                                    const ClassConfusionModel& model) {
  auto e = std::make_shared<StateEvaluation>();
  e->state = state;
  e->valid = true;
  e->log_target = TestLogTarget(state, model);
  for (const auto& block : state.blocks) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int t : block) mean += kTrackPositions[t];
    mean /= block.size();
    double spread = 0.2;
    for (int t : block) spread += (kTrackPositions[t] - mean).squaredNorm();
    e->locations.push_back(mean);
    e->residual2.push_back(spread);
  }
  return e;
}

class TestEvaluator : public StateEvaluator {
 public:
  // What an evaluator did, kept where it outlives the evaluator (a sampler
  // destroys its evaluators when its run ends).
  struct Counts {
    size_t solves = 0;
    int completions = 0;
  };

  explicit TestEvaluator(const ClassConfusionModel& model) : model_(model) {}
  ~TestEvaluator() override {
    if (counts_) counts_->solves = cache_.solves();
  }
  EvaluationPtr Evaluate(const AssociationState& state, const StateEvaluation*) override {
    if (EvaluationPtr found = cache_.Find(state)) return found;
    if (fail_after_solves_ >= 0 && cache_.solves() >= static_cast<size_t>(fail_after_solves_))
      throw Error("test evaluator: failing as asked");
    EvaluationPtr e = TestEvaluation(state, model_);
    cache_.CountSolve();
    cache_.Store(e);
    return e;
  }
  EvaluationPtr Refine(const AssociationState& state, const StateEvaluation* from) override {
    return Evaluate(state, from);
  }
  // For delayed acceptance: the exact evaluation of `to` with its target and
  // locations perturbed by a deterministic function of (from, to), and none at
  // all for some pairs, so that both screening paths are exercised.
  EvaluationPtr Approximate(const AssociationState& to, const StateEvaluation& from) override {
    if (!approximate_) return nullptr;  // EnableApproximation(0): exact values
    const size_t key = AssociationStateHash()(to) * 31 + AssociationStateHash()(from.state);
    if (key % 7 == 0) return nullptr;
    std::mt19937_64 rng(key);
    std::uniform_real_distribution<double> noise(-approximation_error_, approximation_error_);
    auto approximate = std::make_shared<StateEvaluation>(*TestEvaluation(to, model_));
    approximate->log_target += noise(rng);
    for (auto& location : approximate->locations) location.x() += 0.1 * noise(rng);
    return approximate;
  }
  // A completed evaluation is a copy with evaluation_time_s = 1, so that the
  // tests can tell completed samples from the chains' evaluations.
  EvaluationPtr Complete(const EvaluationPtr& evaluation) override {
    if (counts_) ++counts_->completions;
    auto completed = std::make_shared<StateEvaluation>(*evaluation);
    completed->evaluation_time_s = 1.0;
    return completed;
  }
  void EnableApproximation(double error) {
    approximate_ = true;
    approximation_error_ = error;
  }
  // Evaluate throws oslam::Error instead of solving once `solves` were done.
  void FailAfterSolves(int solves) { fail_after_solves_ = solves; }
  void Remember(const EvaluationPtr& e) override { cache_.Store(e); }
  size_t num_solves() const override { return cache_.solves(); }
  size_t num_cache_hits() const override { return cache_.hits(); }
  void CountInto(std::shared_ptr<Counts> counts) { counts_ = std::move(counts); }
  void DisableRollBack() { roll_back_ = false; }
  bool SupportsRollBack() const override { return roll_back_; }
  size_t Mark() override { return cache_.Mark(); }
  void RollBack(size_t mark) override { cache_.RollBack(mark); }
  void Release(size_t mark) override { cache_.Release(mark); }

 private:
  const ClassConfusionModel& model_;
  EvaluationCache cache_{1000000};
  bool roll_back_ = true;
  bool approximate_ = false;
  double approximation_error_ = 0;
  int fail_after_solves_ = -1;
  std::shared_ptr<Counts> counts_;
};

// All set partitions of n elements (restricted growth strings) x classes.
inline std::vector<AssociationState> EnumerateStates(int n, int num_classes) {
  std::vector<AssociationState> states;
  std::vector<int> label(n, 0);
  std::function<void(int, int)> partitions = [&](int i, int used) {
    if (i == n) {
      std::vector<std::vector<int>> blocks(used);
      for (int t = 0; t < n; ++t) blocks[label[t]].push_back(t);
      const int k = used;
      for (int code = 0; code < std::pow(num_classes, k); ++code) {
        AssociationState s;
        s.blocks = blocks;
        for (int j = 0, c = code; j < k; ++j, c /= num_classes)
          s.classes.push_back(c % num_classes);
        s.Canonicalize();
        states.push_back(s);
      }
      return;
    }
    for (int l = 0; l <= used; ++l) {
      label[i] = l;
      partitions(i + 1, std::max(used, l + 1));
    }
  };
  partitions(0, 0);
  return states;
}

}  // namespace oslam::testing

// The sampler's state (C, J) over atomic tracks (docs/method.md §9.5): a partition of
// the track ids into objects plus a class per object, kept canonical (ids
// sorted in each block, blocks sorted by their first id) so that equal states
// compare and hash equal. Also the class-confusion model of the tracks
// (docs/method.md §7.1) and what a state's evaluation provides to the moves.
#pragma once

#include <cstddef>
#include <deque>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "slam/geometric_slam.h"

namespace oslam {

struct AssociationState {
  std::vector<std::vector<int>> blocks;  // track ids per object
  std::vector<int> classes;              // class index per object (c_j)

  void Canonicalize();
  int BlockOf(int track) const;  // -1 when absent
  // The canonical state with `track` moved out of its object (which keeps its
  // class, or goes when empty) into object `target_block` (an index of this
  // state) or, for -1, alone; the object it ends in takes `joined_class`.
  // This state must be canonical (only the two objects are re-placed).
  AssociationState WithTrackMoved(int track, int target_block, int joined_class) const;
  // The canonical state with objects a and b (indices, a != b) merged into
  // one, which takes the class of the earlier; built without re-sorting the
  // objects, since the merged one keeps the earlier's first track.
  AssociationState WithBlocksMerged(int a, int b) const;
  size_t num_tracks() const;
  bool operator==(const AssociationState& other) const {
    return blocks == other.blocks && classes == other.classes;
  }
  std::string ToString() const;  // "{0,2}:1 {1}:0"
};

struct AssociationStateHash {
  size_t operator()(const AssociationState& state) const;
};

// Every track its own object, with its detected class (Algorithm 9 step 3).
AssociationState SeparateTracksState(const std::vector<int>& track_classes);

// log P(a | c) for the tracks: a track's detections share one detected class.
class ClassConfusionModel {
 public:
  // confusion[c][a] = P(a | c); entries are floored at `floor` (docs/method.md §7.1,
  // so that no class is impossible) and rows renormalised. track_size[t] is
  // the number of detector class decisions track t counts for: its detection
  // count (eq. 4.32 as printed) or 1 (one decision per track).
  ClassConfusionModel(const std::vector<std::vector<double>>& confusion, double floor,
                      std::vector<int> track_class, std::vector<int> track_size);
  // Identity confusion (known classes, docs/method.md §11.4): P(a | c) = 1 if a == c, else `floor`.
  static ClassConfusionModel Identity(int num_classes, double floor, std::vector<int> track_class,
                                      std::vector<int> track_size);

  int num_classes() const { return static_cast<int>(log_confusion_.size()); }
  int num_tracks() const { return static_cast<int>(track_class_.size()); }
  int track_class(int track) const { return track_class_[track]; }
  int track_size(int track) const { return track_size_[track]; }
  // sum over the block's tracks of track_size * log P(a_t | c) (the penalty of eq. 4.32).
  double BlockLogLikelihood(const std::vector<int>& block, int c) const;
  // log q(c | Psi) for every c: q ∝ prod P(a | c) (Algorithms 5-7).
  std::vector<double> ClassLogProposal(const std::vector<int>& block) const;

 private:
  std::vector<std::vector<double>> log_confusion_;  // [c][a]
  std::vector<int> track_class_, track_size_;
};

// A state's target and the per-object quantities the moves need, all
// computed on that state's solution (docs/method.md §9.2-9.3); index = block index.
struct StateEvaluation {
  AssociationState state;
  bool valid = false;
  double log_target = 0;                   // log P(Z | C, J) + log P(C, J), untempered
  std::vector<Eigen::Vector3d> locations;  // l_j
  std::vector<double> residual2;           // r^2(j), eq. 5.2
  // The geometric solution, for fusion and warm starts (null in tests).
  std::shared_ptr<const GeometricSlamResult> solution;
  double evaluation_time_s = 0;
};

using EvaluationPtr = std::shared_ptr<const StateEvaluation>;

// Evaluations by state, with the evaluator's solve and hit counters, for
// StateEvaluator implementations. After the first Mark() every change is
// journalled, so RollBack(mark) restores entries and counters exactly as they
// were at the mark; Release(mark) drops the journal before it.
class EvaluationCache {
 public:
  explicit EvaluationCache(size_t max_entries) : max_entries_(max_entries) {}
  EvaluationPtr Find(const AssociationState& state);  // counts a hit when found
  // Inserts or replaces; the whole cache is cleared first when it is full.
  void Store(const EvaluationPtr& evaluation);
  // Drops every entry (not journalled: call before the first Mark()).
  void Clear();
  void CountSolve() { ++solves_; }
  size_t solves() const { return solves_; }
  size_t hits() const { return hits_; }
  size_t size() const { return entries_.size(); }

  size_t Mark();
  void RollBack(size_t mark);
  void Release(size_t mark);

 private:
  using Map = std::unordered_map<AssociationState, EvaluationPtr, AssociationStateHash>;
  struct Change {
    bool is_mark = false;  // a mark: the counters then
    size_t solves = 0, hits = 0;
    AssociationState key;  // a store: the key and what it replaced (null: absent)
    EvaluationPtr previous;
    std::unique_ptr<Map> cleared;  // a clear: the entries it removed
  };
  size_t max_entries_;
  Map entries_;
  size_t solves_ = 0, hits_ = 0;
  bool journaling_ = false;
  std::deque<Change> journal_;
  size_t journal_begin_ = 0;  // the mark number of journal_.front()
};

// Computes (and caches) evaluations. One instance per chain: not thread-safe.
class StateEvaluator {
 public:
  virtual ~StateEvaluator() = default;
  // Evaluates `state`, linearised at `from` (the current state's evaluation,
  // may be null); a cached value is returned for a revisited state.
  virtual EvaluationPtr Evaluate(const AssociationState& state, const StateEvaluation* from) = 0;
  // Full optimisation of `state`; replaces its cached value (docs/method.md §9.3).
  virtual EvaluationPtr Refine(const AssociationState& state, const StateEvaluation* from) = 0;
  // Puts an evaluation computed elsewhere into the cache (chain start, swaps).
  virtual void Remember(const EvaluationPtr& evaluation) = 0;
  // From now on Evaluate linearises every state at `reference` instead of at
  // `from`, so that a state's value is a function of the state alone
  // (docs/method.md §9.6); evaluations cached before are dropped. Evaluators
  // whose values never depend on `from` ignore it.
  virtual void LineariseAt(const EvaluationPtr& reference) { (void)reference; }
  // The same evaluation with what only recorded samples need (the objects'
  // marginal covariances, for the spurious-object model) filled in. Proposals
  // skip it because most are rejected; the default returns the input.
  virtual EvaluationPtr Complete(const EvaluationPtr& evaluation) { return evaluation; }
  // A cheap approximation of `to`'s evaluation made from `from` (its log
  // target and the objects' locations and residuals the moves use), for the
  // sampler's delayed acceptance: any function of (from, to) keeps the sampler
  // exact, a close one spares most solves. Null when there is none.
  virtual EvaluationPtr Approximate(const AssociationState& to, const StateEvaluation& from) {
    (void)to, (void)from;
    return nullptr;
  }
  virtual size_t num_solves() const = 0;
  virtual size_t num_cache_hits() const = 0;

  // Speculative MC3: a chain steps ahead of the swap decisions and goes back
  // when a swap at an earlier iteration is accepted. Mark() names the
  // evaluator's state now; RollBack(mark) returns to it (cache and counters),
  // after which every call gives what it would have given had nothing
  // happened since the mark; Release(mark) forgets what going back to a mark
  // before `mark` would need. An evaluator whose results depend on work it
  // cannot undo (a solver's cached analysis, say) leaves SupportsRollBack()
  // false, and the sampler then steps the chains in lock-step.
  virtual bool SupportsRollBack() const { return false; }
  virtual size_t Mark() { return 0; }
  virtual void RollBack(size_t mark) { (void)mark; }
  virtual void Release(size_t mark) { (void)mark; }
};

}  // namespace oslam

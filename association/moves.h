// The data-driven proposals of docs/method.md §9.2 (Algorithms 5-7) with the review's
// fixes (docs/method.md §9.2-9.3, §13 #16-#19, #40-#45): merge (class-aware and
// distance-based, forward probability summed over both orders), split
// (residual-based; the partition probability is the one of the sampler
// actually used) and switch class; beyond the thesis, reassign (one track
// moved to a nearby object or alone). Each move's probability is a function of
// (state, evaluation) so that the reverse probability is computed by the same
// code as the forward one.
#pragma once

#include <limits>
#include <random>
#include <string>

#include "association/association_state.h"

namespace oslam {

enum class MoveType { kMerge = 0, kSplit = 1, kSwitch = 2, kReassign = 3 };
constexpr int kNumMoveTypes = 4;
const char* MoveName(MoveType type);

// P_merge, P_split, P_switch, P_reassign (must sum to 1). Reassign is beyond
// the thesis (docs/method.md §9.2): one track leaves its object for a nearby
// object or becomes an object alone, in one step instead of a split and a
// merge through an improbable intermediate state.
struct MoveProbabilities {
  double merge = 0.4, split = 0.4, switch_class = 0.2;
  double reassign = 0.0;
};

// How a split partitions an object's tracks (docs/method.md §13 #18/#43).
enum class SplitSampler {
  kUniform,  // uniform non-empty subset of the non-earliest tracks: 1/(2^(n-1) - 1)
  kThesis,   // Algorithm 6 step 4, with its true probability |Psi2|/(n-1) 2^-(n-2)
  // Beyond the thesis (docs/method.md §9.2): with probability 1/2 one of the
  // n tracks, drawn uniformly, is split off alone; else kUniform. The one
  // wrong track of an object is then proposed with probability about 1/(2n)
  // instead of 1/(2^(n-1) - 1).
  kOneTrackOrUniform,
};

struct MoveOptions {
  double merge_distance_m = 0.5;           // d_thr (Sec. 6.2)
  double merge_sigma_m = 0.5;              // sigma_E (#14)
  double class_mismatch_penalty = 3.0;     // on e_j; infinity = never merge across classes (#15)
  double merge_count_smoothing = 0.1;      // epsilon_d added to every d_j (#16)
  bool merge_count_includes_self = false;  // d_j counts o_j itself (#41)
  SplitSampler split_sampler = SplitSampler::kUniform;
  // Share of a uniform distribution in the class drawn by merge, split and
  // switch, q(c) = (1 - u) prod P(a | c) / Z + u / |classes| (0 = thesis).
  // Without it a class the detector seldom reports is never proposed.
  double class_proposal_uniform = 0.1;
  // sigma_R: the reassign move's sigma_E for where a track goes (beyond the
  // thesis, docs/method.md §9.2).
  double reassign_sigma_m = 1.0;
  // kappa: how much more often reassign picks a track whose detected class
  // misfits its object's, or a track alone (docs/method.md §9.2); 0 = every
  // track alike.
  double reassign_focus = 10.0;

  bool Validate(std::string* why) const;
};

struct Proposal {
  MoveType type = MoveType::kMerge;
  bool self_transition = true;  // nothing to propose (or the same state)
  AssociationState state;       // the proposed state (canonical)
  double log_q_forward = 0;
  // What the reverse move needs: the affected track sets and the old classes.
  // merge: the two merged blocks; split: the two halves; reassign: what the
  // moved track's object keeps (part_a) and the object it joins (part_b;
  // empty: it becomes an object alone).
  std::vector<int> part_a, part_b;
  // merge: classes of part_a/b; split/switch: old class; reassign: old
  // classes of the object the moved track left (a) and of the one it joined
  // (b).
  int old_class_a = 0, old_class_b = 0;
  int track = 0;  // switch: a track of the switched object; reassign: the moved track
};

using Rng = std::mt19937_64;

// Normalises log weights in place (log-sum-exp); false when every weight is zero.
bool NormaliseLog(std::vector<double>* log_weights);
// Draws an index from normalised log probabilities (one uniform from `rng`);
// indices of probability zero are never drawn.
int SampleLog(const std::vector<double>& log_p, Rng& rng);

// Draws a move from `current` (whose evaluation is `evaluation`).
Proposal ProposeMove(const StateEvaluation& current, const ClassConfusionModel& model,
                     const MoveOptions& options, const MoveProbabilities& probabilities, Rng& rng);

// log q(proposed -> current) evaluated on the proposed state's evaluation;
// -infinity when the reverse move is impossible.
double LogReverseProbability(const Proposal& proposal, const StateEvaluation& proposed,
                             const ClassConfusionModel& model, const MoveOptions& options,
                             const MoveProbabilities& probabilities);

// log q(current -> proposed) evaluated on `from`, an evaluation of the state
// the proposal started from (proposal.log_q_forward when it is that state's
// own evaluation; delayed acceptance passes an approximate one).
double LogForwardProbability(const Proposal& proposal, const StateEvaluation& from,
                             const ClassConfusionModel& model, const MoveOptions& options,
                             const MoveProbabilities& probabilities);

// The move probabilities themselves (log q, including P_move), exposed for tests.
double LogMergeProbability(const StateEvaluation& s, int block_a, int block_b, int merged_class,
                           const ClassConfusionModel& model, const MoveOptions& options,
                           const MoveProbabilities& probabilities);
double LogSplitProbability(const StateEvaluation& s, int block, const std::vector<int>& part_first,
                           const std::vector<int>& part_second, int class_first, int class_second,
                           const ClassConfusionModel& model, const MoveOptions& options,
                           const MoveProbabilities& probabilities);
double LogSwitchProbability(const StateEvaluation& s, int block, int new_class,
                            const ClassConfusionModel& model, const MoveOptions& options,
                            const MoveProbabilities& probabilities);
// Moving `track` into the object `target_block`, or alone (target_block =
// -1), the object it then belongs to taking class `joined_class` and what it
// leaves (when not empty) `rest_class`.
double LogReassignProbability(const StateEvaluation& s, int track, int target_block,
                              int joined_class, int rest_class, const ClassConfusionModel& model,
                              const MoveOptions& options, const MoveProbabilities& probabilities);

}  // namespace oslam

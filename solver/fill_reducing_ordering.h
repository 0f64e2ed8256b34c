// The fill-reducing ordering of the Cholesky back end, chosen on the block
// graph of J^T J (one node per free variable, so a variable's entries stay
// together, and a graph a few times smaller than the scalar one).
// Candidates are AMD; CAMD with the variables of high block degree last
// (objects seen from most poses: the pose chain is eliminated first, as a
// band, and the objects end up in one dense trailing block); and, from
// kMetisMinBlocks variables on, METIS nested dissection (objects seen on
// many laps of a long run). OrderingType::kAutomatic keeps the candidate
// with the fewest factorisation flops; the other types force one method.
#pragma once

#include <vector>

#include "solver/block_pattern.h"
#include "solver/sparse_solver.h"

struct cholmod_common_struct;

namespace oslam {

class FillReducingOrdering {
 public:
  // METIS is tried from this many variables on (below, it costs more than
  // it saves).
  static constexpr int kMetisMinBlocks = 2000;
  // Problems whose variable counts differ by at most this many, or by this
  // fraction of the larger count, are "similar" for the choice of ordering
  // kind: a problem growing in small steps is not compared afresh at every
  // step.
  static constexpr int kSimilarProblemBlocks = 8;
  static constexpr double kSimilarProblemFraction = 0.02;

  // The order in which to eliminate `pattern`'s variables (block_order[k]:
  // the k-th variable eliminated). A small association change (an O-SLAM
  // proposal: one object more or less) keeps the problem's character, so
  // an automatic choice reuses the kind that won the last comparison for a
  // similar problem; a problem that has drifted further from the compared
  // one, and every problem when `independent_of_history`, is compared
  // afresh. When no candidate works, the variables' own order. False only
  // when CHOLMOD cannot allocate the block graph.
  bool Choose(const BlockPattern& pattern, OrderingType requested, bool independent_of_history,
              cholmod_common_struct* cc, std::vector<int>* block_order);

  // The kind the last successful Choose used (never kAutomatic).
  OrderingType used() const { return used_; }
  // Forgets the last comparison.
  void Forget() { compared_num_blocks_ = -1; }

 private:
  OrderingType used_ = OrderingType::kAmd;
  // The last automatic comparison: its problem's variable count and winner.
  int compared_num_blocks_ = -1;
  OrderingType compared_choice_ = OrderingType::kAmd;
};

}  // namespace oslam

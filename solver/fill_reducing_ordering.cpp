#include "solver/fill_reducing_ordering.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <utility>

#include <cholmod.h>

namespace oslam {
namespace {

using Candidate = std::pair<OrderingType, std::vector<int>>;

// The pattern's block graph as a CHOLMOD pattern matrix (upper triangle),
// and each variable's block degree (variables it shares a factor with).
cholmod_sparse* BlockGraph(const BlockPattern& pattern, cholmod_common* cc,
                           std::vector<int>* degree) {
  const int num_free = pattern.num_blocks();
  size_t nnz = 0;
  for (const auto& rows : pattern.rows) nnz += rows.size();
  cholmod_sparse* blocks =
      cholmod_allocate_sparse(num_free, num_free, nnz, 1, 1, 1, CHOLMOD_PATTERN, cc);
  if (!blocks) return nullptr;
  auto* bp = static_cast<int*>(blocks->p);
  auto* bi = static_cast<int*>(blocks->i);
  degree->assign(num_free, 0);
  int next = 0;
  for (int b = 0; b < num_free; ++b) {
    bp[b] = next;
    for (int a : pattern.rows[b]) {
      bi[next++] = a;
      if (a != b) {
        ++(*degree)[a];
        ++(*degree)[b];
      }
    }
  }
  bp[num_free] = next;
  return blocks;
}

// The permutations of `blocks` that `wanted` asks for (kAutomatic: AMD,
// CAMD when some variables have a high block degree, METIS on big
// problems).
std::vector<Candidate> Candidates(cholmod_sparse* blocks, const std::vector<int>& degree,
                                  OrderingType wanted, cholmod_common* cc) {
  const int num_free = static_cast<int>(degree.size());
  std::vector<Candidate> candidates;
  std::vector<int> permutation(num_free);
  auto want = [wanted](OrderingType type) {
    return wanted == OrderingType::kAutomatic || wanted == type;
  };
  if (want(OrderingType::kAmd) && cholmod_amd(blocks, nullptr, 0, permutation.data(), cc))
    candidates.emplace_back(OrderingType::kAmd, permutation);
  // High degree: above 4 times the median, and above 16.
  std::vector<int> sorted = degree;
  std::nth_element(sorted.begin(), sorted.begin() + num_free / 2, sorted.end());
  const int threshold = std::max(16, 4 * sorted[num_free / 2]);
  std::vector<int> constraint(num_free, 0);
  bool any_high = false;
  for (int v = 0; v < num_free; ++v)
    if (degree[v] > threshold) constraint[v] = 1, any_high = true;
  if (((any_high && wanted == OrderingType::kAutomatic) ||
       wanted == OrderingType::kHighDegreeLast) &&
      cholmod_camd(blocks, nullptr, 0, constraint.data(), permutation.data(), cc))
    candidates.emplace_back(OrderingType::kHighDegreeLast, permutation);
  if (((num_free >= FillReducingOrdering::kMetisMinBlocks && wanted == OrderingType::kAutomatic) ||
       wanted == OrderingType::kMetis) &&
      cholmod_metis(blocks, nullptr, 0, /*postorder=*/0, permutation.data(), cc))
    candidates.emplace_back(OrderingType::kMetis, permutation);
  return candidates;
}

// The candidate with the fewest factorisation flops, as the postordered
// block order of its analysis (empty when none could be analysed), and its
// kind in `kind`. Candidates are compared by a symbolic analysis of the
// block pattern (a few times cheaper than the scalar one, and the scalar
// matrix is then analysed once): flops ~ sum_j d_j (count_j d)^2, with
// count_j the block column counts of L and d the mean block size.
std::vector<int> Cheapest(cholmod_sparse* blocks, const BlockPattern& pattern,
                          const std::vector<Candidate>& candidates, cholmod_common* cc,
                          OrderingType* kind) {
  const int num_free = pattern.num_blocks();
  const double mean_dim = static_cast<double>(pattern.n) / num_free;
  cc->nmethods = 1;
  cc->method[0].ordering = CHOLMOD_GIVEN;
  const int supernodal = cc->supernodal;
  cc->supernodal = CHOLMOD_SIMPLICIAL;
  std::vector<int> best;
  double best_flops = 0.0;
  for (const auto& [candidate_kind, block_permutation] : candidates) {
    cholmod_factor* analysed =
        cholmod_analyze_p(blocks, const_cast<int*>(block_permutation.data()), nullptr, 0, cc);
    if (!analysed) continue;
    const auto* perm = static_cast<const int*>(analysed->Perm);  // postordered
    const auto* counts = static_cast<const int*>(analysed->ColCount);
    double flops = 0.0;
    for (int j = 0; j < num_free; ++j)
      flops += pattern.dims[perm[j]] * std::pow(counts[j] * mean_dim, 2);
    if (std::getenv("OSLAM_SOLVER_TRACE"))
      std::fprintf(stderr, "ordering %d: block lnz %.0f estimated flops %.3g\n",
                   static_cast<int>(candidate_kind), cc->lnz, flops);
    if (best.empty() || flops < best_flops) {
      best.assign(perm, perm + num_free);
      best_flops = flops;
      *kind = candidate_kind;
    }
    cholmod_free_factor(&analysed, cc);
  }
  cc->supernodal = supernodal;
  return best;
}

}  // namespace

bool FillReducingOrdering::Choose(const BlockPattern& pattern, OrderingType requested,
                                  bool independent_of_history, cholmod_common* cc,
                                  std::vector<int>* block_order) {
  std::vector<int> degree;
  cholmod_sparse* blocks = BlockGraph(pattern, cc, &degree);
  if (!blocks) return false;
  const int num_free = pattern.num_blocks();
  OrderingType wanted = requested;
  const double similar = std::max<double>(
      kSimilarProblemBlocks, kSimilarProblemFraction * std::max(num_free, compared_num_blocks_));
  const bool compare =
      wanted == OrderingType::kAutomatic && (independent_of_history || compared_num_blocks_ < 0 ||
                                             std::abs(num_free - compared_num_blocks_) > similar);
  if (wanted == OrderingType::kAutomatic && !compare) wanted = compared_choice_;
  const std::vector<Candidate> candidates = Candidates(blocks, degree, wanted, cc);
  *block_order = Cheapest(blocks, pattern, candidates, cc, &used_);
  cholmod_free_sparse(&blocks, cc);
  if (compare && !block_order->empty()) {
    compared_num_blocks_ = num_free;
    compared_choice_ = used_;
  }
  if (block_order->empty()) {  // the variables' own order as the fallback
    block_order->resize(num_free);
    std::iota(block_order->begin(), block_order->end(), 0);
    used_ = OrderingType::kAmd;
  }
  return true;
}

}  // namespace oslam

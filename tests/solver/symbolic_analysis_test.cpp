#include "solver/symbolic_analysis.h"

#include <algorithm>
#include <numeric>
#include <utility>
#include <vector>

#include <cholmod.h>
#include <gtest/gtest.h>

#include "tests/solver/cholmod_workspace.h"

namespace oslam {
namespace {

// Objects of 3 and 2 entries (a base point and a size) seen from a chain
// of poses (3 entries): pose p sees object p % objects.
BlockPattern PosesAndObjects(int poses, int objects) {
  // Variables: poses first, then per object its base and size.
  const int num = poses + 2 * objects;
  std::vector<std::vector<int>> upper(num);
  auto link = [&](int a, int b) {
    if (a > b) std::swap(a, b);
    upper[b].push_back(a);
  };
  for (int p = 1; p < poses; ++p) link(p - 1, p);
  for (int p = 0; p < poses; ++p) {
    const int base = poses + 2 * (p % objects);
    link(p, base);
    link(p, base + 1);
    link(base, base + 1);
  }
  BlockPattern pattern;
  for (int v = 0; v < num; ++v) {
    pattern.dims.push_back(v < poses || (v - poses) % 2 == 0 ? 3 : 2);
    std::vector<int>& rows = upper[v];
    std::sort(rows.begin(), rows.end());
    rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
    rows.push_back(v);
    pattern.rows.push_back(rows);
  }
  pattern.ComputeLayout();
  return pattern;
}

// The Hessian's entries as the Cholesky back end stores them: per column
// of delta, its block rows' entries (the diagonal block's up to the
// diagonal). (row, column) of each, row <= column.
std::vector<std::pair<int, int>> HessianEntries(const BlockPattern& pattern) {
  std::vector<std::pair<int, int>> entries;
  for (int b = 0; b < pattern.num_blocks(); ++b)
    for (int q = 0; q < pattern.dims[b]; ++q)
      for (int a : pattern.rows[b]) {
        const int last = a == b ? q : pattern.dims[a] - 1;
        for (int r = 0; r <= last; ++r)
          entries.emplace_back(pattern.offsets[a] + r, pattern.offsets[b] + q);
      }
  return entries;
}

// Orders to try: the variables' own, reversed, and objects first.
std::vector<std::vector<int>> Orders(const BlockPattern& pattern, int poses) {
  std::vector<int> own(pattern.num_blocks());
  std::iota(own.begin(), own.end(), 0);
  std::vector<int> reversed(own.rbegin(), own.rend());
  std::vector<int> objects_first(own.begin() + poses, own.end());
  objects_first.insert(objects_first.end(), own.begin(), own.begin() + poses);
  return {own, reversed, objects_first};
}

// Every Hessian entry (r, c) sits at its permuted positions (a, b): in the
// lower triangle at (max, min), in the upper one at (min, max); each column
// sorted and holding its diagonal (first in the lower triangle, last in the
// upper); every matrix entry hit exactly once.
void ExpectEveryHessianEntryOnce(const BlockPattern& pattern,
                                 const std::vector<std::pair<int, int>>& entries,
                                 const PermutedHessian& permuted, bool upper) {
  const auto* p = static_cast<const int*>(permuted.matrix->p);
  const auto* i = static_cast<const int*>(permuted.matrix->i);
  ASSERT_EQ(p[pattern.n], static_cast<int>(entries.size()));
  for (int c = 0; c < pattern.n; ++c) {
    ASSERT_LT(p[c], p[c + 1]);
    EXPECT_EQ(i[upper ? p[c + 1] - 1 : p[c]], c);
    EXPECT_TRUE(std::is_sorted(i + p[c], i + p[c + 1]));
  }
  const std::vector<int>& inverse = permuted.inverse_permutation;
  std::vector<int> hits(entries.size(), 0);
  for (size_t k = 0; k < entries.size(); ++k) {
    const int a = inverse[entries[k].first], b = inverse[entries[k].second];
    const int row = upper ? std::min(a, b) : std::max(a, b);
    const int column = upper ? std::max(a, b) : std::min(a, b);
    const int at = permuted.entry[k];
    ASSERT_GE(at, p[column]);
    ASSERT_LT(at, p[column + 1]);
    EXPECT_EQ(i[at], row);
    ++hits[at];
  }
  EXPECT_EQ(std::count(hits.begin(), hits.end(), 1), static_cast<long>(entries.size()));
}

// The permuted copy holds every Hessian entry once in its lower triangle,
// and after UseUpperTriangle in its upper one, transposed.
TEST(SymbolicAnalysisTest, PermutedMatrixHoldsEveryHessianEntryOnceInEitherTriangle) {
  testing::CholmodWorkspace cholmod;
  const int poses = 12;
  const BlockPattern pattern = PosesAndObjects(poses, 3);
  const std::vector<std::pair<int, int>> entries = HessianEntries(pattern);
  for (const std::vector<int>& order : Orders(pattern, poses)) {
    PermutedHessian permuted;
    ASSERT_TRUE(BuildPermutedHessian(pattern, order, static_cast<int>(entries.size()), &cholmod.cc,
                                     &permuted));
    // A variable's entries stay together, in the block order.
    const std::vector<int>& inverse = permuted.inverse_permutation;
    EXPECT_EQ(inverse[pattern.offsets[order[0]]], 0);
    for (int v = 0; v < pattern.num_blocks(); ++v)
      for (int q = 1; q < pattern.dims[v]; ++q)
        EXPECT_EQ(inverse[pattern.offsets[v] + q], inverse[pattern.offsets[v]] + q);
    EXPECT_EQ(permuted.matrix->stype, -1);
    ExpectEveryHessianEntryOnce(pattern, entries, permuted, /*upper=*/false);
    ASSERT_TRUE(UseUpperTriangle(&permuted, &cholmod.cc));
    EXPECT_EQ(permuted.matrix->stype, 1);
    ExpectEveryHessianEntryOnce(pattern, entries, permuted, /*upper=*/true);
    cholmod_free_sparse(&permuted.matrix, &cholmod.cc);
  }
}

TEST(SymbolicAnalysisTest, BlockwiseAnalysisEqualsCholmodsSimplicialAndSupernodal) {
  for (const int supernodal : {CHOLMOD_SIMPLICIAL, CHOLMOD_SUPERNODAL}) {
    testing::CholmodWorkspace cholmod;
    cholmod_common& cc = cholmod.cc;
    cc.supernodal = supernodal;
    const int poses = 30;
    const BlockPattern pattern = PosesAndObjects(poses, 4);
    const int hessian_entries = static_cast<int>(HessianEntries(pattern).size());
    for (const std::vector<int>& order : Orders(pattern, poses)) {
      PermutedHessian permuted;
      ASSERT_TRUE(BuildPermutedHessian(pattern, order, hessian_entries, &cc, &permuted));
      cholmod_factor* mine = AnalyzeBlockwise(pattern, order, permuted, &cc);
      ASSERT_NE(mine, nullptr);
      cc.nmethods = 1;
      cc.method[0].ordering = CHOLMOD_NATURAL;
      cc.postorder = 0;
      cholmod_factor* theirs = cholmod_analyze(permuted.matrix, &cc);
      ASSERT_NE(theirs, nullptr);
      EXPECT_EQ(mine->is_super, supernodal == CHOLMOD_SUPERNODAL);
      EXPECT_EQ(theirs->is_super, mine->is_super);
      const auto* my_counts = static_cast<const int*>(mine->ColCount);
      const auto* their_counts = static_cast<const int*>(theirs->ColCount);
      EXPECT_TRUE(std::equal(my_counts, my_counts + pattern.n, their_counts));
      if (mine->is_super) {
        ASSERT_EQ(mine->nsuper, theirs->nsuper);
        const auto* my_super = static_cast<const int*>(mine->super);
        const auto* their_super = static_cast<const int*>(theirs->super);
        EXPECT_TRUE(std::equal(my_super, my_super + mine->nsuper + 1, their_super));
        EXPECT_EQ(mine->ssize, theirs->ssize);
      }
      cholmod_free_factor(&mine, &cc);
      cholmod_free_factor(&theirs, &cc);
      cholmod_free_sparse(&permuted.matrix, &cc);
    }
  }
}

}  // namespace
}  // namespace oslam

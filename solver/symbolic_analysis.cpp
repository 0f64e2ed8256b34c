#include "solver/symbolic_analysis.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <cholmod.h>

namespace oslam {
namespace {

// An off-diagonal block of the permuted lower triangle: in the column block
// of the pair's variable that comes first in the block order, the rows of
// the other one (`variable`), which start at row_start.
struct BelowBlock {
  int row_start, rows, pair, variable;
  bool operator<(const BelowBlock& other) const { return row_start < other.row_start; }
};

// Where the off-diagonal blocks go. Each off-diagonal pair of the pattern
// (index = its place in pattern.rows, column by column, from pair_begin)
// belongs to the column block of its variable that comes first in the
// order; its rows there follow the diagonal block, in permuted order.
// Returns the blocks, grouped per column block (from low_begin) and sorted
// by row; each pair's row offset below the diagonal block in pair_prefix,
// and each column block's rows below its diagonal block in below_rows.
std::vector<BelowBlock> PlaceBelowBlocks(const BlockPattern& pattern, const std::vector<int>& start,
                                         const std::vector<int>& pair_begin,
                                         std::vector<int>* low_begin, std::vector<int>* pair_prefix,
                                         std::vector<int>* below_rows) {
  const int num_free = pattern.num_blocks();
  const std::vector<int>& dims = pattern.dims;
  std::vector<int>& low_count = *low_begin;
  low_count.assign(num_free + 1, 0);
  for (int b = 0; b < num_free; ++b)
    for (int a : pattern.rows[b])
      if (a != b) ++low_count[(start[a] < start[b] ? a : b) + 1];
  for (int v = 0; v < num_free; ++v) low_count[v + 1] += low_count[v];
  std::vector<BelowBlock> below(low_count[num_free]);
  std::vector<int> fill(low_count.begin(), low_count.end() - 1);
  for (int b = 0; b < num_free; ++b)
    for (size_t k = 0; k < pattern.rows[b].size(); ++k) {
      const int a = pattern.rows[b][k];
      if (a == b) continue;
      const bool a_low = start[a] < start[b];
      below[fill[a_low ? a : b]++] = {a_low ? start[b] : start[a], a_low ? dims[b] : dims[a],
                                      pair_begin[b] + static_cast<int>(k), a_low ? b : a};
    }
  pair_prefix->assign(pair_begin[num_free], 0);
  below_rows->assign(num_free, 0);
  for (int v = 0; v < num_free; ++v) {
    const auto first = below.begin() + low_count[v], last = below.begin() + low_count[v + 1];
    std::sort(first, last);
    int prefix = 0;
    for (auto it = first; it != last; ++it) {
      (*pair_prefix)[it->pair] = prefix;
      prefix += it->rows;
    }
    (*below_rows)[v] = prefix;
  }
  return below;
}

// Each Hessian entry's position in the permuted matrix (column pointers
// pp), the Hessian walked in its storage order.
void MapHessianEntries(const BlockPattern& pattern, const std::vector<int>& start,
                       const std::vector<int>& pair_begin, const std::vector<int>& pair_prefix,
                       const int* pp, std::vector<int>* entry) {
  const std::vector<int>& dims = pattern.dims;
  int k = 0;
  for (int b = 0; b < pattern.num_blocks(); ++b)
    for (int q = 0; q < dims[b]; ++q)
      for (size_t t = 0; t < pattern.rows[b].size(); ++t) {
        const int a = pattern.rows[b][t];
        if (a == b) {
          for (int r = 0; r <= q; ++r) (*entry)[k++] = pp[start[b] + r] + (q - r);
          continue;
        }
        const int prefix = pair_prefix[pair_begin[b] + static_cast<int>(t)];
        if (start[a] < start[b]) {  // column block a, rows of b
          for (int r = 0; r < dims[a]; ++r)
            (*entry)[k++] = pp[start[a] + r] + (dims[a] - r) + prefix + q;
        } else {  // column block b, rows of a
          const int base = pp[start[b] + q] + (dims[b] - q) + prefix;
          for (int r = 0; r < dims[a]; ++r) (*entry)[k++] = base + r;
        }
      }
}

// Compares `mine` with cholmod_analyze's analysis of the same matrix and
// reports on stderr (OSLAM_SOLVER_CHECK_ANALYSIS).
void CheckAgainstCholmod(const cholmod_factor* mine, cholmod_sparse* permuted, cholmod_common* cc) {
  cc->method[0].ordering = CHOLMOD_NATURAL;
  cc->postorder = 0;
  cholmod_factor* theirs = cholmod_analyze(permuted, cc);
  cc->postorder = 1;
  bool same = theirs && theirs->is_super == mine->is_super && theirs->n == mine->n &&
              theirs->nsuper == mine->nsuper && theirs->ssize == mine->ssize &&
              theirs->xsize == mine->xsize && theirs->maxcsize == mine->maxcsize &&
              theirs->maxesize == mine->maxesize && theirs->is_ll == mine->is_ll &&
              theirs->ordering == mine->ordering;
  auto equal = [](const void* a, const void* b, size_t count) {
    return std::memcmp(a, b, count * sizeof(int)) == 0;
  };
  if (same)
    same = equal(theirs->ColCount, mine->ColCount, mine->n) &&
           equal(theirs->Perm, mine->Perm, mine->n);
  if (same && mine->is_super)
    same = equal(theirs->super, mine->super, mine->nsuper + 1) &&
           equal(theirs->pi, mine->pi, mine->nsuper + 1) &&
           equal(theirs->px, mine->px, mine->nsuper + 1) && equal(theirs->s, mine->s, mine->ssize);
  std::fprintf(stderr, "analysis check: %s (n %d super %d nsuper %d)\n",
               same ? "same" : "DIFFERENT", static_cast<int>(mine->n), mine->is_super,
               static_cast<int>(mine->nsuper));
  if (theirs) cholmod_free_factor(&theirs, cc);
}

}  // namespace

bool BuildPermutedHessian(const BlockPattern& pattern, const std::vector<int>& block_order,
                          int hessian_entries, cholmod_common* cc, PermutedHessian* out) {
  const int num_free = pattern.num_blocks(), n = pattern.n;
  const std::vector<int>& dims = pattern.dims;
  std::vector<int> start(num_free);  // first permuted entry of each variable
  int position = 0;
  for (int v : block_order) {
    start[v] = position;
    position += dims[v];
  }
  out->inverse_permutation.resize(n);
  for (int v = 0; v < num_free; ++v)
    for (int q = 0; q < dims[v]; ++q)
      out->inverse_permutation[pattern.offsets[v] + q] = start[v] + q;
  std::vector<int> pair_begin(num_free + 1, 0);
  for (int b = 0; b < num_free; ++b)
    pair_begin[b + 1] = pair_begin[b] + static_cast<int>(pattern.rows[b].size());
  std::vector<int> pair_prefix, below_rows;
  const std::vector<BelowBlock> below =
      PlaceBelowBlocks(pattern, start, pair_begin, &out->below_begin, &pair_prefix, &below_rows);
  out->below.resize(below.size());
  for (size_t k = 0; k < below.size(); ++k) out->below[k] = below[k].variable;

  std::size_t nnz = 0;
  for (int v = 0; v < num_free; ++v)
    nnz += static_cast<std::size_t>(dims[v]) * (dims[v] + 1) / 2 +
           static_cast<std::size_t>(dims[v]) * below_rows[v];
  out->matrix = cholmod_allocate_sparse(n, n, nnz, 1, 1, -1, CHOLMOD_REAL, cc);
  if (!out->matrix) return false;
  auto* pp = static_cast<int*>(out->matrix->p);
  auto* pi = static_cast<int*>(out->matrix->i);
  const std::vector<int>& low_begin = out->below_begin;
  int next = 0;
  for (int v : block_order)
    for (int q = 0; q < dims[v]; ++q) {
      pp[start[v] + q] = next;
      for (int r = q; r < dims[v]; ++r) pi[next++] = start[v] + r;
      for (int k = low_begin[v]; k < low_begin[v + 1]; ++k)
        for (int r = 0; r < below[k].rows; ++r) pi[next++] = below[k].row_start + r;
    }
  pp[n] = next;
  out->entry.resize(hessian_entries);
  MapHessianEntries(pattern, start, pair_begin, pair_prefix, pp, &out->entry);
  return true;
}

cholmod_factor* AnalyzeBlockwise(const BlockPattern& pattern, const std::vector<int>& block_order,
                                 const PermutedHessian& permuted, cholmod_common* cc) {
  const int num_free = pattern.num_blocks(), n = pattern.n;
  const std::vector<int>& dims = pattern.dims;
  std::vector<int> index_of(num_free), first_scalar(num_free);
  for (int k = 0, position = 0; k < num_free; ++k) {
    index_of[block_order[k]] = k;
    first_scalar[k] = position;
    position += dims[block_order[k]];
  }
  // L's block pattern column by column (in permuted order): the column's
  // own rows below the diagonal, merged with its children's (Liu's
  // column-merge); parent = the pattern's first row.
  std::vector<int> block_parent(num_free, -1), weight(num_free, 0), mark(num_free, -1);
  std::vector<int> child_head(num_free, -1), child_next(num_free, -1);
  std::vector<std::vector<int>> below_pattern(num_free);
  for (int k = 0; k < num_free; ++k) {
    std::vector<int>& rows = below_pattern[k];
    mark[k] = k;
    const int v = block_order[k];
    for (int e = permuted.below_begin[v]; e < permuted.below_begin[v + 1]; ++e) {
      const int i = index_of[permuted.below[e]];
      if (mark[i] != k) mark[i] = k, rows.push_back(i);
    }
    for (int c = child_head[k]; c >= 0; c = child_next[c]) {
      for (int i : below_pattern[c])
        if (mark[i] != k) mark[i] = k, rows.push_back(i);
      std::vector<int>().swap(below_pattern[c]);  // merged: not needed again
    }
    if (rows.empty()) continue;
    const int parent = *std::min_element(rows.begin(), rows.end());
    block_parent[k] = parent;
    child_next[k] = child_head[parent];
    child_head[parent] = k;
    for (int i : rows) weight[k] += dims[block_order[i]];
  }
  cholmod_factor* factor = cholmod_allocate_factor(n, cc);
  if (!factor) return nullptr;
  auto* column_count = static_cast<int*>(factor->ColCount);
  std::vector<int> parent(n);
  double flops = 0.0, lnz = 0.0;
  for (int k = 0; k < num_free; ++k) {
    const int d = dims[block_order[k]], first = first_scalar[k];
    for (int q = 0; q < d; ++q) {
      const int count = (d - q) + weight[k];
      column_count[first + q] = count;
      flops += static_cast<double>(count) * count;
      lnz += count;
      parent[first + q] = q + 1 < d              ? first + q + 1
                          : block_parent[k] >= 0 ? first_scalar[block_parent[k]]
                                                 : -1;
    }
  }
  // As cholmod_analyze: its flop and size counts, and a supernodal factor
  // when there are enough flops per entry.
  cc->fl = flops;
  cc->lnz = lnz;
  const bool supernodal =
      cc->supernodal > CHOLMOD_AUTO ||
      (cc->supernodal == CHOLMOD_AUTO && lnz > 0 && flops / lnz >= cc->supernodal_switch);
  if (supernodal) {
    cholmod_sparse* upper = cholmod_transpose(permuted.matrix, 0, cc);
    const bool ok = upper && cholmod_super_symbolic2(CHOLMOD_ANALYZE_FOR_CHOLESKY, upper,
                                                     permuted.matrix, parent.data(), factor, cc);
    if (upper) cholmod_free_sparse(&upper, cc);
    if (!ok) cholmod_free_factor(&factor, cc);
  }
  if (factor && std::getenv("OSLAM_SOLVER_CHECK_ANALYSIS"))
    CheckAgainstCholmod(factor, permuted.matrix, cc);
  return factor;
}

bool UseUpperTriangle(PermutedHessian* permuted, cholmod_common* cc) {
  const cholmod_sparse* lower = permuted->matrix;
  const int n = static_cast<int>(lower->ncol);
  const auto* lp = static_cast<const int*>(lower->p);
  const auto* li = static_cast<const int*>(lower->i);
  const int nnz = lp[n];
  cholmod_sparse* upper = cholmod_allocate_sparse(n, n, nnz, 1, 1, 1, CHOLMOD_REAL, cc);
  if (!upper) return false;
  auto* up = static_cast<int*>(upper->p);
  auto* ui = static_cast<int*>(upper->i);
  // Counting transpose: lower entry (i, j) becomes upper entry (j, i);
  // columns of the lower triangle taken in order leave each upper column's
  // rows sorted.
  std::vector<int> next(n + 1, 0);
  for (int k = 0; k < nnz; ++k) ++next[li[k] + 1];
  for (int c = 0; c < n; ++c) next[c + 1] += next[c];
  std::copy(next.begin(), next.end(), up);
  std::vector<int> moved(nnz);  // lower entry -> upper entry
  for (int j = 0; j < n; ++j)
    for (int k = lp[j]; k < lp[j + 1]; ++k) {
      const int at = next[li[k]]++;
      ui[at] = j;
      moved[k] = at;
    }
  for (int& e : permuted->entry) e = moved[e];
  cholmod_free_sparse(&permuted->matrix, cc);
  permuted->matrix = upper;
  return true;
}

}  // namespace oslam

// The Cholesky back end's matrix in its fill-reducing order, and CHOLMOD's
// symbolic analysis of it, both derived from the block pattern.
//
// The Hessian is assembled in the variables' order (upper triangle) and
// copied into `PermutedHessian::matrix`, the same matrix with the block
// order applied: CHOLMOD factors that with its natural ordering, which spares
// the transpose-and-permute copy every cholmod_factorize of an unpermuted
// matrix makes. The copy is a lower triangle for a supernodal factor and an
// upper one for a simplicial factor, the forms each factorisation reads
// without a transpose of its own. Every variable's entries
// stay together, so a pair of variables is one dense block in either
// matrix, and both the copy's map and the analysis work on blocks.
#pragma once

#include <vector>

#include "solver/block_pattern.h"

struct cholmod_common_struct;
struct cholmod_factor_struct;
struct cholmod_sparse_struct;

namespace oslam {

struct PermutedHessian {
  // Block order; lower triangle (upper after UseUpperTriangle); owned by the
  // user.
  cholmod_sparse_struct* matrix = nullptr;
  std::vector<int> entry;                // Hessian entry -> matrix entry
  std::vector<int> inverse_permutation;  // scalar column of delta -> position in matrix
  // The block pattern below the diagonal: per variable, the variables after
  // it in the block order that share a factor with it (compressed).
  std::vector<int> below_begin, below;
};

// `pattern` in `block_order` (block_order[k]: the k-th variable) into
// `out`. `hessian_entries`: the entry count of the Hessian as the Cholesky
// back end stores it (per column of delta, its block rows in the pattern's
// order, the diagonal block's upper triangle only). False when CHOLMOD
// cannot allocate the matrix.
bool BuildPermutedHessian(const BlockPattern& pattern, const std::vector<int>& block_order,
                          int hessian_entries, cholmod_common_struct* cc, PermutedHessian* out);

// Symbolic analysis of `permuted.matrix` in its own (natural) order; null
// when CHOLMOD fails. Every variable's entries form a dense block in it, so
// the elimination tree and column counts of L are those of the block
// pattern, expanded: the entries of a variable form a chain, and its last
// one's parent is the first entry of the variable's parent in the block
// tree. Computed on the blocks (a few thousand entries), this replaces
// cholmod_analyze's two transposes, elimination tree and column counts on
// the scalar matrix (~8 % of an O-SLAM proposal); the supernodal analysis
// is CHOLMOD's, on the same input, so the factor is the one
// cholmod_analyze would make. With OSLAM_SOLVER_CHECK_ANALYSIS set, every
// analysis is compared with cholmod_analyze's, and the outcome reported on
// stderr (a test runs it; a diagnostic if CHOLMOD's analysis ever changes).
cholmod_factor_struct* AnalyzeBlockwise(const BlockPattern& pattern,
                                        const std::vector<int>& block_order,
                                        const PermutedHessian& permuted, cholmod_common_struct* cc);

// Turns `permuted`'s lower triangle into the upper one (the same matrix,
// `entry` remapped): a simplicial factorisation reads the upper triangle,
// and given the lower one copies it transposed on every cholmod_factorize.
// False when CHOLMOD cannot allocate it (`permuted` unchanged).
bool UseUpperTriangle(PermutedHessian* permuted, cholmod_common_struct* cc);

}  // namespace oslam

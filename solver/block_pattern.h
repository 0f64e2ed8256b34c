// The block structure of the least-squares problem on a factor graph: which
// variables are unknowns ("free": not held fixed), where each one's entries
// sit in the step delta and each factor's rows in the whitened Jacobian J,
// which blocks of J^T J can be non-zero, and where each factor's
// contribution J_f^T J_f goes in them. Blocks are per variable, so a
// variable's entries always stay together.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "solver/factor_graph.h"

namespace oslam {

// The block pattern of the upper triangle of J^T J, block column by block
// column (free variables in key order), and its scalar layout.
struct BlockPattern {
  std::vector<int> dims;               // dimension per free variable
  std::vector<std::vector<int>> rows;  // per column b: block rows a <= b, sorted (b last)
  // Set by ComputeLayout:
  std::vector<std::vector<int>> prefix;  // per column: each block row's first scalar row
  std::vector<int> offsets;              // per free variable: its first entry in delta
  int n = 0;                             // entries of delta

  int num_blocks() const { return static_cast<int>(dims.size()); }
  // offsets, n and prefix from dims and rows (at least one variable).
  void ComputeLayout();
  // Whether every block of `other` (same dims) is in this pattern;
  // `exactly`: whether the patterns are equal.
  bool Covers(const std::vector<std::vector<int>>& other_rows, bool exactly) const;
  void Clear();
};

// One (variable a, variable b) block of J^T J that a factor contributes to,
// a <= b in column order (the block at rows a, column b of the upper
// triangle). 20 bytes, not 32: a set-up writes one per block of every
// factor, assembly reads them all back, per O-SLAM proposal.
struct BlockPair {
  int a_offset, b_offset;            // offsets in delta
  int row_prefix;                    // position of a's first row inside each column of b
  std::uint16_t a_column, b_column;  // columns in the factor's Jacobian
  std::uint8_t a_dim, b_dim;         // variable sizes
  bool diagonal;                     // a == b: only the upper triangle is stored
};

// Where a graph's unknowns and residuals sit, and where every factor's
// blocks go.
struct ProblemLayout {
  // What BlockPair can hold (larger factors or variables are refused).
  static constexpr int kMaxFactorColumns = 65535, kMaxVariableDim = 255;

  std::vector<int> free_index;      // per key: free variable index, or -1 when fixed
  std::vector<int> factor_row;      // per factor: its first row in J
  int m = 0;                        // rows of J
  std::vector<int> factor_columns;  // per factor: its Jacobian's column count
  int max_columns = 0;              // the largest of them
  std::vector<int> pair_begin;      // per factor (and one past the last): its range in pairs
  std::vector<BlockPair> pairs;

  int factor_rows(std::size_t f) const {
    return (f + 1 < factor_row.size() ? factor_row[f + 1] : m) - factor_row[f];
  }
};

// Builds a graph's layout and block pattern. Keeps its scratch across
// calls: a proposal's graph is much like the last one.
class BlockPatternBuilder {
 public:
  // layout->free_index and the free variables' dims. False with `why` when
  // there is none or one is too large for BlockPair.
  bool FindFreeVariables(const FactorGraph& graph, ProblemLayout* layout, std::string* why);
  // layout->factor_row and m, and rows() (the block pattern's rows for
  // the free variables found). False with `why` when a free variable is in
  // no factor.
  bool FindBlocks(const FactorGraph& graph, ProblemLayout* layout, std::string* why);
  // The rest of `layout`: every factor's Jacobian columns and block pairs,
  // placed in `pattern`, which must cover rows(). False with `why` when a
  // factor has too many Jacobian columns for BlockPair.
  bool PlaceFactorBlocks(const FactorGraph& graph, const BlockPattern& pattern,
                         ProblemLayout* layout, std::string* why);

  const std::vector<int>& dims() const { return dims_; }
  // Swapped with a pattern's rows when the pattern is rebuilt, so both keep
  // their capacity.
  std::vector<std::vector<int>>& rows() { return rows_; }

 private:
  std::vector<int> dims_;
  std::vector<std::vector<int>> rows_;
  // FindBlocks: the factors of each free variable (start offsets, factor
  // indices), a fill cursor per variable, and the last column each
  // variable was entered in. PlaceFactorBlocks: a cursor per column and a
  // factor's key columns.
  std::vector<int> variable_start_, variable_factors_, fill_, stamp_;
  std::vector<int> cursor_, key_columns_;
};

}  // namespace oslam

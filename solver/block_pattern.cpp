#include "solver/block_pattern.h"

#include <algorithm>

namespace oslam {

void BlockPattern::ComputeLayout() {
  const int num_free = num_blocks();
  offsets.assign(num_free, 0);
  for (int v = 1; v < num_free; ++v) offsets[v] = offsets[v - 1] + dims[v - 1];
  n = offsets.back() + dims.back();
  prefix.assign(num_free, {});
  for (int b = 0; b < num_free; ++b) {
    int next = 0;
    for (int a : rows[b]) {
      prefix[b].push_back(next);
      next += dims[a];
    }
  }
}

bool BlockPattern::Covers(const std::vector<std::vector<int>>& other_rows, bool exactly) const {
  bool covers = true;
  for (int v = 0; covers && v < num_blocks(); ++v)
    covers = exactly ? rows[v] == other_rows[v]
                     : std::includes(rows[v].begin(), rows[v].end(), other_rows[v].begin(),
                                     other_rows[v].end());
  return covers;
}

void BlockPattern::Clear() {
  dims.clear();
  rows.clear();
  prefix.clear();
}

bool BlockPatternBuilder::FindFreeVariables(const FactorGraph& graph, ProblemLayout* layout,
                                            std::string* why) {
  const int num_keys = graph.num_variables();
  layout->free_index.assign(num_keys, -1);
  dims_.clear();
  for (int key = 0; key < num_keys; ++key) {
    if (graph.IsFixed(key)) continue;
    layout->free_index[key] = static_cast<int>(dims_.size());
    dims_.push_back(graph.values().Dim(key));
    if (dims_.back() > ProblemLayout::kMaxVariableDim) {
      *why =
          "a variable has more than " + std::to_string(ProblemLayout::kMaxVariableDim) + " entries";
      return false;
    }
  }
  if (dims_.empty()) {
    *why = "the graph has no free variable";
    return false;
  }
  return true;
}

bool BlockPatternBuilder::FindBlocks(const FactorGraph& graph, ProblemLayout* layout,
                                     std::string* why) {
  const std::vector<int>& free_index = layout->free_index;
  const int num_free = static_cast<int>(dims_.size());
  const auto& factors = graph.factors();
  rows_.resize(num_free);
  layout->m = 0;
  layout->factor_row.resize(factors.size());
  // The factors of every free variable (compressed columns) ...
  std::vector<int>& start = variable_start_;
  start.assign(num_free + 1, 0);
  for (size_t f = 0; f < factors.size(); ++f) {
    layout->factor_row[f] = layout->m;
    layout->m += factors[f]->Dimension();
    for (int key : factors[f]->keys())
      if (free_index[key] >= 0) ++start[free_index[key] + 1];
  }
  for (int v = 0; v < num_free; ++v) start[v + 1] += start[v];
  variable_factors_.resize(start[num_free]);
  fill_.assign(start.begin(), start.end() - 1);
  for (size_t f = 0; f < factors.size(); ++f)
    for (int key : factors[f]->keys())
      if (free_index[key] >= 0) variable_factors_[fill_[free_index[key]]++] = static_cast<int>(f);
  // ... give each column's rows once each (an object's column would
  // otherwise collect its base point once per detection, all to be sorted
  // and dropped again).
  stamp_.assign(num_free, -1);
  for (int b = 0; b < num_free; ++b) {
    if (start[b] == start[b + 1]) {
      *why = "a free variable is constrained by no factor (add a prior or fix it)";
      return false;
    }
    std::vector<int>& column = rows_[b];
    column.clear();
    for (int k = start[b]; k < start[b + 1]; ++k)
      for (int key : factors[variable_factors_[k]]->keys()) {
        const int a = free_index[key];
        if (a >= 0 && a < b && stamp_[a] != b) {
          stamp_[a] = b;
          column.push_back(a);
        }
      }
    // Factors come in frame order, so an object's poses mostly arrive
    // sorted already; the diagonal goes last.
    if (!std::is_sorted(column.begin(), column.end())) std::sort(column.begin(), column.end());
    column.push_back(b);
  }
  return true;
}

bool BlockPatternBuilder::PlaceFactorBlocks(const FactorGraph& graph, const BlockPattern& pattern,
                                            ProblemLayout* layout, std::string* why) {
  const auto& factors = graph.factors();
  const std::vector<int>& free_index = layout->free_index;
  // Consecutive factors of one variable mostly meet the next row of its
  // column (an object's detections in frame order), so each column keeps a
  // cursor at its last hit.
  cursor_.assign(pattern.num_blocks(), 0);
  auto position_in_column = [&](int a, int b) {
    const std::vector<int>& col_rows = pattern.rows[b];
    const int size = static_cast<int>(col_rows.size());
    // A column's rows are sorted and end with its own variable.
    if (a == b) return size - 1;
    int& at = cursor_[b];
    if (col_rows[at] == a) return at;
    if (at + 1 < size && col_rows[at + 1] == a) return ++at;
    // The row just above the diagonal (an object's base in its size column).
    if (size >= 2 && col_rows[size - 2] == a) return size - 2;
    at = static_cast<int>(std::lower_bound(col_rows.begin(), col_rows.end(), a) - col_rows.begin());
    return at;
  };
  std::vector<BlockPair>& pairs = layout->pairs;
  pairs.clear();
  layout->pair_begin.assign(factors.size() + 1, 0);
  layout->factor_columns.resize(factors.size());
  layout->max_columns = 0;
  for (size_t f = 0; f < factors.size(); ++f) {
    layout->pair_begin[f] = static_cast<int>(pairs.size());
    const auto& keys = factors[f]->keys();
    int total = 0;
    key_columns_.clear();
    for (int key : keys) {
      key_columns_.push_back(total);
      total += graph.values().Dim(key);
    }
    if (total > ProblemLayout::kMaxFactorColumns) {
      *why = "a " + factors[f]->Name() + " factor has more than " +
             std::to_string(ProblemLayout::kMaxFactorColumns) + " Jacobian columns";
      return false;
    }
    layout->factor_columns[f] = total;
    layout->max_columns = std::max(layout->max_columns, total);
    for (size_t i = 0; i < keys.size(); ++i) {
      for (size_t j = 0; j < keys.size(); ++j) {
        const int a = free_index[keys[i]], b = free_index[keys[j]];
        if (a < 0 || b < 0 || a > b || (a == b && i > j)) continue;
        pairs.push_back({pattern.offsets[a], pattern.offsets[b],
                         pattern.prefix[b][position_in_column(a, b)],
                         static_cast<std::uint16_t>(key_columns_[i]),
                         static_cast<std::uint16_t>(key_columns_[j]),
                         static_cast<std::uint8_t>(pattern.dims[a]),
                         static_cast<std::uint8_t>(pattern.dims[b]), a == b});
      }
    }
  }
  layout->pair_begin[factors.size()] = static_cast<int>(pairs.size());
  return true;
}

}  // namespace oslam

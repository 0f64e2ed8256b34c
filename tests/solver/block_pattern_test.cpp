#include "solver/block_pattern.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/solver/linear_factor.h"

namespace oslam {
namespace {

using testing::LinearFactor;

// A factor of the given keys (dimensions from the graph) and rows.
void AddFactor(FactorGraph* graph, const std::vector<int>& keys, int rows = 1) {
  int columns = 0;
  for (int key : keys) columns += graph->values().Dim(key);
  graph->Emplace<LinearFactor>(keys, Eigen::MatrixXd::Ones(rows, columns),
                               Eigen::VectorXd::Zero(rows), 1.0);
}

// Poses 0 (fixed), 1, 2 (3 entries each) in a chain, and an object (base
// point key 3, size key 4) seen from poses 0 and 2.
FactorGraph ChainWithObject() {
  FactorGraph graph;
  for (int i = 0; i < 3; ++i) graph.AddPose(i, 0.0, 0.0, i == 0);
  graph.AddVariable(Eigen::Vector3d::Zero());
  graph.AddVariable(Eigen::Vector2d::Ones());
  AddFactor(&graph, {0, 1}, 3);
  AddFactor(&graph, {1, 2}, 3);
  AddFactor(&graph, {0, 3, 4}, 4);
  AddFactor(&graph, {2, 3, 4}, 4);
  AddFactor(&graph, {3}, 3);
  AddFactor(&graph, {4}, 2);
  return graph;
}

TEST(BlockPatternTest, FindsTheFreeVariablesFactorRowsAndUpperBlocks) {
  const FactorGraph graph = ChainWithObject();
  BlockPatternBuilder builder;
  ProblemLayout layout;
  std::string why;
  ASSERT_TRUE(builder.FindFreeVariables(graph, &layout, &why)) << why;
  EXPECT_EQ(layout.free_index, (std::vector<int>{-1, 0, 1, 2, 3}));
  EXPECT_EQ(builder.dims(), (std::vector<int>{3, 3, 3, 2}));
  ASSERT_TRUE(builder.FindBlocks(graph, &layout, &why)) << why;
  EXPECT_EQ(layout.factor_row, (std::vector<int>{0, 3, 6, 10, 14, 17}));
  EXPECT_EQ(layout.m, 19);
  EXPECT_EQ(layout.factor_rows(2), 4);
  EXPECT_EQ(layout.factor_rows(5), 2);
  // Per column (free variable): the rows above and on the diagonal. The
  // fixed pose 0 is in no block; pose 1 (free 0) meets pose 2 (free 1),
  // which meets the object.
  const std::vector<std::vector<int>> expected = {{0}, {0, 1}, {1, 2}, {1, 2, 3}};
  EXPECT_EQ(builder.rows(), expected);
}

TEST(BlockPatternTest, LayoutPlacesEveryFactorsBlocksInThePattern) {
  const FactorGraph graph = ChainWithObject();
  BlockPatternBuilder builder;
  ProblemLayout layout;
  std::string why;
  ASSERT_TRUE(builder.FindFreeVariables(graph, &layout, &why));
  ASSERT_TRUE(builder.FindBlocks(graph, &layout, &why));
  BlockPattern pattern;
  pattern.dims = builder.dims();
  pattern.rows = builder.rows();
  pattern.ComputeLayout();
  EXPECT_EQ(pattern.offsets, (std::vector<int>{0, 3, 6, 9}));
  EXPECT_EQ(pattern.n, 11);
  // Column 3 (the size): rows 1 (3 entries), 2 (3), 3 (2).
  EXPECT_EQ(pattern.prefix[3], (std::vector<int>{0, 3, 6}));
  ASSERT_TRUE(builder.PlaceFactorBlocks(graph, pattern, &layout, &why)) << why;
  EXPECT_EQ(layout.factor_columns, (std::vector<int>{6, 6, 8, 8, 3, 2}));
  EXPECT_EQ(layout.max_columns, 8);
  // Factor 0 (fixed pose 0, pose 1): only pose 1's diagonal block.
  ASSERT_EQ(layout.pair_begin[1] - layout.pair_begin[0], 1);
  const BlockPair& own = layout.pairs[layout.pair_begin[0]];
  EXPECT_TRUE(own.diagonal);
  EXPECT_EQ(own.a_column, 3);  // pose 1's columns in the factor's Jacobian
  EXPECT_EQ(own.a_offset, 0);
  // Factor 3 (pose 2, base, size): the 6 blocks of its upper triangle.
  ASSERT_EQ(layout.pair_begin[4] - layout.pair_begin[3], 6);
  // The (pose 2, size) block: rows of pose 2 in column 3, after nothing.
  bool found = false;
  for (int k = layout.pair_begin[3]; k < layout.pair_begin[4]; ++k) {
    const BlockPair& pair = layout.pairs[k];
    if (pair.a_offset == 3 && pair.b_offset == 9) {
      found = true;
      EXPECT_FALSE(pair.diagonal);
      EXPECT_EQ(pair.row_prefix, 0);
      EXPECT_EQ(pair.a_column, 0);
      EXPECT_EQ(pair.b_column, 6);
      EXPECT_EQ(pair.a_dim, 3);
      EXPECT_EQ(pair.b_dim, 2);
    }
    if (pair.a_offset == 6 && pair.b_offset == 9) {
      EXPECT_EQ(pair.row_prefix, 3);  // base, size
    }
  }
  EXPECT_TRUE(found);
  EXPECT_EQ(layout.pair_begin.back(), static_cast<int>(layout.pairs.size()));
}

TEST(BlockPatternTest, CoversSubPatternsOrOnlyItselfExactly) {
  BlockPattern pattern;
  pattern.dims = {1, 1, 1};
  pattern.rows = {{0}, {0, 1}, {0, 1, 2}};
  const std::vector<std::vector<int>> fewer = {{0}, {1}, {0, 2}};
  EXPECT_TRUE(pattern.Covers(fewer, false));
  EXPECT_FALSE(pattern.Covers(fewer, true));
  EXPECT_TRUE(pattern.Covers(pattern.rows, true));
  const std::vector<std::vector<int>> other = {{0}, {0, 1}, {1, 2}};
  EXPECT_TRUE(pattern.Covers(other, false));
  const std::vector<std::vector<int>> outside = {{0}, {0, 1}, {0, 1, 2}};
  BlockPattern sparse = pattern;
  sparse.rows = {{0}, {1}, {2}};
  EXPECT_FALSE(sparse.Covers(outside, false));
}

TEST(BlockPatternTest, RefusesGraphsItCannotLayOut) {
  BlockPatternBuilder builder;
  ProblemLayout layout;
  std::string why;

  FactorGraph all_fixed;
  all_fixed.AddPose(0, 0, 0, /*fixed=*/true);
  EXPECT_FALSE(builder.FindFreeVariables(all_fixed, &layout, &why));
  EXPECT_NE(why.find("no free variable"), std::string::npos) << why;

  FactorGraph unconstrained;
  unconstrained.AddVariable(Eigen::VectorXd::Zero(1));
  unconstrained.AddVariable(Eigen::VectorXd::Zero(1));
  AddFactor(&unconstrained, {0});
  ASSERT_TRUE(builder.FindFreeVariables(unconstrained, &layout, &why));
  EXPECT_FALSE(builder.FindBlocks(unconstrained, &layout, &why));
  EXPECT_NE(why.find("constrained by no factor"), std::string::npos) << why;

  FactorGraph wide;
  wide.AddVariable(Eigen::VectorXd::Zero(ProblemLayout::kMaxVariableDim + 1));
  EXPECT_FALSE(builder.FindFreeVariables(wide, &layout, &why));
  EXPECT_NE(why.find("more than 255 entries"), std::string::npos) << why;

  // 258 variables of 255 entries in one factor: more Jacobian columns than
  // a BlockPair can address.
  FactorGraph many;
  std::vector<int> keys;
  for (int i = 0; i < 258; ++i)
    keys.push_back(many.AddVariable(Eigen::VectorXd::Zero(ProblemLayout::kMaxVariableDim)));
  many.Emplace<LinearFactor>(keys, Eigen::MatrixXd::Zero(1, 258 * 255), Eigen::VectorXd::Zero(1),
                             1.0);
  ASSERT_TRUE(builder.FindFreeVariables(many, &layout, &why));
  ASSERT_TRUE(builder.FindBlocks(many, &layout, &why));
  BlockPattern pattern;
  pattern.dims = builder.dims();
  pattern.rows = builder.rows();
  pattern.ComputeLayout();
  EXPECT_FALSE(builder.PlaceFactorBlocks(many, pattern, &layout, &why));
  EXPECT_NE(why.find("linear factor has more than 65535 Jacobian columns"), std::string::npos)
      << why;
}

}  // namespace
}  // namespace oslam

#include "solver/factor_graph.h"

#include <cstdint>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "slam/factors.h"
#include "solver/sparse_solver.h"
#include "tests/solver/linear_factor.h"

namespace oslam {
namespace {

using testing::LinearFactor;

// Counts live instances, to see the graph destroy what it owns.
struct CountedFactor : LinearFactor {
  static int alive;
  explicit CountedFactor(int key)
      : LinearFactor({key}, Eigen::MatrixXd::Identity(1, 1), Eigen::VectorXd::Zero(1), 1.0) {
    ++alive;
  }
  ~CountedFactor() override { --alive; }
};
int CountedFactor::alive = 0;

// Bigger than an arena block (64 kB): gets a block of its own.
struct HugeFactor : CountedFactor {
  using CountedFactor::CountedFactor;
  char payload[100 * 1024] = {};
};

TEST(FactorGraphTest, VariablesKeepTheirValuesAndFixedFlags) {
  FactorGraph graph;
  const int pose = graph.AddPose(1.0, 2.0, 0.5, /*fixed=*/true);
  const int point = graph.AddVariable(Eigen::Vector3d(4.0, 5.0, 6.0));
  EXPECT_EQ(graph.num_variables(), 2);
  EXPECT_TRUE(graph.IsFixed(pose));
  EXPECT_FALSE(graph.IsFixed(point));
  EXPECT_EQ(graph.values().AngleIndex(pose), 2);
  graph.SetFixed(point, true);
  EXPECT_TRUE(graph.IsFixed(point));
  graph.mutable_values().MutableData(point)[0] = 9.0;
  EXPECT_EQ(graph.values().Get(point)[0], 9.0);
}

TEST(FactorGraphTest, FactorsOnUnknownVariablesAreRejectedNamingTheKey) {
  FactorGraph graph;
  const int x = graph.AddVariable(Eigen::VectorXd::Zero(1));
  EXPECT_THROW(graph.Add(std::unique_ptr<Factor>()), Error);
  try {
    graph.Emplace<LinearFactor>(std::vector<int>{x, 3}, Eigen::MatrixXd::Ones(1, 2),
                                Eigen::VectorXd::Zero(1), 1.0);
    FAIL() << "accepted an unknown key";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("linear factor refers to unknown variable 3"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(
      graph.Add(std::make_unique<LinearFactor>(std::vector<int>{-1}, Eigen::MatrixXd::Ones(1, 1),
                                               Eigen::VectorXd::Zero(1), 1.0)),
      Error);
  EXPECT_TRUE(graph.factors().empty());
  // A rejected factor is destroyed, whether made in the arena or not.
  CountedFactor::alive = 0;
  EXPECT_THROW(graph.Emplace<CountedFactor>(5), Error);
  EXPECT_THROW(graph.Add(std::make_unique<CountedFactor>(5)), Error);
  EXPECT_EQ(CountedFactor::alive, 0);
}

TEST(FactorGraphTest, ArenaFactorsAreAlignedAndDestroyedWithTheGraph) {
  CountedFactor::alive = 0;
  {
    FactorGraph graph;
    const int x = graph.AddVariable(Eigen::VectorXd::Zero(1));
    const Factor* first = graph.Emplace<CountedFactor>(x);
    const Factor* huge = graph.Emplace<HugeFactor>(x);
    const Factor* after = graph.Emplace<CountedFactor>(x);
    graph.Add(std::make_unique<CountedFactor>(x));  // from the heap
    EXPECT_EQ(CountedFactor::alive, 4);
    for (const Factor* factor : {first, huge, after})
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(factor) % alignof(HugeFactor), 0u);
    ASSERT_EQ(graph.factors().size(), 4u);
    EXPECT_EQ(graph.factors()[0].get(), first);
    EXPECT_EQ(graph.factors()[1].get(), huge);
    EXPECT_EQ(graph.factors()[2].get(), after);
    EXPECT_TRUE(graph.factors()[0].get_deleter().in_arena);
    EXPECT_FALSE(graph.factors()[3].get_deleter().in_arena);
  }
  EXPECT_EQ(CountedFactor::alive, 0);
}

// Factors made by Emplace live in the graph's arena (64 kB blocks): a
// graph spanning many blocks, moved to another variable, keeps every factor
// intact and solvable, next to a heap factor handed over by Add.
TEST(FactorGraphTest, ArenaFactorsSurviveManyBlocksAndAMove) {
  constexpr int kPoses = 3000;  // ~3,000 odometry factors: several blocks
  FactorGraph built;
  for (int i = 0; i < kPoses; ++i) built.AddPose(0.1 * i, 0.0, 0.0, i == 0);
  const OdometryIncrement step{0.1, 0.0};
  for (int i = 1; i < kPoses; ++i) {
    const Factor* factor = built.Emplace<OdometryFactor>(i - 1, i, step, MotionNoiseOptions());
    ASSERT_EQ(reinterpret_cast<std::uintptr_t>(factor) % alignof(OdometryFactor), 0u);
  }
  built.Add(MakeLocationPrior(built.AddVariable(Eigen::Vector3d(1, 2, 0)), Eigen::Vector3d::Zero(),
                              Eigen::Vector3d::Ones()));
  FactorGraph graph = std::move(built);
  ASSERT_EQ(graph.factors().size(), static_cast<size_t>(kPoses));
  for (int i = 1; i < kPoses; ++i) {
    EXPECT_EQ(graph.factors()[i - 1]->keys()[0], i - 1);
    EXPECT_EQ(graph.factors()[i - 1]->keys()[1], i);
  }
  graph.mutable_values().MutableData(kPoses - 1)[1] += 0.5;  // off the odometry
  const SolveResult result = SparseSolver().Solve(&graph);
  ASSERT_EQ(result.summary.termination, TerminationType::kConverged) << result.summary.message;
  EXPECT_LT(result.summary.final_cost, 1e-6);  // to the solver's tolerances
  EXPECT_NEAR(graph.values().Data(kPoses - 1)[0], 0.1 * (kPoses - 1), 1e-4);
}

TEST(FactorKeysTest, KeepsFourKeysInlineAndMoreOnTheHeap) {
  const FactorKeys few{3, 1, 2};
  EXPECT_EQ(few.size(), 3u);
  EXPECT_EQ(few[0], 3);
  EXPECT_EQ(few[2], 2);
  const std::vector<int> many_keys = {0, 1, 2, 3, 4, 5};
  const FactorKeys many(many_keys);
  EXPECT_EQ(std::vector<int>(many.begin(), many.end()), many_keys);
}

}  // namespace
}  // namespace oslam

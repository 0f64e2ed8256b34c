#include "solver/fill_reducing_ordering.h"

#include <algorithm>
#include <cstdlib>
#include <numeric>
#include <string>
#include <vector>

#include <cholmod.h>
#include <gtest/gtest.h>

#include "tests/solver/cholmod_workspace.h"

namespace oslam {
namespace {

// An object (variable 0, 3 entries) seen from `poses` poses (3 entries
// each) that form a chain: the object's block degree is far above the
// median (2).
BlockPattern ObjectSeenFromAChain(int poses) {
  BlockPattern pattern;
  pattern.dims.assign(poses + 1, 3);
  pattern.rows = {{0}, {0, 1}};
  for (int b = 2; b <= poses; ++b) pattern.rows.push_back({0, b - 1, b});
  pattern.ComputeLayout();
  return pattern;
}

bool IsPermutation(std::vector<int> order, int size) {
  std::sort(order.begin(), order.end());
  std::vector<int> identity(size);
  std::iota(identity.begin(), identity.end(), 0);
  return order == identity;
}

// The number of orderings compared (OSLAM_SOLVER_TRACE prints one line per
// candidate analysed) by one Choose.
int ComparedCandidates(FillReducingOrdering* ordering, const BlockPattern& pattern,
                       bool independent_of_history, cholmod_common* cc) {
  setenv("OSLAM_SOLVER_TRACE", "1", 1);
  ::testing::internal::CaptureStderr();
  std::vector<int> order;
  EXPECT_TRUE(
      ordering->Choose(pattern, OrderingType::kAutomatic, independent_of_history, cc, &order));
  const std::string report = ::testing::internal::GetCapturedStderr();
  unsetenv("OSLAM_SOLVER_TRACE");
  int lines = 0;
  for (size_t at = report.find("ordering "); at != std::string::npos;
       at = report.find("ordering ", at + 1))
    ++lines;
  return lines;
}

TEST(FillReducingOrderingTest, EveryKindGivesAPermutationOfTheVariables) {
  testing::CholmodWorkspace cholmod;
  const BlockPattern pattern = ObjectSeenFromAChain(40);
  for (const OrderingType kind : {OrderingType::kAutomatic, OrderingType::kAmd,
                                  OrderingType::kHighDegreeLast, OrderingType::kMetis}) {
    FillReducingOrdering ordering;
    std::vector<int> order;
    ASSERT_TRUE(ordering.Choose(pattern, kind, false, &cholmod.cc, &order));
    EXPECT_TRUE(IsPermutation(order, pattern.num_blocks())) << static_cast<int>(kind);
    if (kind == OrderingType::kAutomatic)
      EXPECT_NE(ordering.used(), OrderingType::kAutomatic);
    else
      EXPECT_EQ(ordering.used(), kind);
  }
}

TEST(FillReducingOrderingTest, HighDegreeLastEliminatesTheObjectLast) {
  testing::CholmodWorkspace cholmod;
  const BlockPattern pattern = ObjectSeenFromAChain(40);
  FillReducingOrdering ordering;
  std::vector<int> order;
  ASSERT_TRUE(ordering.Choose(pattern, OrderingType::kHighDegreeLast, false, &cholmod.cc, &order));
  EXPECT_EQ(order.back(), 0);
}

TEST(FillReducingOrderingTest, MetisIsACandidateOnlyForBigProblems) {
  testing::CholmodWorkspace cholmod;
  FillReducingOrdering ordering;
  std::vector<int> order;
  for (int poses : {40, 100, 400}) {
    ASSERT_TRUE(ordering.Choose(ObjectSeenFromAChain(poses), OrderingType::kAutomatic, true,
                                &cholmod.cc, &order));
    EXPECT_NE(ordering.used(), OrderingType::kMetis);
  }
  // Below kMetisMinBlocks, AMD and CAMD; from it on, METIS too.
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(1998), true, &cholmod.cc), 2);
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(1999), true, &cholmod.cc), 3);
}

TEST(FillReducingOrderingTest, ASimilarProblemReusesTheLastComparisonsWinner) {
  testing::CholmodWorkspace cholmod;
  FillReducingOrdering ordering;
  // AMD and CAMD (the object's degree is high) are compared.
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(40), false, &cholmod.cc), 2);
  const OrderingType winner = ordering.used();
  // A few variables more: the winner alone.
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(46), false, &cholmod.cc), 1);
  EXPECT_EQ(ordering.used(), winner);
  // ... unless every problem is to be compared afresh,
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(46), true, &cholmod.cc), 2);
  // ... or the problem has drifted further from the last compared one,
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(30), false, &cholmod.cc), 2);
  // ... or the comparison was forgotten.
  ordering.Forget();
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(31), false, &cholmod.cc), 2);
  // A big problem is similar within 2 % of its size (AMD, CAMD and METIS compared).
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(5000), false, &cholmod.cc), 3);
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(5090), false, &cholmod.cc), 1);
  EXPECT_EQ(ComparedCandidates(&ordering, ObjectSeenFromAChain(5200), false, &cholmod.cc), 3);
}

}  // namespace
}  // namespace oslam

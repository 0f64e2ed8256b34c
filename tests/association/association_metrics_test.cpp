// Measures of an association and a trajectory against a reference.
#include "association/association_metrics.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/error.h"

namespace oslam {
namespace {

TEST(AssociationMetricsTest, PairwiseAgreementCountsPairs) {
  // truth {0,1,2} {3}; estimate {0,1} {2,3}: pairs (6): same in truth 3,
  // same in estimate 2, same in both 1 ((0,1)); disagreements (0,2) (1,2) (2,3).
  const PairwiseAgreement a = ComparePairwise({5, 5, 7, 7}, {1, 1, 1, 2});
  EXPECT_EQ(a.pairs, 6);
  EXPECT_EQ(a.same_truth, 3);
  EXPECT_EQ(a.same_estimate, 2);
  EXPECT_EQ(a.same_both, 1);
  EXPECT_DOUBLE_EQ(a.agreement, 0.5);
  EXPECT_DOUBLE_EQ(a.precision, 0.5);
  EXPECT_DOUBLE_EQ(a.recall, 1.0 / 3.0);
  // -1 is a landmark of its own, never "same" as another -1.
  const PairwiseAgreement b = ComparePairwise({-1, -1, 3}, {-1, -1, 4});
  EXPECT_EQ(b.same_estimate, 0);
  EXPECT_DOUBLE_EQ(b.agreement, 1.0);
  EXPECT_THROW(ComparePairwise({1}, {1, 2}), Error);
}

TEST(AssociationMetricsTest, IdsNeedNotMatchAndEmptyAgrees) {
  // The same partition under other ids agrees fully.
  const PairwiseAgreement a = ComparePairwise({9, 9, 4, 4, 4}, {0, 0, 1, 1, 1});
  EXPECT_EQ(a.same_both, 4);
  EXPECT_DOUBLE_EQ(a.agreement, 1.0);
  EXPECT_DOUBLE_EQ(a.precision, 1.0);
  EXPECT_DOUBLE_EQ(a.recall, 1.0);
  // Everything merged against everything apart: no pair agrees.
  const PairwiseAgreement b = ComparePairwise({0, 0, 0}, {0, 1, 2});
  EXPECT_DOUBLE_EQ(b.agreement, 0.0);
  EXPECT_DOUBLE_EQ(b.precision, 0.0);
  EXPECT_DOUBLE_EQ(b.recall, 1.0);  // no "same" pair in the truth to miss
  const PairwiseAgreement none = ComparePairwise({}, {});
  EXPECT_EQ(none.pairs, 0);
  EXPECT_DOUBLE_EQ(none.agreement, 1.0);
}

TEST(AssociationMetricsTest, TrajectoryRmseIgnoresHeadings) {
  const std::vector<Pose2> a{{0, 0, 0}, {1, 0, 0.5}, {2, 0, 1.0}};
  const std::vector<Pose2> b{{3, 4, 0}, {1, 0, -0.5}, {2, 0, 1.0}};
  // Errors 5, 0, 0 m: sqrt(25 / 3).
  EXPECT_DOUBLE_EQ(TrajectoryRmse(a, b), std::sqrt(25.0 / 3.0));
  EXPECT_DOUBLE_EQ(TrajectoryRmse(a, a), 0.0);
  EXPECT_THROW(TrajectoryRmse(a, {a[0]}), Error);
  EXPECT_THROW(TrajectoryRmse({}, {}), Error);
}

// A rotated and shifted copy aligns to nothing; noise on top of it leaves
// the noise's RMS.
TEST(AssociationMetricsTest, AlignedTrajectoryRmseRemovesARigidMotion) {
  const std::vector<Pose2> truth{{0, 0, 0}, {10, 0, 0}, {10, 5, 1}, {0, 8, 2}};
  std::vector<Pose2> moved, noisy;
  const double c = std::cos(0.3), s = std::sin(0.3);
  const double offsets[4][2] = {{0.1, 0}, {-0.1, 0}, {0, 0.1}, {0, -0.1}};  // zero mean, RMS 0.1
  for (size_t i = 0; i < truth.size(); ++i) {
    const Pose2& p = truth[i];
    moved.push_back({c * p.x - s * p.y + 4, s * p.x + c * p.y - 7, p.theta + 0.3});
    noisy.push_back({p.x + offsets[i][0], p.y + offsets[i][1], p.theta});
  }
  EXPECT_GT(TrajectoryRmse(moved, truth), 5.0);
  EXPECT_NEAR(AlignedTrajectoryRmse(moved, truth), 0.0, 1e-9);
  EXPECT_LE(AlignedTrajectoryRmse(noisy, truth), TrajectoryRmse(noisy, truth) + 1e-12);
  EXPECT_NEAR(AlignedTrajectoryRmse(noisy, truth), 0.1, 0.02);
  EXPECT_THROW(AlignedTrajectoryRmse(truth, {truth[0]}), Error);
}

}  // namespace
}  // namespace oslam

// Rigid planar alignment: the least-squares fit recovers a known transform,
// a part of a transform interpolates it, and RANSAC finds the transform and
// its correspondences among outliers (by their count, or weighted by fit in a
// layout that repeats itself), or declines when there is none.
#include "association/rigid_alignment.h"

#include <cmath>
#include <optional>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace oslam {
namespace {

Rigid2 MakeRigid(double angle, double tx, double ty) {
  Rigid2 rigid;
  rigid.angle = angle;
  rigid.t = Eigen::Vector2d(tx, ty);
  return rigid;
}

// Points in a 100 m x 100 m square about the origin, at least `spacing_m`
// apart.
std::vector<Eigen::Vector2d> Scatter(size_t count, double spacing_m, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uniform(-50.0, 50.0);
  std::vector<Eigen::Vector2d> points;
  while (points.size() < count) {
    const Eigen::Vector2d p(uniform(rng), uniform(rng));
    bool clear = true;
    for (const auto& q : points) clear = clear && (q - p).norm() > spacing_m;
    if (clear) points.push_back(p);
  }
  return points;
}

TEST(RigidAlignmentTest, FitRigidRecoversAKnownTransform) {
  std::mt19937_64 rng(1);
  const std::vector<Eigen::Vector2d> from = Scatter(6, 1.0, rng);
  const Rigid2 truth = MakeRigid(0.3, 4.0, -2.0);
  std::vector<Eigen::Vector2d> to;
  for (const auto& p : from) to.push_back(truth(p));
  const Rigid2 fitted = FitRigid(from, to);
  EXPECT_NEAR(fitted.angle, 0.3, 1e-12);
  EXPECT_NEAR(fitted.t.x(), 4.0, 1e-10);
  EXPECT_NEAR(fitted.t.y(), -2.0, 1e-10);
  for (size_t i = 0; i < from.size(); ++i) EXPECT_LT((fitted(from[i]) - to[i]).norm(), 1e-10);
}

// With noise the fit is the least-squares one: no rotation or shift of it
// lowers the summed squared distance.
TEST(RigidAlignmentTest, FitRigidMinimisesTheSquaredDistances) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> noise(0.0, 0.3);
  const std::vector<Eigen::Vector2d> from = Scatter(20, 1.0, rng);
  const Rigid2 truth = MakeRigid(-1.2, -30.0, 12.0);
  std::vector<Eigen::Vector2d> to;
  for (const auto& p : from) to.push_back(truth(p) + Eigen::Vector2d(noise(rng), noise(rng)));
  const Rigid2 fitted = FitRigid(from, to);
  auto cost = [&](const Rigid2& r) {
    double sum = 0;
    for (size_t i = 0; i < from.size(); ++i) sum += (r(from[i]) - to[i]).squaredNorm();
    return sum;
  };
  EXPECT_NEAR(fitted.angle, -1.2, 0.02);
  for (const Rigid2& nudge : {MakeRigid(1e-3, 0, 0), MakeRigid(-1e-3, 0, 0), MakeRigid(0, 0.01, 0),
                              MakeRigid(0, 0, -0.01)}) {
    Rigid2 other = fitted;
    other.angle += nudge.angle;
    other.t += nudge.t;
    EXPECT_GT(cost(other), cost(fitted));
  }
}

TEST(RigidAlignmentTest, PartOfInterpolatesAboutThePivot) {
  const Rigid2 rigid = MakeRigid(0.4, 10.0, -6.0);
  const Eigen::Vector2d pivot(3.0, 7.0), x(-5.0, 2.0);
  const Rigid2 none = PartOf(rigid, pivot, 0.0);
  EXPECT_LT((none(x) - x).norm(), 1e-12);
  const Rigid2 all = PartOf(rigid, pivot, 1.0);
  EXPECT_NEAR(all.angle, rigid.angle, 1e-15);
  EXPECT_LT((all(x) - rigid(x)).norm(), 1e-12);
  const Rigid2 half = PartOf(rigid, pivot, 0.5);
  EXPECT_NEAR(half.angle, 0.2, 1e-15);
  // The pivot moves half-way to where the whole transform takes it.
  EXPECT_LT((half(pivot) - 0.5 * (pivot + rigid(pivot))).norm(), 1e-12);
}

// Old landmarks, and recent ones: 12 of the old seen again through a drifted
// frame (rotated and shifted, with noise) and 8 seen only lately (6 m or
// more from every old one once the drift is undone).
struct Scene {
  std::vector<Eigen::Vector2d> old, recent;
  std::vector<std::pair<int, int>> truth;  // (recent, old), by ascending old
};

Scene MakeScene(const Rigid2& drift, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.2);
  Scene scene;
  const std::vector<Eigen::Vector2d> points = Scatter(38, 6.0, rng);
  scene.old.assign(points.begin(), points.begin() + 30);
  const Eigen::Rotation2Dd back(-drift.angle);
  for (int o = 0; o < 12; ++o) {
    const Eigen::Vector2d seen = back * (scene.old[o] - drift.t);  // drift(seen) = old
    scene.truth.push_back({static_cast<int>(scene.recent.size()), o});
    scene.recent.push_back(seen + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  for (size_t i = 30; i < points.size(); ++i) scene.recent.push_back(back * (points[i] - drift.t));
  return scene;
}

TEST(RigidAlignmentTest, RansacFindsTheDriftAmongOutliers) {
  const Rigid2 drift = MakeRigid(0.1, 8.0, -5.0);
  const Scene scene = MakeScene(drift, 3);
  RigidRansacOptions options;
  options.search_m = 20;
  options.inlier_m = 1.5;
  options.max_rotation_rad = 0.5;
  options.min_inliers = 8;
  std::mt19937_64 rng(4);
  const std::optional<RigidMatch> match = MatchRigidly(scene.recent, scene.old, options, rng);
  ASSERT_TRUE(match.has_value());
  EXPECT_NEAR(match->rigid.angle, drift.angle, 0.01);
  EXPECT_LT((match->rigid.t - drift.t).norm(), 0.5);
  EXPECT_EQ(match->pairs, scene.truth);
}

// A layout that repeats itself: the recent points are 6 old ones seen again
// (5 cm noise) and 12 more that look like another old group a block (40 m)
// away (1.2 m off each).
struct RepeatingLayout {
  std::vector<Eigen::Vector2d> old, recent;
  Eigen::Vector2d block = Eigen::Vector2d(40.0, 0.0);
};

RepeatingLayout MakeRepeatingLayout() {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> close(0.0, 0.05), loose(0.0, 1.2);
  const std::vector<Eigen::Vector2d> points = Scatter(18, 8.0, rng);
  RepeatingLayout layout;
  for (int i = 0; i < 6; ++i) {
    layout.old.push_back(points[i]);
    layout.recent.push_back(points[i] + Eigen::Vector2d(close(rng), close(rng)));
  }
  for (int i = 6; i < 18; ++i) {
    layout.old.push_back(points[i] + layout.block);
    layout.recent.push_back(points[i] + Eigen::Vector2d(loose(rng), loose(rng)));
  }
  return layout;
}

// The plain count takes the 40 m shift; the pairs weighted by fit take the
// 6 close ones.
TEST(RigidAlignmentTest, TheScoreWeightedByFitPrefersFewCloseInliersToManyLooseOnes) {
  const RepeatingLayout layout = MakeRepeatingLayout();
  const std::vector<Eigen::Vector2d>&old = layout.old, &recent = layout.recent;
  const Eigen::Vector2d& block = layout.block;
  RigidRansacOptions options;
  options.search_m = 60;
  options.inlier_m = 2.5;
  options.min_inliers = 5;
  std::mt19937_64 count_rng(4), both_rng(4);
  const std::optional<RigidMatch> by_count = MatchRigidly(recent, old, options, count_rng);
  ASSERT_TRUE(by_count.has_value());
  EXPECT_GT(by_count->pairs.size(), 6u);
  EXPECT_NEAR(by_count->rigid.t.x(), block.x(), 1.0);
  EXPECT_DOUBLE_EQ(by_count->score, static_cast<double>(by_count->pairs.size()));
  // One run from the same samples gives both: the same transform by count,
  // its pairs weighed by fit a loose match, and the close one by score.
  options.score_std_m = 0.8;
  const RigidMatches both = MatchRigidlyBothWays(recent, old, options, both_rng);
  ASSERT_TRUE(both.most_pairs.has_value());
  ASSERT_TRUE(both.best_fit.has_value());
  EXPECT_EQ(both.most_pairs->pairs, by_count->pairs);
  EXPECT_LT(both.most_pairs->score, 0.6 * both.most_pairs->pairs.size());
  const RigidMatch& by_score = *both.best_fit;
  EXPECT_LT(by_score.rigid.t.norm(), 0.2);
  EXPECT_NEAR(by_score.rigid.angle, 0.0, 0.01);
  ASSERT_EQ(by_score.pairs.size(), 6u);
  for (const auto& [r, o] : by_score.pairs) EXPECT_EQ(r, o);
  EXPECT_GT(by_score.score, 5.9);
  EXPECT_LE(by_score.score, 6.0);
}

// The best few transforms of one run, for a judge that knows the drift: in
// the repeating layout both the close alignment and the block-shifted
// one are among them, each once (distinct pairs), best score first.
TEST(RigidAlignmentTest, TheTopTransformsHoldEachCandidateOnceBestFirst) {
  const RepeatingLayout layout = MakeRepeatingLayout();
  const std::vector<Eigen::Vector2d>&old = layout.old, &recent = layout.recent;
  const Eigen::Vector2d& block = layout.block;
  RigidRansacOptions options;
  options.search_m = 60;
  options.inlier_m = 2.5;
  options.min_inliers = 4;
  options.score_std_m = 0.8;
  std::mt19937_64 top_rng(4);
  const std::vector<RigidMatch> top = MatchRigidlyTop(recent, old, options, 10, top_rng);
  ASSERT_GE(top.size(), 2u);
  EXPECT_LE(top.size(), 10u);
  bool has_close = false, has_shifted = false;
  for (size_t i = 0; i < top.size(); ++i) {
    EXPECT_GE(top[i].pairs.size(), 4u);
    if (i > 0) {
      EXPECT_GE(top[i - 1].score, top[i].score);
    }
    for (size_t j = 0; j < i; ++j) EXPECT_NE(top[i].pairs, top[j].pairs);
    has_close = has_close || (top[i].rigid.t.norm() < 0.2 && top[i].pairs.size() == 6);
    has_shifted = has_shifted || std::abs(top[i].rigid.t.x() - block.x()) < 1.0;
  }
  EXPECT_TRUE(has_close);
  EXPECT_TRUE(has_shifted);
  EXPECT_LT(top.front().rigid.t.norm(), 0.2);  // the close one scores most
  std::mt19937_64 none_rng(4);
  EXPECT_TRUE(MatchRigidlyTop(recent, old, options, 0, none_rng).empty());
}

// The samples are measured on threads: the same transforms, pairs and
// scores, and the generator left in the same state, on one thread or four.
TEST(RigidAlignmentTest, ThreadsLeaveTheResultAsItIs) {
  const RepeatingLayout layout = MakeRepeatingLayout();
  RigidRansacOptions options;
  options.min_inliers = 4;
  options.score_std_m = 0.8;
  options.iterations = 200;
  const auto same = [](const std::optional<RigidMatch>& x, const std::optional<RigidMatch>& y) {
    ASSERT_EQ(x.has_value(), y.has_value());
    if (!x) return;
    EXPECT_EQ(x->pairs, y->pairs);
    EXPECT_EQ(x->score, y->score);
    EXPECT_EQ(x->rigid.angle, y->rigid.angle);
    EXPECT_EQ(x->rigid.t, y->rigid.t);
  };
  RigidRansacOptions serial = options, threaded = options;
  serial.threads = 1;
  threaded.threads = 4;
  std::mt19937_64 serial_rng(9), threaded_rng(9);
  const RigidMatches a = MatchRigidlyBothWays(layout.recent, layout.old, serial, serial_rng);
  const RigidMatches b = MatchRigidlyBothWays(layout.recent, layout.old, threaded, threaded_rng);
  ASSERT_TRUE(a.most_pairs.has_value());
  same(a.most_pairs, b.most_pairs);
  same(a.best_fit, b.best_fit);
  EXPECT_EQ(serial_rng(), threaded_rng());
  const std::vector<RigidMatch> top_a =
      MatchRigidlyTop(layout.recent, layout.old, serial, 8, serial_rng);
  const std::vector<RigidMatch> top_b =
      MatchRigidlyTop(layout.recent, layout.old, threaded, 8, threaded_rng);
  ASSERT_GE(top_a.size(), 2u);
  ASSERT_EQ(top_a.size(), top_b.size());
  for (size_t i = 0; i < top_a.size(); ++i) same(top_a[i], top_b[i]);
}

TEST(RigidAlignmentTest, RansacDeclinesWithoutEnoughSupport) {
  const Rigid2 drift = MakeRigid(0.1, 8.0, -5.0);
  const Scene scene = MakeScene(drift, 3);
  RigidRansacOptions options;
  options.search_m = 20;
  options.inlier_m = 1.5;
  options.min_inliers = 8;
  // More inliers asked than there are true pairs.
  {
    RigidRansacOptions strict = options;
    strict.min_inliers = 14;
    std::mt19937_64 rng(4);
    EXPECT_FALSE(MatchRigidly(scene.recent, scene.old, strict, rng).has_value());
  }
  // The drift's rotation beyond the limit.
  {
    RigidRansacOptions straight = options;
    straight.max_rotation_rad = 0.05;
    std::mt19937_64 rng(4);
    EXPECT_FALSE(MatchRigidly(scene.recent, scene.old, straight, rng).has_value());
  }
  // Its shift beyond the limit: within 70 m of the origin the drift moves
  // every point by |t| - 0.1 * 70 m = 2.4 m or more.
  {
    RigidRansacOptions near = options;
    near.max_shift_m = 1.0;
    std::mt19937_64 rng(4);
    EXPECT_FALSE(MatchRigidly(scene.recent, scene.old, near, rng).has_value());
  }
  // Fewer points with a candidate than inliers asked: nothing is drawn.
  {
    RigidRansacOptions blind = options;
    blind.search_m = 0.01;
    blind.inlier_m = 0.01;
    std::mt19937_64 rng(4);
    const std::mt19937_64 untouched = rng;
    EXPECT_FALSE(MatchRigidly(scene.recent, scene.old, blind, rng).has_value());
    EXPECT_TRUE(rng == untouched);
  }
}

}  // namespace
}  // namespace oslam

// Rigid planar alignment of point sets: the least-squares fit of matched
// points, a fraction of a transform (to spread a correction along a drive),
// and a RANSAC matching of one point set onto another (the joint re-entry
// merges of pipeline/landmark_association.h align the landmarks seen lately
// onto the old ones).
#pragma once

#include <optional>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace oslam {

// A rigid planar transform x -> R(angle) x + t.
struct Rigid2 {
  double angle = 0;
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  Eigen::Vector2d operator()(const Eigen::Vector2d& x) const {
    return Eigen::Rotation2Dd(angle) * x + t;
  }
};

// The least-squares rigid transform taking from[i] onto to[i] (same sizes,
// not empty).
Rigid2 FitRigid(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to);

// The part `fraction` of `rigid` about `pivot`: at 0 the identity, at 1
// `rigid` itself, rotating by fraction * angle about pivot in between.
Rigid2 PartOf(const Rigid2& rigid, const Eigen::Vector2d& pivot, double fraction);

struct RigidRansacOptions {
  // A `to` point is a candidate of a `from` point within search_m + inlier_m
  // of it (before any transform).
  double search_m = 60;
  // Inliers: mutually nearest (from, to) pairs within inlier_m once the from
  // point is moved.
  double inlier_m = 2.5;
  double max_rotation_rad = 0.5;
  // Samples moving their pair's midpoint by more than this are skipped (0:
  // no limit).
  double max_shift_m = 0;
  int iterations = 300;
  int min_inliers = 3;
  // A transform's score: its inliers weighted by fit, a pair at distance d
  // counting exp(-d² / (2 score_std_m²)) (0: every inlier 1, the plain
  // count). In a regular layout (a city grid) a transform shifted by a block
  // collects inliers at random distances within inlier_m; the true one may
  // collect fewer, but close.
  double score_std_m = 0;
  // Samples measured at once (0: one thread per core). The result is the
  // same for any count: the samples are drawn in order from the caller's
  // generator and their transforms are taken in that order.
  int threads = 1;
};

struct RigidMatch {
  Rigid2 rigid;
  std::vector<std::pair<int, int>> pairs;  // (from, to) indices, by ascending `to`
  double score = 0;                        // the pairs weighted by fit
};

// RANSAC: `iterations` samples of two `from` points, each with every pair of
// their candidates whose spacing matches theirs within inlier_m and whose
// rotation is within max_rotation_rad; the transform with the most inliers
// (at least min_inliers) is refitted to its inliers while that keeps as many.
// nullopt when fewer than min_inliers points have a candidate (then nothing is
// drawn from `rng`), or no transform has enough inliers, or the refitted one
// too large a rotation.
std::optional<RigidMatch> MatchRigidly(const std::vector<Eigen::Vector2d>& from,
                                       const std::vector<Eigen::Vector2d>& to,
                                       const RigidRansacOptions& options, std::mt19937_64& rng);

// Both best transforms of one RANSAC run (the same samples), each refitted
// and checked as above: the one with the most inliers and the one with the
// highest score.
struct RigidMatches {
  std::optional<RigidMatch> most_pairs, best_fit;
};
RigidMatches MatchRigidlyBothWays(const std::vector<Eigen::Vector2d>& from,
                                  const std::vector<Eigen::Vector2d>& to,
                                  const RigidRansacOptions& options, std::mt19937_64& rng);

// Up to `count` of the highest-scoring transforms of one RANSAC run with
// distinct inlier pairs, each refitted and checked as above, best first: the
// candidates of a regular layout, for a judge that knows the drift (the joint
// compatibility of the pairs, pipeline/landmark_association.h).
std::vector<RigidMatch> MatchRigidlyTop(const std::vector<Eigen::Vector2d>& from,
                                        const std::vector<Eigen::Vector2d>& to,
                                        const RigidRansacOptions& options, int count,
                                        std::mt19937_64& rng);

}  // namespace oslam

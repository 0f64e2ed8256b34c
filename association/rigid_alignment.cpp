#include "association/rigid_alignment.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <unordered_map>

#include "core/angles.h"
#include "core/pair_key.h"
#include "core/parallel.h"

namespace oslam {

Rigid2 FitRigid(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to) {
  Eigen::Vector2d cf = Eigen::Vector2d::Zero(), ct = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < from.size(); ++i) {
    cf += from[i];
    ct += to[i];
  }
  cf /= double(from.size());
  ct /= double(to.size());
  double dot = 0, cross = 0;
  for (size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector2d a = from[i] - cf, b = to[i] - ct;
    dot += a.dot(b);
    cross += a.x() * b.y() - a.y() * b.x();
  }
  Rigid2 rigid;
  rigid.angle = std::atan2(cross, dot);
  rigid.t = ct - Eigen::Rotation2Dd(rigid.angle) * cf;
  return rigid;
}

Rigid2 PartOf(const Rigid2& rigid, const Eigen::Vector2d& pivot, double fraction) {
  Rigid2 part;
  part.angle = fraction * rigid.angle;
  const Eigen::Vector2d shift = rigid(pivot) - pivot;
  part.t = pivot + fraction * shift - Eigen::Rotation2Dd(part.angle) * pivot;
  return part;
}

namespace {

struct Support {
  int count = 0;     // inliers
  double score = 0;  // weighted by fit
};

// Measure's per-call work: the `to` points reached, and per `to` point its
// nearest moved `from` point (distance², index). One per thread.
struct MeasureBuffers {
  std::vector<std::pair<double, int>> best_of_to;
  std::vector<int> touched;
};

// The candidates of each `from` point and the inliers of a transform. The
// `to` points sit on a grid of cells just over 2 inlier_m wide, and every
// 2 x 2 block of cells keeps the list of its points: a transform's inliers
// are then found in the one block around each moved point instead of among
// all its candidates (thousands with clutter; one lookup per moved point
// rather than one per cell, as most cells are empty); the same pairs as a scan of
// the candidates (ties to the higher index, as that scan). Measure runs for
// every candidate transform of every sample, so the blocks are an array over
// the `to` points' bounding box (a hash beyond kMaxDenseCells), and each
// thread keeps its own buffers.
class InlierCounter {
 public:
  InlierCounter(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to,
                const RigidRansacOptions& options)
      : from_(from),
        to_(to),
        inlier_m_(options.inlier_m),
        inlier2_(inlier_m_ * inlier_m_),
        per_cell_m_(1 / (2 * inlier_m_ * (1 + 1e-9))),
        score_std2_(options.score_std_m * options.score_std_m),
        reach_(options.search_m + inlier_m_),
        // Within this of its own place a moved point's inliers (within
        // inlier_m of it) are all within reach: no candidate check needed.
        // The margin keeps rounding out of that triangle inequality.
        sure_reach2_(std::pow(std::max(options.search_m - kReachMarginM, 0.0), 2)),
        near_(from.size()) {
    for (size_t i = 0; i < from_.size(); ++i) {
      for (size_t o = 0; o < to_.size(); ++o)
        if (IsCandidate(static_cast<int>(i), static_cast<int>(o)))
          near_[i].push_back(static_cast<int>(o));
      with_candidates_ += !near_[i].empty();
    }
  }

  int with_candidates() const { return with_candidates_; }
  const std::vector<int>& near(size_t i) const { return near_[i]; }

  // Builds the blocks; needed before Measure(). Block (x, y) holds the
  // points of cells x..x+1, y..y+1, by ascending index.
  void Index() {
    if (to_.empty()) return;
    long min_x = CellOf(to_[0]).first, max_x = min_x, min_y = CellOf(to_[0]).second, max_y = min_y;
    for (const Eigen::Vector2d& p : to_) {
      const auto [x, y] = CellOf(p);
      min_x = std::min(min_x, x);
      max_x = std::max(max_x, x);
      min_y = std::min(min_y, y);
      max_y = std::max(max_y, y);
    }
    --min_x;  // the blocks reaching the lowest cells start one cell lower
    --min_y;
    std::vector<std::pair<long long, int>> keyed;  // (block, point), sorted
    keyed.reserve(4 * to_.size());
    const double cells = (double(max_x - min_x) + 1) * (double(max_y - min_y) + 1);
    dense_ = cells <= kMaxDenseCells;
    origin_x_ = min_x;
    origin_y_ = min_y;
    width_ = max_x - min_x + 1;
    height_ = max_y - min_y + 1;
    for (size_t o = 0; o < to_.size(); ++o) {
      const auto [cx, cy] = CellOf(to_[o]);
      for (long x = cx - 1; x <= cx; ++x)
        for (long y = cy - 1; y <= cy; ++y)
          keyed.push_back({dense_ ? (x - min_x) * height_ + (y - min_y) : PairKey(x, y), int(o)});
    }
    std::sort(keyed.begin(), keyed.end());
    block_points_.clear();
    for (const auto& entry : keyed) block_points_.push_back(entry.second);
    if (dense_) {
      block_begin_.assign(static_cast<size_t>(cells) + 1, 0);
      for (const auto& entry : keyed) ++block_begin_[entry.first + 1];
      for (size_t c = 1; c < block_begin_.size(); ++c) block_begin_[c] += block_begin_[c - 1];
      return;
    }
    for (size_t k = 0; k < keyed.size(); ++k) {
      if (k == 0 || keyed[k].first != keyed[k - 1].first)
        blocks_[keyed[k].first] = {static_cast<int>(k), static_cast<int>(k)};
      ++blocks_[keyed[k].first].second;
    }
  }

  MeasureBuffers NewBuffers() const {
    MeasureBuffers buffers;
    buffers.best_of_to.assign(to_.size(), {0.0, -1});
    return buffers;
  }

  // The inliers of `rigid` and their score (RigidRansacOptions::score_std_m),
  // with `pairs` the pairs; `buffers` from NewBuffers().
  Support Measure(const Rigid2& rigid, MeasureBuffers* buffers,
                  std::vector<std::pair<int, int>>* pairs) const {
    std::vector<std::pair<double, int>>& best_of_to = buffers->best_of_to;
    std::vector<int>& touched = buffers->touched;
    touched.clear();
    const Eigen::Matrix2d rotation = Eigen::Rotation2Dd(rigid.angle).toRotationMatrix();
    for (size_t i = 0; i < from_.size(); ++i) {
      if (near_[i].empty()) continue;
      const Eigen::Vector2d p = rotation * from_[i] + rigid.t;  // rigid(from_[i])
      const bool all_candidates = (p - from_[i]).squaredNorm() <= sure_reach2_;
      // The disc of inlier_m around p lies in the 2 x 2 cells on p's side
      // of its cell's centre.
      const double ux = p.x() * per_cell_m_, uy = p.y() * per_cell_m_;
      const long fx = Floor(ux), fy = Floor(uy);
      const long x0 = ux - static_cast<double>(fx) < 0.5 ? fx - 1 : fx;
      const long y0 = uy - static_cast<double>(fy) < 0.5 ? fy - 1 : fy;
      int nearest = -1;
      double best = inlier2_;
      const std::pair<int, int> block = Block(x0, y0);
      for (int k = block.first; k < block.second; ++k) {
        const int o = block_points_[k];
        if (!all_candidates && !IsCandidate(static_cast<int>(i), o)) continue;  // not in near_[i]
        const double d2 = (to_[o] - p).squaredNorm();
        if (d2 < best || (d2 == best && o > nearest)) {
          best = d2;
          nearest = o;
        }
      }
      if (nearest < 0) continue;
      std::pair<double, int>& at = best_of_to[nearest];
      if (at.second < 0) {
        touched.push_back(nearest);
        at = {best, static_cast<int>(i)};
      } else if (best < at.first) {
        at = {best, static_cast<int>(i)};
      }
    }
    // By ascending to point, as the pairs are reported and the score summed.
    std::sort(touched.begin(), touched.end());
    if (pairs) pairs->clear();
    Support support;
    support.count = static_cast<int>(touched.size());
    for (int o : touched) {
      std::pair<double, int>& at = best_of_to[o];
      if (pairs) pairs->push_back({at.second, o});
      support.score += score_std2_ > 0 ? std::exp(-0.5 * at.first / score_std2_) : 1.0;
      at = {0.0, -1};
    }
    return support;
  }

 private:
  bool IsCandidate(int i, int o) const {
    return (to_[o] - from_[i]).squaredNorm() <= reach_ * reach_;
  }

  // The range of block_points_ in block (x, y); empty outside the grid.
  std::pair<int, int> Block(long x, long y) const {
    if (dense_) {
      const long dx = x - origin_x_, dy = y - origin_y_;
      if (dx < 0 || dy < 0 || dx >= width_ || dy >= height_) return {0, 0};
      const size_t c = static_cast<size_t>(dx * height_ + dy);
      return {block_begin_[c], block_begin_[c + 1]};
    }
    const auto block = blocks_.find(PairKey(x, y));
    return block == blocks_.end() ? std::pair<int, int>{0, 0} : block->second;
  }

  std::pair<long, long> CellOf(const Eigen::Vector2d& p) const {
    return std::make_pair(Floor(p.x() * per_cell_m_), Floor(p.y() * per_cell_m_));
  }

  // std::floor for a cell index (finite, far within long's range), inline:
  // the library call was 1-2 % of a landmark search.
  static long Floor(double v) {
    const long truncated = static_cast<long>(v);
    return truncated - (v < static_cast<double>(truncated) ? 1 : 0);
  }

  const std::vector<Eigen::Vector2d>& from_;
  const std::vector<Eigen::Vector2d>& to_;
  static constexpr double kReachMarginM = 1e-6;
  // Cells a little wider than the inlier disc's diameter (the margin keeps
  // rounding out of the 2 x 2 cover).
  const double inlier_m_, inlier2_, per_cell_m_, score_std2_, reach_, sure_reach2_;
  std::vector<std::vector<int>> near_;  // candidates (to points within reach) per from point
  int with_candidates_ = 0;
  // A grid larger than this (4 million cells: a 10 km square at an inlier
  // distance of 2.5 m) is hashed instead.
  static constexpr double kMaxDenseCells = 4e6;
  bool dense_ = true;
  long origin_x_ = 0, origin_y_ = 0, width_ = 0, height_ = 0;
  std::vector<int> block_begin_;  // dense: block b's points are block_points_[begin[b], begin[b+1])
  std::unordered_map<long long, std::pair<int, int>> blocks_;  // hashed: block -> its range
  std::vector<int> block_points_;                              // to points, block by block
};

// The sampled transforms with at least min_inliers inliers and the most of
// them, and the highest score (count 0: none).
struct Sampled {
  Rigid2 most_rigid, best_fit_rigid;
  Support most, best_fit;
};

// The highest-scoring sampled transforms with distinct inlier pairs, best
// first (a transform found again from other samples replaces its copy when
// it scores more).
class TopTransforms {
 public:
  explicit TopTransforms(int capacity) : capacity_(capacity) {}

  // Whether a transform of this score would be kept (before its pairs are
  // listed).
  bool Wants(double score) const {
    return capacity_ > 0 &&
           (static_cast<int>(kept_.size()) < capacity_ || score > kept_.back().score);
  }

  // `pairs` are the transform's inliers (InlierCounter::Measure's).
  void Offer(const Rigid2& rigid, const Support& support,
             const std::vector<std::pair<int, int>>& pairs) {
    if (!Wants(support.score)) return;
    RigidMatch match;
    match.rigid = rigid;
    match.score = support.score;
    match.pairs = pairs;
    const auto same = std::find_if(kept_.begin(), kept_.end(),
                                   [&](const RigidMatch& k) { return k.pairs == match.pairs; });
    if (same != kept_.end()) {
      if (same->score >= match.score) return;
      kept_.erase(same);
    }
    kept_.insert(std::upper_bound(
                     kept_.begin(), kept_.end(), match,
                     [](const RigidMatch& x, const RigidMatch& y) { return x.score > y.score; }),
                 std::move(match));
    if (static_cast<int>(kept_.size()) > capacity_) kept_.pop_back();
  }

  const std::vector<RigidMatch>& kept() const { return kept_; }

 private:
  int capacity_;
  std::vector<RigidMatch> kept_;
};

// A sample's transform with at least min_inliers inliers.
struct Hypothesis {
  Rigid2 rigid;
  Support support;
};

void MeasureSample(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to,
                   const InlierCounter& counter, const RigidRansacOptions& options, size_t a,
                   size_t b, MeasureBuffers* buffers, std::vector<Hypothesis>* out) {
  const double inlier_m = options.inlier_m;
  if (a == b || counter.near(a).empty() || counter.near(b).empty()) return;
  const Eigen::Vector2d ra = from[a], rb = from[b];
  const double d = (rb - ra).norm();
  if (d < 2 * inlier_m) return;
  const double heading = std::atan2(rb.y() - ra.y(), rb.x() - ra.x());
  Hypothesis h;
  for (int oa : counter.near(a))
    for (int ob : counter.near(b)) {
      if (oa == ob) continue;
      const Eigen::Vector2d v = to[ob] - to[oa];
      if (std::abs(v.norm() - d) > inlier_m) continue;
      const double angle = WrapAngle(std::atan2(v.y(), v.x()) - heading);
      if (std::abs(angle) > options.max_rotation_rad) continue;
      if (options.max_shift_m > 0 &&
          (0.5 * (to[oa] + to[ob] - ra - rb)).norm() > options.max_shift_m)
        continue;
      h.rigid.angle = angle;
      h.rigid.t = 0.5 * (to[oa] + to[ob]) - Eigen::Rotation2Dd(angle) * (0.5 * (ra + rb));
      h.support = counter.Measure(h.rigid, buffers, nullptr);
      if (h.support.count >= options.min_inliers) out->push_back(h);
    }
}

// The samples are drawn first, in order, then measured (on threads, a block
// of samples at a time) and their transforms taken in sample order: the
// same outcome on any number of threads.
Sampled Sample(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to,
               const InlierCounter& counter, const RigidRansacOptions& options,
               std::mt19937_64& rng, TopTransforms* top = nullptr) {
  std::uniform_int_distribution<size_t> pick(0, from.size() - 1);
  const size_t samples = static_cast<size_t>(std::max(options.iterations, 0));
  std::vector<std::pair<size_t, size_t>> drawn(samples);
  for (auto& [a, b] : drawn) {
    a = pick(rng);
    b = pick(rng);
  }
  // Blocks of samples: few enough that a thread's start costs little,
  // enough that the threads finish together.
  constexpr size_t kSamplesPerBlock = 16;
  const size_t blocks = (samples + kSamplesPerBlock - 1) / kSamplesPerBlock;
  const int threads = ThreadCount(options.threads, blocks);
  std::vector<MeasureBuffers> buffers(static_cast<size_t>(threads));
  for (MeasureBuffers& b : buffers) b = counter.NewBuffers();
  std::vector<std::vector<Hypothesis>> found(samples);
  ParallelFor(0, static_cast<size_t>(threads), threads, [&](size_t worker) {
    MeasureBuffers* mine = &buffers[worker];
    for (size_t block = worker; block < blocks; block += static_cast<size_t>(threads))
      for (size_t i = block * kSamplesPerBlock;
           i < std::min(samples, (block + 1) * kSamplesPerBlock); ++i)
        MeasureSample(from, to, counter, options, drawn[i].first, drawn[i].second, mine, &found[i]);
  });
  // In sample order; the pairs only of the transforms `top` would keep (a
  // grid offers thousands of transforms of a few inliers each).
  Sampled best;
  std::vector<std::pair<int, int>> pairs;
  for (const std::vector<Hypothesis>& sample : found)
    for (const Hypothesis& h : sample) {
      if (top && top->Wants(h.support.score)) {
        counter.Measure(h.rigid, &buffers.front(), &pairs);
        top->Offer(h.rigid, h.support, pairs);
      }
      if (h.support.count > best.most.count) {
        best.most = h.support;
        best.most_rigid = h.rigid;
      }
      if (h.support.score > best.best_fit.score) {
        best.best_fit = h.support;
        best.best_fit_rigid = h.rigid;
      }
    }
  return best;
}

// `rigid` refitted to its inliers while that keeps as many (a drift that
// bends the recent points takes in more of them at a lower score: the count
// decides here), with its pairs and score; nullopt when it has too few
// inliers or too large a rotation.
std::optional<RigidMatch> Refitted(const std::vector<Eigen::Vector2d>& from,
                                   const std::vector<Eigen::Vector2d>& to,
                                   const InlierCounter& counter, const RigidRansacOptions& options,
                                   const Rigid2& rigid) {
  RigidMatch match;
  match.rigid = rigid;
  MeasureBuffers buffers = counter.NewBuffers();
  for (int refit = 0; refit < 2; ++refit) {
    counter.Measure(match.rigid, &buffers, &match.pairs);
    std::vector<Eigen::Vector2d> matched_from, matched_to;
    for (const auto& [r, o] : match.pairs) {
      matched_from.push_back(from[r]);
      matched_to.push_back(to[o]);
    }
    const Rigid2 fitted = FitRigid(matched_from, matched_to);
    if (counter.Measure(fitted, &buffers, nullptr).count < static_cast<int>(match.pairs.size()))
      break;
    match.rigid = fitted;
  }
  match.score = counter.Measure(match.rigid, &buffers, &match.pairs).score;
  if (static_cast<int>(match.pairs.size()) < options.min_inliers ||
      std::abs(match.rigid.angle) > options.max_rotation_rad)
    return std::nullopt;
  return match;
}

}  // namespace

RigidMatches MatchRigidlyBothWays(const std::vector<Eigen::Vector2d>& from,
                                  const std::vector<Eigen::Vector2d>& to,
                                  const RigidRansacOptions& options, std::mt19937_64& rng) {
  RigidMatches matches;
  if (from.size() < 2) return matches;
  InlierCounter counter(from, to, options);
  if (counter.with_candidates() < options.min_inliers) return matches;
  counter.Index();
  const Sampled best = Sample(from, to, counter, options, rng);
  if (best.most.count == 0) return matches;
  matches.most_pairs = Refitted(from, to, counter, options, best.most_rigid);
  matches.best_fit = Refitted(from, to, counter, options, best.best_fit_rigid);
  return matches;
}

std::vector<RigidMatch> MatchRigidlyTop(const std::vector<Eigen::Vector2d>& from,
                                        const std::vector<Eigen::Vector2d>& to,
                                        const RigidRansacOptions& options, int count,
                                        std::mt19937_64& rng) {
  std::vector<RigidMatch> matches;
  if (from.size() < 2 || count <= 0) return matches;
  InlierCounter counter(from, to, options);
  if (counter.with_candidates() < options.min_inliers) return matches;
  counter.Index();
  TopTransforms top(count);
  Sample(from, to, counter, options, rng, &top);
  for (const RigidMatch& sampled : top.kept()) {
    std::optional<RigidMatch> match = Refitted(from, to, counter, options, sampled.rigid);
    if (!match) continue;
    const bool seen = std::any_of(matches.begin(), matches.end(),
                                  [&](const RigidMatch& m) { return m.pairs == match->pairs; });
    if (!seen) matches.push_back(std::move(*match));
  }
  std::stable_sort(matches.begin(), matches.end(),
                   [](const RigidMatch& x, const RigidMatch& y) { return x.score > y.score; });
  return matches;
}

std::optional<RigidMatch> MatchRigidly(const std::vector<Eigen::Vector2d>& from,
                                       const std::vector<Eigen::Vector2d>& to,
                                       const RigidRansacOptions& options, std::mt19937_64& rng) {
  return MatchRigidlyBothWays(from, to, options, rng).most_pairs;
}

}  // namespace oslam

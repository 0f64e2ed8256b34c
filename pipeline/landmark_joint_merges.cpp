// The joint re-entry merges of LandmarkAssociation (docs/method.md §16.2):
// the recent landmarks aligned onto the old ones by RANSAC, the alignment
// tried per anchor pose, its misfit pairs split off, kept on the evidence.
#include "pipeline/landmark_association.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include "core/angles.h"
#include "core/text.h"
#include "slam/landmark_factors.h"

namespace oslam {

// ---- joint re-entry merges (see UnknownAssociationOptions::joint_*) ----

RigidRansacOptions JointRansacOptions(const UnknownAssociationOptions& options) {
  RigidRansacOptions ransac;
  ransac.search_m = options.joint_search_m;
  ransac.inlier_m = options.joint_inlier_m;
  ransac.max_rotation_rad = options.joint_max_rotation_rad;
  ransac.max_shift_m = options.joint_max_shift_m;
  ransac.iterations = options.joint_ransac_iterations;
  ransac.min_inliers = options.joint_min_inliers;
  ransac.score_std_m = options.joint_score_std_m;
  ransac.threads = options.threads;
  return ransac;
}

long LandmarkAssociation::JointMerge(int n) {
  if (options_.joint_min_inliers <= 0 || n - last_ransac_ < options_.joint_every_poses) return 0;
  last_ransac_ = n;
  const auto joint_start = std::chrono::steady_clock::now();
  const long merged = TryJointMerge(n);
  result_.joint_time_s += SecondsSince(joint_start);
  return merged;
}

long LandmarkAssociation::TryJointMerge(int n) {
  const int recent_from = StretchStart(n, options_.joint_recent_m);
  if (last_failure_ < recent_from) joint_needed_score_ = 0;
  if (recent_from <= 0) return 0;  // not driven that far yet
  const EvaluationPtr before = current_;
  std::optional<JointAlignment> alignment = AlignRecentOntoOld(*before, n);
  if (!alignment) alignment = ScreenedAlignment(*before, n);
  if (!alignment) return 0;
  // Per anchor pose: the merges made since it are undone (they were made
  // under the drift), every pair merged, and the state solved from the
  // trajectory with the correction spread along the drive since the anchor.
  const std::vector<Pose2>& trajectory = before->solution->trajectory;
  std::vector<double> driven(trajectory.size(), 0.0);
  for (size_t i = 1; i < trajectory.size(); ++i)
    driven[i] = driven[i - 1] + std::hypot(trajectory[i].x - trajectory[i - 1].x,
                                           trajectory[i].y - trajectory[i - 1].y);
  EvaluationPtr best;
  int best_anchor = 0, last_anchor = n;
  const auto try_anchor = [&](int anchor) {
    const EvaluationPtr e = TryAnchor(*before, *alignment, driven, anchor, n);
    if (e && e->valid && (!best || e->log_target > best->log_target)) {
      best = e;
      best_anchor = anchor;
    }
  };
  for (int k = 0, previous_anchor = -1; k < options_.joint_anchors; ++k) {
    const int anchor = std::max(0, StretchStart(n, options_.joint_recent_m * (1 << k)) - 1);
    if (anchor == previous_anchor) break;
    previous_anchor = anchor;
    // The correction moves every pose after the anchor: poses held in the
    // window's solves would stay bent, their odometry broken.
    if (anchor + 1 < held_poses_) break;
    try_anchor(anchor);
    last_anchor = anchor;
  }
  const int loop_anchor = options_.joint_loop_anchor ? LoopStart(*alignment) - 1 : -1;
  if (loop_anchor + 1 >= held_poses_ && loop_anchor >= 0 && loop_anchor < last_anchor)
    try_anchor(loop_anchor);
  return KeepJointMerge(before, best, best_anchor, n, *alignment);
}

// The median over the aligned pairs of the pose at which the old landmark
// was last seen: where the loop the alignment closes began.
int LandmarkAssociation::LoopStart(const JointAlignment& alignment) const {
  std::vector<int> last_seen;
  for (const auto& pair : alignment.match.pairs) {
    int last = 0;
    for (int t : alignment.old[pair.second].tracks) last = std::max(last, last_pose_[t]);
    last_seen.push_back(last);
  }
  std::nth_element(last_seen.begin(), last_seen.begin() + last_seen.size() / 2, last_seen.end());
  return last_seen[last_seen.size() / 2];
}

// The units aligned: the recent part of each landmark (its tracks first seen
// in the last joint_recent_m metres, placed by their own sightings: a merge made
// under the drift may be wrong) and the old part (tracks last seen before
// that, at the landmark's position), by RANSAC (joint_close_ratio). nullopt
// when no alignment is worth a try.
LandmarkAssociation::JointAlignment LandmarkAssociation::RecentAndOldUnits(
    const StateEvaluation& before, int n) const {
  const int recent_from = StretchStart(n, options_.joint_recent_m);
  const AssociationState& s = before.state;
  JointAlignment units;
  for (size_t j = 0; j < s.blocks.size(); ++j) {
    Unit r, o;
    for (int t : s.blocks[j]) {
      if (first_pose_[t] >= recent_from) r.tracks.push_back(t);
      if (last_pose_[t] < recent_from) o.tracks.push_back(t);
    }
    if (!r.tracks.empty()) {
      r.position_m = PlacedBy(r.tracks, before.solution->trajectory, n);
      units.recent.push_back(r);
    }
    if (!o.tracks.empty()) {
      o.position_m = before.locations[j].head<2>();
      units.old.push_back(o);
    }
  }
  return units;
}

std::optional<LandmarkAssociation::JointAlignment> LandmarkAssociation::AlignRecentOntoOld(
    const StateEvaluation& before, int n) {
  const AssociationState& s = before.state;
  JointAlignment units = RecentAndOldUnits(before, n);
  if (static_cast<int>(units.recent.size()) < options_.joint_min_inliers) return std::nullopt;
  std::vector<Eigen::Vector2d> from, to;
  for (const Unit& u : units.recent) from.push_back(u.position_m);
  for (const Unit& u : units.old) to.push_back(u.position_m);
  RigidMatches matches = MatchRigidlyBothWays(from, to, JointRansacOptions(options_), rng_);
  std::optional<RigidMatch>& match = matches.most_pairs;
  const std::optional<RigidMatch>& close = matches.best_fit;
  if (options_.joint_close_ratio > 0 && close &&
      (!match || close->score > options_.joint_close_ratio * match->score))
    match = close;
  if (!match || match->score < std::max(joint_needed_score_, options_.joint_min_score))
    return std::nullopt;
  JointAlignment alignment = std::move(units);
  alignment.match = std::move(*match);
  if (!WorthATry(s, &alignment)) return std::nullopt;
  return alignment;
}

// A re-entry below the RANSAC floors (joint_screen_*): the best few
// alignments judged by the closed-form joint merge of their pairs.
std::optional<LandmarkAssociation::JointAlignment> LandmarkAssociation::ScreenedAlignment(
    const StateEvaluation& before, int n) {
  if (options_.joint_screen_candidates <= 0 ||
      options_.target.mode != LandmarkEvaluationMode::kMarginal)
    return std::nullopt;
  JointAlignment units = RecentAndOldUnits(before, n);
  if (static_cast<int>(units.recent.size()) < options_.joint_screen_min_inliers)
    return std::nullopt;
  // The candidates: alignments scoring at least joint_screen_min_score that
  // would merge at least joint_screen_min_inliers recent landmarks not
  // merged with an old one yet (where the recent tracks re-seen are merged
  // already, the targeted merges have closed the re-entry).
  // Only those are aligned (a re-seen landmark merged already would only
  // repeat its merge).
  std::vector<int> unmerged;  // indices into units.recent
  std::vector<Eigen::Vector2d> from, to;
  for (size_t r = 0; r < units.recent.size(); ++r) {
    const Unit& u = units.recent[r];
    if (u.tracks.size() != before.state.blocks[before.state.BlockOf(u.tracks.front())].size())
      continue;
    unmerged.push_back(static_cast<int>(r));
    from.push_back(u.position_m);
  }
  if (static_cast<int>(from.size()) < options_.joint_screen_min_inliers) return std::nullopt;
  for (const Unit& u : units.old) to.push_back(u.position_m);
  RigidRansacOptions ransac = JointRansacOptions(options_);
  ransac.min_inliers = options_.joint_screen_min_inliers;
  std::vector<RigidMatch> candidates;
  for (RigidMatch& match :
       MatchRigidlyTop(from, to, ransac, options_.joint_screen_candidates, rng_)) {
    if (match.score < options_.joint_screen_min_score) break;  // best first
    for (auto& pair : match.pairs) pair.first = unmerged[pair.first];
    int new_merges = 0;  // of recent landmarks not merged with an old one yet
    for (const auto& [r, o] : match.pairs) {
      const int jr = before.state.BlockOf(units.recent[r].tracks.front());
      new_merges += jr != before.state.BlockOf(units.old[o].tracks.front()) &&
                    units.recent[r].tracks.size() == before.state.blocks[jr].size();
    }
    units.match = match;
    units.pivot.setZero();
    if (new_merges >= options_.joint_screen_min_inliers && WorthATry(before.state, &units))
      candidates.push_back(std::move(match));
  }
  const int anchor = std::max(0, StretchStart(n, options_.joint_recent_m) - 1);
  if (candidates.empty() || anchor + 1 < held_poses_) return std::nullopt;
  // Judged where the recent tracks are landmarks of their own: a merge made
  // under the drift pins the trajectory and makes every other pair misfit
  // (when there is one, a solve there and one back).
  StateEvaluation seed;
  seed.state = ReleasedAndMerged(before.state, JointAlignment(), anchor);
  const bool release = !(seed.state == before.state);
  seed.locations = SeedLocations(before, seed.state, before.solution->trajectory, anchor, n);
  seed.solution = before.solution;
  // The reference (before) is set aside for the released one's solve and
  // brought back after, instead of being solved again.
  const bool stash = release && evaluator_->IsReference(before);
  if (stash) evaluator_->StashReference();
  const EvaluationPtr released = release ? Refine(seed.state, &seed) : current_;
  // A try must promise more than the state before holds (its merges since
  // the anchor included).
  double best_gain = before.log_target - released->log_target + options_.joint_screen_min_gain;
  std::optional<RigidMatch> best;
  for (RigidMatch& match : candidates) {
    double gain = 0;
    if (!released->valid || !JointGainOfBestPairs(*released, units, n, &match, &gain) ||
        !(gain > best_gain))
      continue;
    // The pairs left, refitted on the state before's places, must still
    // be worth a try (move something, merge something new).
    std::vector<Eigen::Vector2d> matched_from, matched_to;
    for (const auto& [r, o] : match.pairs) {
      matched_from.push_back(units.recent[r].position_m);
      matched_to.push_back(units.old[o].position_m);
    }
    match.rigid = FitRigid(matched_from, matched_to);
    units.match = match;
    units.pivot.setZero();
    if (!WorthATry(before.state, &units)) continue;
    best_gain = gain;
    best = std::move(match);
  }
  if (stash)
    current_ = evaluator_->RestoreReference();
  else if (release)
    current_ = Refine(before.state, &before);  // the reference back at before
  if (!best) return std::nullopt;
  Say(
      Format("joint merge at %.0f poses: of %.0f alignments screened, %.0f pairs gain %.1f in "
             "closed form",
             double(n), double(candidates.size()), double(best->pairs.size()), best_gain));
  units.match = *best;
  units.pivot.setZero();
  WorthATry(before.state, &units);  // sets the pivot
  return units;
}

// The closed-form gain of merging `match`'s pairs at `at` (a state whose
// recent tracks are landmarks of their own), after leaving out the pairs
// individually incompatible and then, one at a time, the pair whose removal
// raises it most while that helps and at least joint_screen_min_inliers
// pairs remain: the largest jointly compatible set found greedily (a pair
// 2 m off among right ones is a wrong tree). False when not computable.
bool LandmarkAssociation::JointGainOfBestPairs(const StateEvaluation& at,
                                               const JointAlignment& units, int n,
                                               RigidMatch* match, double* gain) {
  std::map<int, std::vector<int>> scans;
  const auto gain_of = [&](const RigidMatch& m, double* g) {
    const std::vector<std::vector<int>> groups = MergedGroups(at.state, units, m, n, &scans);
    int merges = 0;
    for (const auto& group : groups) merges += static_cast<int>(group.size()) - 1;
    return merges >= options_.joint_screen_min_inliers &&
           evaluator_->JointMergeDelta(at.state, groups, g);
  };
  // Grossly incompatible pairs first: a pair whose own merge loses more
  // than kIndividualGate nats (14 sigmas of the pair's relative
  // uncertainty) cannot be right whatever the others do; a block-shifted
  // alignment's pairs lose thousands and go here, before any joint score.
  // (Not a 5-sigma gate: alone, the first true pair of a re-entry after
  // drift pays for bending the whole stretch, which its partners share.)
  constexpr double kIndividualGate = 100;
  std::vector<std::pair<int, int>> compatible;
  for (const auto& pair : match->pairs) {
    RigidMatch one;
    one.pairs = {pair};
    const std::vector<std::vector<int>> groups = MergedGroups(at.state, units, one, n, &scans);
    double g = 0;
    if (groups.empty() || !evaluator_->JointMergeDelta(at.state, groups, &g) ||
        g > -kIndividualGate)
      compatible.push_back(pair);
  }
  if (static_cast<int>(compatible.size()) < options_.joint_screen_min_inliers) return false;
  match->pairs = std::move(compatible);
  if (!gain_of(*match, gain)) return false;
  while (static_cast<int>(match->pairs.size()) > options_.joint_screen_min_inliers) {
    double best = *gain;
    int drop = -1;
    for (size_t i = 0; i < match->pairs.size(); ++i) {
      RigidMatch without = *match;
      without.pairs.erase(without.pairs.begin() + i);
      double g = 0;
      if (gain_of(without, &g) && g > best) {
        best = g;
        drop = static_cast<int>(i);
      }
    }
    if (drop < 0) break;
    match->pairs.erase(match->pairs.begin() + drop);
    *gain = best;
  }
  return true;
}

std::vector<std::vector<int>> LandmarkAssociation::MergedGroups(
    const AssociationState& s, const JointAlignment& units, const RigidMatch& match, int n,
    std::map<int, std::vector<int>>* scans) const {
  // Union-find over the blocks the pairs touch; a pair joins its recent
  // landmark (whole: one with older tracks was merged under the drift and
  // is left to the trial) to its old one unless their scans overlap.
  // `scans` keeps each block's sorted poses for the next call on `s`.
  std::map<int, int> parent;
  const auto root = [&](int j) {
    parent.emplace(j, j);
    while (parent[j] != j) j = parent[j] = parent[parent[j]];
    return j;
  };
  const auto scans_of = [&](int j) -> const std::vector<int>& {
    auto [at, added] = scans->emplace(j, std::vector<int>());
    if (added) {
      for (int t : s.blocks[j])
        for (int k : result_.tracks[t])
          if (data_->sightings[k].pose < n) at->second.push_back(data_->sightings[k].pose);
      std::sort(at->second.begin(), at->second.end());
    }
    return at->second;
  };
  std::map<int, std::vector<int>> members;  // root -> its blocks
  for (const auto& [r, o] : match.pairs) {
    const Unit& recent = units.recent[r];
    const int jr = s.BlockOf(recent.tracks.front()), jo = s.BlockOf(units.old[o].tracks.front());
    if (recent.tracks.size() != s.blocks[jr].size()) continue;  // not a whole landmark
    int a = root(jr), b = root(jo);
    if (a == b) continue;
    std::vector<int>& ma = members.emplace(a, std::vector<int>{a}).first->second;
    std::vector<int>& mb = members.emplace(b, std::vector<int>{b}).first->second;
    bool overlap = false;
    for (size_t x = 0; x < ma.size() && !overlap; ++x)
      for (size_t y = 0; y < mb.size() && !overlap; ++y) {
        const std::vector<int>&sx = scans_of(ma[x]), &sy = scans_of(mb[y]);
        for (size_t i = 0, k = 0; i < sx.size() && k < sy.size() && !overlap;) {
          overlap = sx[i] == sy[k];
          if (sx[i] < sy[k])
            ++i;
          else
            ++k;
        }
      }
    if (overlap) continue;
    if (ma.size() < mb.size()) {
      std::swap(a, b);
    }
    std::vector<int>& into = members[a];
    std::vector<int>& from = members[b];
    parent[b] = a;
    into.insert(into.end(), from.begin(), from.end());
    members.erase(b);
  }
  std::vector<std::vector<int>> groups;
  for (auto& [r, blocks] : members)
    if (blocks.size() > 1) groups.push_back(std::move(blocks));
  return groups;
}

// Sets the alignment's pivot; false when it hardly moves the recent
// landmarks (the single merges can make the pairs), the pairs are already
// merged, or it shifts them beyond joint_max_shift_m.
bool LandmarkAssociation::WorthATry(const AssociationState& s, JointAlignment* alignment) const {
  const Rigid2& rigid = alignment->match.rigid;
  const auto& pairs = alignment->match.pairs;
  double largest_move = 0;
  int unmerged = 0;
  for (const auto& [r, o] : pairs) {
    const Eigen::Vector2d& position = alignment->recent[r].position_m;
    alignment->pivot += position / double(pairs.size());
    largest_move = std::max(largest_move, (rigid(position) - position).norm());
    unmerged += s.BlockOf(alignment->recent[r].tracks.front()) !=
                s.BlockOf(alignment->old[o].tracks.front());
  }
  if (largest_move < options_.joint_inlier_m || unmerged == 0) return false;
  return !(options_.joint_max_shift_m > 0 &&
           (rigid(alignment->pivot) - alignment->pivot).norm() > options_.joint_max_shift_m);
}

// The joint merge with the correction from `anchor`: the tracks first seen
// after it released from their landmarks, every pair merged, and the whole
// problem solved from the trajectory bent by the alignment (linearly in the
// distance driven since the anchor). Null when nothing was driven.
EvaluationPtr LandmarkAssociation::TryAnchor(const StateEvaluation& before,
                                             const JointAlignment& alignment,
                                             const std::vector<double>& driven, int anchor, int n) {
  const double span = driven.back() - driven[anchor];
  if (!(span > 0)) return nullptr;
  StateEvaluation seed;
  seed.state = ReleasedAndMerged(before.state, alignment, anchor);
  auto moved = std::make_shared<GeometricSlamResult>();
  moved->trajectory = before.solution->trajectory;
  for (size_t i = anchor + 1; i < moved->trajectory.size(); ++i) {
    const double fraction = (driven[i] - driven[anchor]) / span;
    const Rigid2 part = PartOf(alignment.match.rigid, alignment.pivot, fraction);
    Pose2& p = moved->trajectory[i];
    const Eigen::Vector2d q = part(Eigen::Vector2d(p.x, p.y));
    p = {q.x(), q.y(), WrapAngle(p.theta + part.angle)};
  }
  seed.locations = SeedLocations(before, seed.state, moved->trajectory, anchor, n);
  seed.solution = std::move(moved);
  const EvaluationPtr e = evaluator_->Trial(seed.state, &seed);
  ++result_.joint_tries;
  const EvaluationPtr repaired = e->valid ? WithoutMisfitPairs(e, alignment) : e;
  const Rigid2& rigid = alignment.match.rigid;
  Say(Format("joint merge at %.0f poses: %.0f of %.0f recent landmarks onto old ones "
             "(score %.1f, rotation %.3f rad, shift %.1f m),",
             double(n), double(alignment.match.pairs.size()), double(alignment.recent.size()),
             alignment.match.score, rigid.angle,
             (rigid(alignment.pivot) - alignment.pivot).norm()) +
      Format(" correction from pose %.0f: log target %.1f -> %.1f", double(anchor),
             before.log_target,
             e->valid ? e->log_target : -std::numeric_limits<double>::infinity()) +
      (repaired != e ? Format(", %.0f misfit pairs split: %.1f", double(split_pairs_),
                              repaired->valid ? repaired->log_target
                                              : -std::numeric_limits<double>::infinity())
                     : std::string()));
  return repaired;
}

// A right alignment can still pair a few landmarks wrongly (the recent
// stretch is bent, not rigidly moved, and landmarks 2 m apart lie within
// the inlier distance): one wrong pair under a laser's noise costs hundreds
// of nats and sinks the whole joint merge. So, as in data snooping, the
// pairs whose landmarks fit worst after the solve (the squared whitened
// residual r2 of a landmark's n sightings standardised as
// (r2 - 2n) / sqrt(4n), the chi-square's mean and spread; every pair with z
// above joint_misfit_z and at least half the worst z) are split off again
// and the problem re-solved, for at most joint_repair_rounds rounds. When more than a quarter of
// the pairs misfit, the alignment itself is wrong and the try is left as it is.
EvaluationPtr LandmarkAssociation::WithoutMisfitPairs(EvaluationPtr e,
                                                      const JointAlignment& alignment) {
  split_pairs_ = 0;
  std::vector<bool> split(alignment.match.pairs.size(), false);
  for (int round = 0; round < options_.joint_repair_rounds && e->valid; ++round) {
    std::vector<std::pair<double, int>> misfits;  // (z, pair)
    for (size_t i = 0; i < alignment.match.pairs.size(); ++i) {
      if (split[i]) continue;
      const int t = alignment.recent[alignment.match.pairs[i].first].tracks.front();
      const double z = MisfitZ(*e, e->state.BlockOf(t));
      if (z > options_.joint_misfit_z) misfits.push_back({z, static_cast<int>(i)});
    }
    if (misfits.empty() || 4 * misfits.size() > alignment.match.pairs.size()) break;
    const double worst_z = std::max_element(misfits.begin(), misfits.end())->first;
    AssociationState state = e->state;
    for (const auto& [z, i] : misfits) {
      if (z < worst_z / 2) continue;
      split[i] = true;
      ++split_pairs_;
      const std::vector<int>& tracks = alignment.recent[alignment.match.pairs[i].first].tracks;
      auto& block = state.blocks[state.BlockOf(tracks.front())];
      for (int t : tracks) block.erase(std::find(block.begin(), block.end(), t));
      state.blocks.push_back(tracks);
      std::sort(state.blocks.back().begin(), state.blocks.back().end());
      state.blocks.erase(std::remove_if(state.blocks.begin(), state.blocks.end(),
                                        [](const std::vector<int>& b) { return b.empty(); }),
                         state.blocks.end());
    }
    state.classes.assign(state.blocks.size(), 0);
    state.Canonicalize();
    e = evaluator_->Trial(state, e.get());
    ++result_.joint_tries;
  }
  return e;
}

// `s` with the tracks first seen after `anchor` split off their landmarks
// (the merges made under the drift are undone) and the recent part of every
// pair moved onto its old part.
AssociationState LandmarkAssociation::ReleasedAndMerged(const AssociationState& s,
                                                        const JointAlignment& alignment,
                                                        int anchor) const {
  std::vector<std::vector<int>> blocks;
  std::vector<int> where(num_tracks_, -1);
  for (const auto& block : s.blocks)
    for (int part = 0; part < 2; ++part) {
      std::vector<int> tracks;
      for (int t : block)
        if ((first_pose_[t] > anchor) == (part == 1)) tracks.push_back(t);
      if (tracks.empty()) continue;
      for (int t : tracks) where[t] = static_cast<int>(blocks.size());
      blocks.push_back(tracks);
    }
  for (const auto& [r, o] : alignment.match.pairs) {
    const int to = where[alignment.old[o].tracks.front()];
    for (int t : alignment.recent[r].tracks) {
      auto& from = blocks[where[t]];
      from.erase(std::find(from.begin(), from.end(), t));
      blocks[to].push_back(t);
      where[t] = to;
    }
  }
  AssociationState merged;
  for (auto& b : blocks)
    if (!b.empty()) {
      std::sort(b.begin(), b.end());
      merged.blocks.push_back(b);
    }
  merged.classes.assign(merged.blocks.size(), 0);
  merged.Canonicalize();
  return merged;
}

// Keeps the best anchor's state when the whole-problem evidence rises, after
// redoing the targeted merges of the released tracks if needed; else
// restores the state before and asks more inliers of the next try.
long LandmarkAssociation::KeepJointMerge(const EvaluationPtr& before, const EvaluationPtr& best,
                                         int best_anchor, int n, const JointAlignment& alignment) {
  const double base = before->log_target;
  if (best) {
    // The merges undone since the anchor may be redone (right this time)
    // by the targeted merges: the try is judged after them.
    current_ = Refine(best->state, best.get());
    if (current_->valid && current_->log_target <= base && options_.targeted_radius_m > 0) {
      const int first_released = static_cast<int>(
          std::upper_bound(first_pose_.begin(), first_pose_.begin() + num_tracks_, best_anchor) -
          first_pose_.begin());
      TargetedMerges(first_released);
      Say(Format("joint merge at %.0f poses: after the targeted merges %.1f (before %.1f)",
                 double(n), current_->log_target, base));
    }
    if (current_->valid && current_->log_target > base) {
      joint_needed_score_ = 0;
      const long pairs = static_cast<long>(alignment.match.pairs.size());
      result_.joint_merges += pairs;
      return pairs;
    }
    current_ = Refine(before->state, before.get());  // back to before
  }
  joint_needed_score_ = alignment.match.score + options_.joint_retry_score;
  last_failure_ = n;
  return 0;
}

int LandmarkAssociation::StretchStart(int n, double metres) const {
  if (n <= 0) return 0;
  const double from = driven_m_[n - 1] - metres;
  return static_cast<int>(std::lower_bound(driven_m_.begin(), driven_m_.begin() + n, from) -
                          driven_m_.begin());
}

std::vector<Eigen::Vector3d> LandmarkAssociation::SeedLocations(
    const StateEvaluation& before, const AssociationState& state,
    const std::vector<Pose2>& trajectory, int anchor, int n) const {
  // Where the block's earliest track was, when it is from before the
  // anchor; else where `trajectory` puts its sightings.
  std::vector<Eigen::Vector3d> locations;
  for (const auto& block : state.blocks) {
    locations.push_back(Eigen::Vector3d::Zero());
    locations.back().head<2>() =
        first_pose_[block.front()] <= anchor
            ? Eigen::Vector2d(before.locations[before.state.BlockOf(block.front())].head<2>())
            : PlacedBy(block, trajectory, n);
  }
  return locations;
}

Eigen::Vector2d LandmarkAssociation::PlacedBy(const std::vector<int>& tracks,
                                              const std::vector<Pose2>& poses, int n) const {
  const LandmarkDataset& data = *data_;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int count = 0;
  for (int t : tracks)
    for (int k : result_.tracks[t]) {
      const LandmarkSighting& z = data.sightings[k];
      if (z.pose >= n) break;
      sum +=
          LandmarkFromRangeBearing(poses[z.pose], z.range_m, z.bearing_rad, data.sensor_offset_m);
      ++count;
    }
  return Eigen::Vector2d(count > 0 ? Eigen::Vector2d(sum / count) : sum);
}

}  // namespace oslam

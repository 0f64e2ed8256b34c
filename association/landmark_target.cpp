#include "association/landmark_target.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <set>
#include <utility>

#include "association/rigid_alignment.h"
#include "core/angles.h"
#include "core/error.h"
#include "slam/landmark_factors.h"

namespace oslam {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

std::string Format(const char* format, double a, double b = 0, double c = 0, double d = 0,
                   double e = 0, double f = 0, double g = 0) {
  char line[256];
  std::snprintf(line, sizeof(line), format, a, b, c, d, e, f, g);
  return line;
}

}  // namespace

bool UnknownAssociationOptions::Validate(std::string* why) const {
  if (!tracks.Validate(why) || !target.Validate(why) || !moves.Validate(why)) return false;
  if (targeted_radius_m > 0 && target.mode != LandmarkEvaluationMode::kMarginal) {
    if (why) *why = "targeted merges need the marginal evaluation";
    return false;
  }
  if (sweep_radius_m > 0 && target.mode != LandmarkEvaluationMode::kMarginal) {
    if (why) *why = "the duplicate sweep needs the marginal evaluation";
    return false;
  }
  if (min_track_sightings < 1 || targeted_max_candidates < 0 || !(sweep_radius_m >= 0)) {
    if (why) *why = "tracks need >= 1 sighting and the candidate cap must be >= 0 (0: none)";
    return false;
  }
  if (window_poses < 0 || free_poses < 0 || !(targeted_radius_m >= 0) ||
      !(hill_climb_steps_per_track >= 0) || final_hill_climb_steps < 0 || refine_every < 1 ||
      samples < 0 || num_chains < 1 || burn_in < 0 || (samples > 0 && burn_in >= samples)) {
    if (why)
      *why =
          "windows, steps and samples must be >= 0, refine_every and chains >= 1, burn-in "
          "below the samples";
    return false;
  }
  if (joint_min_inliers < 0 ||
      (joint_min_inliers > 0 &&
       (joint_min_inliers < 3 || joint_recent_poses < 1 || !(joint_search_m > 0) ||
        !(joint_inlier_m > 0) || !(joint_max_rotation_rad >= 0) || joint_ransac_iterations < 1 ||
        joint_anchors < 1 || joint_retry_inliers < 0 || joint_every_poses < 1 ||
        !(joint_max_shift_m >= 0)))) {
    if (why)
      *why =
          "joint merges need >= 3 inliers (0: off), recent poses, RANSAC samples, anchors "
          "and a pose spacing >= 1, distances > 0";
    return false;
  }
  return true;
}

UnknownAssociationResult SolveUnknownAssociation(const LandmarkDataset& input,
                                                 const UnknownAssociationOptions& options_in,
                                                 const LandmarkProgress& progress) {
  const auto start = std::chrono::steady_clock::now();
  std::string why;
  if (!options_in.Validate(&why)) throw Error("unknown-association landmark SLAM: " + why);
  UnknownAssociationOptions options = options_in;
  auto say = [&](const std::string& line) {
    if (progress) progress(line);
  };
  UnknownAssociationResult result;
  for (auto& track : BuildLandmarkTracks(input, input.dead_reckoning, options.tracks)) {
    if (static_cast<int>(track.size()) >= options.min_track_sightings) {
      result.tracks.push_back(std::move(track));
      continue;
    }
    ++result.clutter_tracks;
    result.clutter_sightings += static_cast<long>(track.size());
  }
  // Per-track diameters: the track's mean on its first sighting, the others
  // unmeasured (same sightings, same order, so every index stays valid).
  LandmarkDataset per_track;
  if (options.diameter_per_track) {
    per_track = input;
    for (const auto& track : result.tracks) {
      const std::optional<double> diameter = MeanMeasuredDiameter(input.sightings, track);
      for (int k : track) per_track.sightings[k].diameter_m = std::nan("");
      if (diameter) per_track.sightings[track.front()].diameter_m = *diameter;
    }
  }
  const LandmarkDataset& data = options.diameter_per_track ? per_track : input;
  const int num_tracks = static_cast<int>(result.tracks.size());
  if (num_tracks == 0)
    throw Error::InFile(data.path, "no track of at least " +
                                       std::to_string(options.min_track_sightings) +
                                       " sightings with a range > 0");
  // The prior's centre: the mean of the dead-reckoned sightings.
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  int placed = 0;
  std::vector<int> first_pose(num_tracks), track_size(num_tracks);
  for (int t = 0; t < num_tracks; ++t) {
    first_pose[t] = data.sightings[result.tracks[t].front()].pose;
    track_size[t] = static_cast<int>(result.tracks[t].size());
    for (int k : result.tracks[t]) {
      const LandmarkSighting& s = data.sightings[k];
      centre += LandmarkFromRangeBearing(data.dead_reckoning[s.pose], s.range_m, s.bearing_rad,
                                         data.sensor_offset_m);
      ++placed;
    }
  }
  options.target.slam.landmark_prior_mean_m = centre / placed;
  result.track_time_s = SecondsSince(start);
  say(Format("tracks: %.0f sightings -> %.0f tracks (gate %.2f m, pose gap %.0f), %.2f s",
             double(placed), double(num_tracks), options.tracks.gate_m,
             double(options.tracks.max_pose_gap), result.track_time_s) +
      (result.clutter_tracks > 0
           ? Format("; %.0f shorter tracks (%.0f sightings) left to clutter",
                    double(result.clutter_tracks), double(result.clutter_sightings))
           : std::string()));

  const ClassConfusionModel model =
      ClassConfusionModel::Identity(1, 1e-3, std::vector<int>(num_tracks, 0), track_size);
  std::vector<int> ends;
  if (options.window_poses > 0)
    for (int n = options.window_poses; n < data.num_poses; n += options.window_poses)
      ends.push_back(n);
  ends.push_back(data.num_poses);

  // ---- hill climbing in growing windows ----
  const auto climb_start = std::chrono::steady_clock::now();
  Rng rng(options.seed);
  AssociationState state;
  EvaluationPtr previous;  // last window's final full solve
  int tracks_before = 0;
  std::array<MoveStatistics, 3> stats{};
  std::unique_ptr<LandmarkDataset> window_dataset;  // kept alive with the evaluator
  std::unique_ptr<LandmarkTargetData> window_data;
  std::unique_ptr<LandmarkEvaluator> evaluator;
  EvaluationPtr current;
  // The window's full solves, timed (they dominate a window's cost).
  auto refine = [&](const AssociationState& s, const StateEvaluation* from) {
    const auto t = std::chrono::steady_clock::now();
    EvaluationPtr e = evaluator->Refine(s, from);
    result.refine_time_s += SecondsSince(t);
    ++result.refines;
    return e;
  };
  auto climb = [&](long steps) {
    long accepted = 0;
    for (long step = 1; step <= steps; ++step) {
      const EvaluationPtr before = current;
      StepRule climb;
      climb.greedy = true;
      current = MetropolisStep(current, climb, *evaluator, model, options.moves,
                               options.hill_climb_moves, rng, &stats);
      if (current != before) ++accepted;
      const bool resolve =
          current != before && options.target.mode == LandmarkEvaluationMode::kMarginal;
      if (resolve || step % options.refine_every == 0 || step == steps) {
        const EvaluationPtr refined = refine(current->state, current.get());
        if (refined->valid) current = refined;
      }
    }
    result.proposals += steps;
    result.accepted += accepted;
    return accepted;
  };
  // Targeted merges of the blocks holding tracks >= first_new (see the options).
  // With sweep_m > 0 instead: every pair of landmarks within sweep_m (see
  // UnknownAssociationOptions::sweep_radius_m).
  auto targeted = [&](int first_new, double sweep_m = 0) {
    long merges = 0;
    for (int round = 0; round < 1000; ++round) {
      const AssociationState& s = current->state;
      const double base = current->log_target;
      struct Candidate {
        double delta;
        int a, b;
        EvaluationPtr evaluation;
      };
      std::vector<Candidate> best;
      for (size_t j = 0; j < s.blocks.size(); ++j) {
        if (sweep_m <= 0 && s.blocks[j].back() < first_new) continue;  // no new track
        Candidate c{0, -1, -1, nullptr};
        std::vector<std::pair<double, int>> candidates;  // (distance, block)
        for (size_t k = sweep_m > 0 ? j + 1 : 0; k < s.blocks.size(); ++k) {
          if (k == j || (sweep_m <= 0 && s.blocks[k].back() >= first_new && k < j))
            continue;  // each pair once
          const double d = (current->locations[j] - current->locations[k]).norm();
          if (d <= (sweep_m > 0 ? sweep_m : options.targeted_radius_m))
            candidates.push_back({d, static_cast<int>(k)});
        }
        const size_t cap = static_cast<size_t>(options.targeted_max_candidates);
        if (cap > 0 && candidates.size() > cap) {
          std::nth_element(candidates.begin(), candidates.begin() + cap, candidates.end());
          candidates.resize(cap);
          std::sort(candidates.begin(), candidates.end(),
                    [](const auto& x, const auto& y) { return x.second < y.second; });
        }
        for (const auto& [distance, kk] : candidates) {
          const size_t k = static_cast<size_t>(kk);
          AssociationState merged = s;
          merged.blocks[j].insert(merged.blocks[j].end(), s.blocks[k].begin(), s.blocks[k].end());
          std::sort(merged.blocks[j].begin(), merged.blocks[j].end());
          merged.blocks.erase(merged.blocks.begin() + k);
          merged.classes.pop_back();
          merged.Canonicalize();
          const auto t = std::chrono::steady_clock::now();
          const EvaluationPtr e = evaluator->Evaluate(merged, current.get());
          result.targeted_time_s += SecondsSince(t);
          ++result.proposals;
          if (e->valid && e->log_target - base > c.delta)
            c = {e->log_target - base, static_cast<int>(j), static_cast<int>(k), e};
        }
        if (c.evaluation) best.push_back(c);
      }
      if (best.empty()) break;
      std::sort(best.begin(), best.end(),
                [](const Candidate& x, const Candidate& y) { return x.delta > y.delta; });
      // All non-conflicting best merges at once.
      AssociationState merged = s;
      std::vector<char> used(s.blocks.size(), 0);
      int made = 0;
      for (const Candidate& c : best) {
        if (used[c.a] || used[c.b]) continue;
        used[c.a] = used[c.b] = 1;
        merged.blocks[c.a].insert(merged.blocks[c.a].end(), s.blocks[c.b].begin(),
                                  s.blocks[c.b].end());
        merged.blocks[c.b].clear();
        ++made;
      }
      merged.blocks.erase(std::remove_if(merged.blocks.begin(), merged.blocks.end(),
                                         [](const std::vector<int>& b) { return b.empty(); }),
                          merged.blocks.end());
      merged.classes.assign(merged.blocks.size(), 0);
      for (auto& b : merged.blocks) std::sort(b.begin(), b.end());
      merged.Canonicalize();
      const EvaluationPtr before = current;
      EvaluationPtr refined = refine(merged, best.front().evaluation.get());
      auto fell = [&] { return !refined->valid || refined->log_target <= base; };
      if (fell() && made > 1) {  // only the single best merge
        refined = refine(best.front().evaluation->state, best.front().evaluation.get());
        made = 1;
      }
      if (fell() && best.front().delta > options.cold_retry_gain) {
        // A strong loop closure the warm re-solve could not pull in: solve
        // from dead reckoning (staged), away from the unclosed trajectory.
        ++result.cold_retries;
        refined = refine(best.front().evaluation->state, nullptr);
      }
      if (sweep_m > 0)
        say(Format("sweep: %.0f landmarks with a paying merge, %.0f made, log target %.1f -> %.1f",
                   double(best.size()), double(made), base,
                   refined->valid ? refined->log_target : -1e300));
      if (fell()) {
        // The linearised gain did not hold: back to the state before.
        current = refine(before->state, before.get());
        break;
      }
      current = refined;
      merges += made;
      result.accepted += made;
    }
    return merges;
  };
  // Joint re-entry merges (see the options).
  std::vector<int> last_pose(num_tracks);
  for (int t = 0; t < num_tracks; ++t) last_pose[t] = data.sightings[result.tracks[t].back()].pose;
  int last_ransac = std::numeric_limits<int>::min() / 2;
  int held_poses = 0;  // the current window's (free_poses)
  int joint_needed = options.joint_min_inliers, last_failure = 0;
  auto joint = [&](int n) -> long {
    if (options.joint_min_inliers <= 0 || n - last_ransac < options.joint_every_poses) return 0;
    last_ransac = n;
    const auto joint_start = std::chrono::steady_clock::now();
    struct AddTime {
      std::chrono::steady_clock::time_point start;
      double* total;
      ~AddTime() { *total += SecondsSince(start); }
    } add_time{joint_start, &result.joint_time_s};
    if (n - last_failure > options.joint_recent_poses) joint_needed = options.joint_min_inliers;
    const int recent_from = n - options.joint_recent_poses;
    if (recent_from <= 0) return 0;
    const EvaluationPtr before = current;
    const AssociationState& s = before->state;
    const std::vector<Pose2>& trajectory = before->solution->trajectory;
    // Where the sightings of `tracks` (in the window) put their landmark.
    auto placed = [&](const std::vector<int>& tracks, const std::vector<Pose2>& poses) {
      Eigen::Vector2d sum = Eigen::Vector2d::Zero();
      int count = 0;
      for (int t : tracks)
        for (int k : result.tracks[t]) {
          const LandmarkSighting& z = data.sightings[k];
          if (z.pose >= n) break;
          sum += LandmarkFromRangeBearing(poses[z.pose], z.range_m, z.bearing_rad,
                                          data.sensor_offset_m);
          ++count;
        }
      return Eigen::Vector2d(count > 0 ? Eigen::Vector2d(sum / count) : sum);
    };
    // The units aligned: the recent part of each landmark (its tracks first
    // seen since recent_from, placed by their own sightings: a merge made
    // under the drift may be wrong) and the old part (tracks last seen
    // before recent_from, at the landmark's position).
    struct Unit {
      std::vector<int> tracks;
      Eigen::Vector2d position_m;
    };
    std::vector<Unit> recent, old;
    for (size_t j = 0; j < s.blocks.size(); ++j) {
      Unit r, o;
      for (int t : s.blocks[j]) {
        if (first_pose[t] >= recent_from) r.tracks.push_back(t);
        if (last_pose[t] < recent_from) o.tracks.push_back(t);
      }
      if (!r.tracks.empty()) {
        r.position_m = placed(r.tracks, trajectory);
        recent.push_back(r);
      }
      if (!o.tracks.empty()) {
        o.position_m = before->locations[j].head<2>();
        old.push_back(o);
      }
    }
    if (static_cast<int>(recent.size()) < joint_needed) return 0;
    RigidRansacOptions ransac;
    ransac.search_m = options.joint_search_m;
    ransac.inlier_m = options.joint_inlier_m;
    ransac.max_rotation_rad = options.joint_max_rotation_rad;
    ransac.max_shift_m = options.joint_max_shift_m;
    ransac.iterations = options.joint_ransac_iterations;
    ransac.min_inliers = joint_needed;
    std::vector<Eigen::Vector2d> recent_m, old_m;
    for (const Unit& u : recent) recent_m.push_back(u.position_m);
    for (const Unit& u : old) old_m.push_back(u.position_m);
    const std::optional<RigidMatch> match = MatchRigidly(recent_m, old_m, ransac, rng);
    if (!match) return 0;
    const Rigid2& best_rigid = match->rigid;
    const std::vector<std::pair<int, int>>& pairs = match->pairs;
    const double inlier_m = options.joint_inlier_m;
    // Nothing for a joint merge when the alignment hardly moves the recent
    // landmarks (the single merges can make the pairs) or the pairs are
    // already merged.
    Eigen::Vector2d pivot = Eigen::Vector2d::Zero();
    double largest_move = 0;
    int unmerged = 0;
    for (const auto& [r, o] : pairs) {
      pivot += recent[r].position_m / double(pairs.size());
      largest_move =
          std::max(largest_move, (best_rigid(recent[r].position_m) - recent[r].position_m).norm());
      unmerged += s.BlockOf(recent[r].tracks.front()) != s.BlockOf(old[o].tracks.front());
    }
    if (largest_move < inlier_m || unmerged == 0) return 0;
    if (options.joint_max_shift_m > 0 &&
        (best_rigid(pivot) - pivot).norm() > options.joint_max_shift_m)
      return 0;
    // Per anchor pose: the merges made since it are undone (they were made
    // under the drift), every pair merged, and the state solved from the
    // trajectory with the correction spread along the drive since the anchor.
    std::vector<double> driven(trajectory.size(), 0.0);
    for (size_t i = 1; i < trajectory.size(); ++i)
      driven[i] = driven[i - 1] + std::hypot(trajectory[i].x - trajectory[i - 1].x,
                                             trajectory[i].y - trajectory[i - 1].y);
    const double base = before->log_target;
    EvaluationPtr best;
    int best_anchor = 0;
    for (int k = 0, previous_anchor = -1; k < options.joint_anchors; ++k) {
      const int anchor = std::max(0, n - 1 - (options.joint_recent_poses << k));
      if (anchor == previous_anchor) break;
      previous_anchor = anchor;
      // The correction moves every pose after the anchor: poses held in the
      // window's solves would stay bent, their odometry broken.
      if (anchor + 1 < held_poses) break;
      const double span = driven.back() - driven[anchor];
      if (!(span > 0)) continue;
      auto fraction = [&](int pose) {
        return pose <= anchor ? 0.0 : (driven[pose] - driven[anchor]) / span;
      };
      std::vector<std::vector<int>> blocks;
      std::vector<int> where(num_tracks, -1);
      for (const auto& block : s.blocks)
        for (int part = 0; part < 2; ++part) {
          std::vector<int> tracks;
          for (int t : block)
            if ((first_pose[t] > anchor) == (part == 1)) tracks.push_back(t);
          if (tracks.empty()) continue;
          for (int t : tracks) where[t] = static_cast<int>(blocks.size());
          blocks.push_back(tracks);
        }
      for (const auto& [r, o] : pairs) {
        const int to = where[old[o].tracks.front()];
        for (int t : recent[r].tracks) {
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
      StateEvaluation seed;
      seed.state = merged;
      auto moved = std::make_shared<GeometricSlamResult>();
      moved->trajectory = trajectory;
      for (size_t i = anchor + 1; i < trajectory.size(); ++i) {
        const Rigid2 part = PartOf(best_rigid, pivot, fraction(static_cast<int>(i)));
        Pose2& p = moved->trajectory[i];
        const Eigen::Vector2d q = part(Eigen::Vector2d(p.x, p.y));
        p = {q.x(), q.y(), WrapAngle(p.theta + part.angle)};
      }
      for (const auto& block : merged.blocks) {
        // Where the block's earliest track was, when it is from before the
        // anchor; else where the moved trajectory puts its sightings.
        seed.locations.push_back(Eigen::Vector3d::Zero());
        seed.locations.back().head<2>() =
            first_pose[block.front()] <= anchor
                ? Eigen::Vector2d(before->locations[s.BlockOf(block.front())].head<2>())
                : placed(block, moved->trajectory);
      }
      seed.solution = std::move(moved);
      const EvaluationPtr e = evaluator->Trial(merged, &seed);
      ++result.joint_tries;
      say(Format("joint merge at %.0f poses: %.0f of %.0f recent landmarks onto old ones "
                 "(rotation %.3f rad, shift %.1f m),",
                 double(n), double(pairs.size()), double(recent.size()), best_rigid.angle,
                 (best_rigid(pivot) - pivot).norm()) +
          Format(" correction from pose %.0f: log target %.1f -> %.1f", double(anchor), base,
                 e->valid ? e->log_target : -std::numeric_limits<double>::infinity()));
      if (e->valid && (!best || e->log_target > best->log_target)) {
        best = e;
        best_anchor = anchor;
      }
    }
    if (best) {
      // The merges undone since the anchor may be redone (right this time)
      // by the targeted merges: the try is judged after them.
      current = refine(best->state, best.get());
      if (current->valid && current->log_target <= base && options.targeted_radius_m > 0) {
        const int first_released = static_cast<int>(
            std::upper_bound(first_pose.begin(), first_pose.begin() + num_tracks, best_anchor) -
            first_pose.begin());
        targeted(first_released);
        say(Format("joint merge at %.0f poses: after the targeted merges %.1f (before %.1f)",
                   double(n), current->log_target, base));
      }
      if (current->valid && current->log_target > base) {
        joint_needed = options.joint_min_inliers;
        result.joint_merges += static_cast<long>(pairs.size());
        return static_cast<long>(pairs.size());
      }
      current = refine(before->state, before.get());  // back to before
    }
    joint_needed = static_cast<int>(pairs.size()) + options.joint_retry_inliers;
    last_failure = n;
    return 0;
  };
  for (size_t w = 0; w < ends.size(); ++w) {
    const auto window_start = std::chrono::steady_clock::now();
    const int n = ends[w];
    std::vector<int> kept;
    auto prefix = std::make_unique<LandmarkDataset>(PosePrefix(data, n, &kept));
    std::vector<int> to_prefix(data.sightings.size(), -1);
    for (size_t i = 0; i < kept.size(); ++i) to_prefix[kept[i]] = static_cast<int>(i);
    int tracks_now = tracks_before;
    while (tracks_now < num_tracks && first_pose[tracks_now] < n) ++tracks_now;
    auto target_data = std::make_unique<LandmarkTargetData>();
    target_data->data = prefix.get();
    for (int t = 0; t < tracks_now; ++t) {
      std::vector<int> in;
      for (int k : result.tracks[t])
        if (to_prefix[k] >= 0) in.push_back(to_prefix[k]);
      target_data->tracks.push_back(in);
    }
    LandmarkTargetOptions window_target = options.target;
    const int previous_end = w > 0 ? ends[w - 1] : 0;
    if (options.free_poses > 0)
      window_target.slam.held_poses = std::min(previous_end, std::max(0, n - options.free_poses));
    held_poses = window_target.slam.held_poses;
    auto window_evaluator = std::make_unique<LandmarkEvaluator>(*target_data, window_target);
    if (options.target.one_sighting_per_scan) {
      // Tracks merged in an earlier window may both go on into this one and
      // be seen in one scan: the landmark would have two sightings of it
      // (P = 0). Its tracks stay together, earliest first, while they share
      // no scan; a track that does starts a new landmark (which the targeted
      // merges may join elsewhere).
      std::vector<std::vector<int>> blocks;
      for (const auto& block : state.blocks) {
        const bool goes_on = std::any_of(block.begin(), block.end(), [&](int t) {
          return data.sightings[result.tracks[t].back()].pose >= previous_end;
        });
        if (block.size() < 2 || !goes_on) {  // no new scan can be shared
          blocks.push_back(block);
          continue;
        }
        std::vector<std::vector<int>> parts;
        std::vector<std::set<int>> scans;  // poses seen per part
        for (int t : block) {
          std::vector<int> poses;
          for (int k : result.tracks[t])
            if (data.sightings[k].pose < n) poses.push_back(data.sightings[k].pose);
          size_t p = 0;
          while (p < parts.size() && std::any_of(poses.begin(), poses.end(), [&](int pose) {
                   return scans[p].count(pose) > 0;
                 }))
            ++p;
          if (p == parts.size()) {
            parts.emplace_back();
            scans.emplace_back();
          }
          parts[p].push_back(t);
          scans[p].insert(poses.begin(), poses.end());
        }
        result.scan_splits += static_cast<long>(parts.size()) - 1;
        blocks.insert(blocks.end(), parts.begin(), parts.end());
      }
      state.blocks = std::move(blocks);
    }
    for (int t = tracks_before; t < tracks_now; ++t) state.blocks.push_back({t});
    state.classes.assign(state.blocks.size(), 0);
    state.Canonicalize();
    // Warm start: the previous window's solution, its trajectory continued
    // by the odometry.
    StateEvaluation seed;
    if (previous) {
      seed = *previous;
      auto extended = std::make_shared<GeometricSlamResult>();
      extended->trajectory =
          ExtendByOdometry(previous->solution->trajectory, prefix->dead_reckoning);
      seed.solution = std::move(extended);
    }
    current = window_evaluator->Refine(state, previous ? &seed : nullptr);
    if (!current->valid)
      throw Error::InFile(data.path,
                          "the solve of the first " + std::to_string(n) + " poses failed");
    // Keep the data alive as long as its evaluator.
    evaluator = std::move(window_evaluator);
    window_data = std::move(target_data);
    window_dataset = std::move(prefix);
    const long steps =
        std::lround(options.hill_climb_steps_per_track * double(tracks_now - tracks_before));
    long accepted = options.targeted_radius_m > 0 ? targeted(tracks_before) : 0;
    if (options.sweep_radius_m > 0) accepted += targeted(0, options.sweep_radius_m);
    if (const long joined = joint(n); joined > 0) {
      accepted += joined;
      // The rest of the re-entry: the recent tracks against everything.
      const int recent_from = n - options.joint_recent_poses;
      const int first_recent = static_cast<int>(
          std::lower_bound(first_pose.begin(), first_pose.begin() + tracks_now, recent_from) -
          first_pose.begin());
      if (options.targeted_radius_m > 0) accepted += targeted(first_recent);
    }
    accepted += climb(steps);
    state = current->state;
    previous = current;
    say(Format("window %.0f/%.0f: %.0f poses, %.0f tracks, %.0f steps (%.0f accepted) -> "
               "%.0f landmarks,",
               double(w + 1), double(ends.size()), double(n), double(tracks_now), double(steps),
               double(accepted), double(state.blocks.size())) +
        Format(" log target %.1f, %.2f s (%.0f full solves so far, %.1f s; targeted merges "
               "scored in %.1f s)",
               current->log_target, SecondsSince(window_start), double(result.refines),
               result.refine_time_s, result.targeted_time_s));
    tracks_before = tracks_now;
  }
  if (options.free_poses > 0 && options.free_poses < data.num_poses) {
    // The windows held early poses: solve the whole problem once more.
    auto whole = std::make_unique<LandmarkEvaluator>(*window_data, options.target);
    const EvaluationPtr refined = whole->Refine(current->state, current.get());
    if (refined->valid) current = refined;
    evaluator = std::move(whole);
    say(Format("all poses free: log target %.1f", current->log_target));
  }
  if (options.sweep_radius_m > 0) {
    // The whole trajectory relaxed: duplicates the windows could not join
    // (their drift needed bending poses held then) may be side by side now.
    const long merged = targeted(0, options.sweep_radius_m);
    say(Format("final sweep: %.0f merges, %.0f landmarks, log target %.1f", double(merged),
               double(current->state.blocks.size()), current->log_target));
  }
  if (options.final_hill_climb_steps > 0) {
    const auto pass_start = std::chrono::steady_clock::now();
    const long accepted = climb(options.final_hill_climb_steps);
    state = current->state;
    say(Format("global pass: %.0f steps (%.0f accepted) -> %.0f landmarks, log target %.1f, %.2f s",
               double(options.final_hill_climb_steps), double(accepted),
               double(state.blocks.size()), current->log_target, SecondsSince(pass_start)));
  }
  result.hill_climb_time_s = SecondsSince(climb_start);
  for (const MoveStatistics& s : stats) result.proposal_time_s += s.time_s;
  result.solves = static_cast<long>(evaluator->num_solves());
  result.cache_hits = static_cast<long>(evaluator->num_cache_hits());
  EvaluationPtr best = current;

  // ---- MC³ ----
  if (options.samples > 0) {
    const auto sampling_start = std::chrono::steady_clock::now();
    SamplerOptions sampler_options;
    sampler_options.hill_climb_steps = 0;
    sampler_options.refine_every = options.refine_every;
    sampler_options.sampling_moves = {0.5, 0.5, 0.0};  // one class: nothing to switch
    sampler_options.moves = options.moves;
    sampler_options.num_chains = options.num_chains;
    sampler_options.num_iterations = options.samples;
    sampler_options.burn_in = options.burn_in;
    sampler_options.seed = options.seed;
    const LandmarkTargetData& full_data = *window_data;
    const LandmarkTargetOptions target = options.target;
    Sampler sampler(
        model,
        [&full_data, target]() -> std::unique_ptr<StateEvaluator> {
          return std::make_unique<LandmarkEvaluator>(full_data, target);
        },
        sampler_options);
    size_t last_report = 0;
    const SamplerResult sampled =
        sampler.Run(state, [&](const char* stage, size_t done, size_t total) {
          if (done == total || done >= last_report + std::max<size_t>(1, total / 10)) {
            last_report = done;
            say(std::string(stage) + Format(": %.0f/%.0f", double(done), double(total)));
          }
        });
    result.sampler = sampled.summary;
    if (sampled.best && sampled.best->valid && sampled.best->log_target > best->log_target)
      best = sampled.best;
    result.sampling_time_s = SecondsSince(sampling_start);
    say(Format("MC3: %.0f iterations, %.0f chains, swaps %.0f/%.0f, %.2f s",
               double(options.samples), double(options.num_chains),
               double(sampled.summary.swaps_accepted), double(sampled.summary.swaps_proposed),
               result.sampling_time_s));
  }

  // ---- the best state, solved in full ----
  result.state = best->state;
  result.association = evaluator->Association(result.state);
  result.solution = evaluator->Solve(result.state, best.get());
  result.log_target = result.solution.evidence.log_evidence;
  result.total_time_s = SecondsSince(start);
  say(Format("final solve: %.0f landmarks, log evidence %.1f, total %.2f s",
             double(result.solution.landmarks.size()), result.log_target, result.total_time_s));
  return result;
}

}  // namespace oslam

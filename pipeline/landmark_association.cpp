#include "pipeline/landmark_association.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <utility>

#include "core/angles.h"
#include "core/error.h"
#include "slam/landmark_factors.h"
#include "slam/landmark_noise.h"

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
  if (calibration_rounds < 0 || !(refine_radius_m >= 0) || refine_sweeps < 0) {
    if (why) *why = "calibration rounds, the refine radius and sweeps must be >= 0";
    return false;
  }
  if (calibration_rounds > 0 && !calibration.Validate(why)) return false;
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
       (joint_min_inliers < 3 || !(joint_recent_m > 0) || !(joint_search_m > 0) ||
        !(joint_inlier_m > 0) || !(joint_max_rotation_rad >= 0) || joint_ransac_iterations < 1 ||
        joint_anchors < 1 || joint_every_poses < 1 || joint_repair_rounds < 0 ||
        !(joint_misfit_z > 0) || !(joint_max_shift_m >= 0) || !(joint_score_std_m >= 0) ||
        !(joint_close_ratio >= 0) || !(joint_retry_score >= 0) || !(joint_min_score >= 0) ||
        (joint_close_ratio > 0 && !(joint_score_std_m > 0))))) {
    if (why)
      *why =
          "joint merges need >= 3 inliers (0: off), RANSAC samples, anchors and a pose "
          "spacing >= 1, repair rounds >= 0, a recent span, distances and a misfit z > 0, a "
          "close ratio, retry and least score >= 0 and, with a close ratio, a score std > 0";
    return false;
  }
  return true;
}

UnknownAssociationResult SolveUnknownAssociation(const LandmarkDataset& data,
                                                 const UnknownAssociationOptions& options,
                                                 const LandmarkProgress& progress) {
  return LandmarkAssociation(data, options, progress).Run();
}

LandmarkAssociation::LandmarkAssociation(const LandmarkDataset& data,
                                         const UnknownAssociationOptions& options,
                                         LandmarkProgress progress)
    : input_(data),
      options_(options),
      progress_(std::move(progress)),
      rng_(options.seed),
      last_ransac_(std::numeric_limits<int>::min() / 2) {
  std::string why;
  if (!options.Validate(&why)) throw Error("unknown-association landmark SLAM: " + why);
}

void LandmarkAssociation::Say(const std::string& line) const {
  if (progress_) progress_(line);
}

UnknownAssociationResult LandmarkAssociation::Run() {
  if (ran_) throw Error("unknown-association landmark SLAM: Run() once per object");
  ran_ = true;
  start_ = std::chrono::steady_clock::now();
  BuildTracks();
  if (options_.calibrate_on_tracks) CalibrateOnTracks();
  climb_start_ = std::chrono::steady_clock::now();
  for (size_t w = 0; w < ends_.size(); ++w) RunWindow(w);
  FinalGlobalPass();
  result_.hill_climb_time_s = SecondsSince(climb_start_);
  for (const MoveStatistics& s : stats_) result_.proposal_time_s += s.time_s;
  result_.solves = static_cast<long>(evaluator_->num_solves());
  result_.cache_hits = static_cast<long>(evaluator_->num_cache_hits());
  EvaluationPtr best = current_;
  if (options_.samples > 0) best = SampleMc3(best);
  if (options_.calibration_rounds > 0) best = CalibrateAndRefine(best);
  FinalSolve(best);
  return std::move(result_);
}

void LandmarkAssociation::BuildTracks() {
  for (auto& track : BuildLandmarkTracks(input_, input_.dead_reckoning, options_.tracks)) {
    if (static_cast<int>(track.size()) >= options_.min_track_sightings) {
      result_.tracks.push_back(std::move(track));
      continue;
    }
    ++result_.clutter_tracks;
    result_.clutter_sightings += static_cast<long>(track.size());
  }
  // Per-track diameters: the track's mean on its first sighting, the others
  // unmeasured (same sightings, same order, so every index stays valid).
  if (options_.diameter_per_track) {
    per_track_ = input_;
    for (const auto& track : result_.tracks) {
      const std::optional<double> diameter = MeanMeasuredDiameter(input_.sightings, track);
      for (int k : track) per_track_.sightings[k].diameter_m = std::nan("");
      if (diameter) per_track_.sightings[track.front()].diameter_m = *diameter;
    }
  }
  data_ = stated_ = options_.diameter_per_track ? &per_track_ : &input_;
  const LandmarkDataset& data = *data_;
  num_tracks_ = static_cast<int>(result_.tracks.size());
  if (num_tracks_ == 0)
    throw Error::InFile(data.path, "no track of at least " +
                                       std::to_string(options_.min_track_sightings) +
                                       " sightings with a range > 0");
  // The prior's centre: the mean of the dead-reckoned sightings.
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  int placed = 0;
  first_pose_.resize(num_tracks_);
  last_pose_.resize(num_tracks_);
  track_size_.resize(num_tracks_);
  for (int t = 0; t < num_tracks_; ++t) {
    first_pose_[t] = data.sightings[result_.tracks[t].front()].pose;
    last_pose_[t] = data.sightings[result_.tracks[t].back()].pose;
    track_size_[t] = static_cast<int>(result_.tracks[t].size());
    for (int k : result_.tracks[t]) {
      const LandmarkSighting& s = data.sightings[k];
      centre += LandmarkFromRangeBearing(data.dead_reckoning[s.pose], s.range_m, s.bearing_rad,
                                         data.sensor_offset_m);
      ++placed;
    }
  }
  options_.target.slam.landmark_prior_mean_m = centre / placed;
  driven_m_.assign(data.dead_reckoning.size(), 0.0);
  for (size_t i = 1; i < data.dead_reckoning.size(); ++i)
    driven_m_[i] =
        driven_m_[i - 1] + std::hypot(data.dead_reckoning[i].x - data.dead_reckoning[i - 1].x,
                                      data.dead_reckoning[i].y - data.dead_reckoning[i - 1].y);
  result_.track_time_s = SecondsSince(start_);
  Say(Format("tracks: %.0f sightings -> %.0f tracks (gate %.2f m, pose gap %.0f), %.2f s",
             double(placed), double(num_tracks_), options_.tracks.gate_m,
             double(options_.tracks.max_pose_gap), result_.track_time_s) +
      (result_.clutter_tracks > 0
           ? Format("; %.0f shorter tracks (%.0f sightings) left to clutter",
                    double(result_.clutter_tracks), double(result_.clutter_sightings))
           : std::string()));

  model_.emplace(
      ClassConfusionModel::Identity(1, 1e-3, std::vector<int>(num_tracks_, 0), track_size_));
  if (options_.window_poses > 0)
    for (int n = options_.window_poses; n < data.num_poses; n += options_.window_poses)
      ends_.push_back(n);
  ends_.push_back(data.num_poses);
}

EvaluationPtr LandmarkAssociation::Refine(const AssociationState& state,
                                          const StateEvaluation* from) {
  const auto t = std::chrono::steady_clock::now();
  EvaluationPtr e = evaluator_->Refine(state, from);
  result_.refine_time_s += SecondsSince(t);
  ++result_.refines;
  return e;
}

// ---- a window ----

void LandmarkAssociation::RunWindow(size_t w) {
  const auto window_start = std::chrono::steady_clock::now();
  const int n = ends_[w];
  StartWindow(w);
  const long steps =
      std::lround(options_.hill_climb_steps_per_track * double(tracks_now_ - tracks_before_));
  long accepted = options_.targeted_radius_m > 0 ? TargetedMerges(tracks_before_) : 0;
  if (options_.sweep_radius_m > 0) accepted += DuplicateSweep();
  if (const long joined = JointMerge(n); joined > 0) {
    accepted += joined;
    // The rest of the re-entry: the recent tracks against everything.
    const int recent_from = StretchStart(n, options_.joint_recent_m);
    const int first_recent = static_cast<int>(
        std::lower_bound(first_pose_.begin(), first_pose_.begin() + tracks_now_, recent_from) -
        first_pose_.begin());
    if (options_.targeted_radius_m > 0) accepted += TargetedMerges(first_recent);
  }
  accepted += HillClimb(steps);
  state_ = current_->state;
  previous_ = current_;
  Say(Format("window %.0f/%.0f: %.0f poses, %.0f tracks, %.0f steps (%.0f accepted) -> "
             "%.0f landmarks,",
             double(w + 1), double(ends_.size()), double(n), double(tracks_now_), double(steps),
             double(accepted), double(state_.blocks.size())) +
      Format(" log target %.1f, %.2f s (%.0f full solves so far, %.1f s; targeted merges "
             "scored in %.1f s)",
             current_->log_target, SecondsSince(window_start), double(result_.refines),
             result_.refine_time_s, result_.targeted_time_s));
  tracks_before_ = tracks_now_;
}

void LandmarkAssociation::StartWindow(size_t w) {
  const int n = ends_[w];
  const int previous_end = w > 0 ? ends_[w - 1] : 0;
  tracks_now_ = tracks_before_;
  while (tracks_now_ < num_tracks_ && first_pose_[tracks_now_] < n) ++tracks_now_;
  OpenWindowProblem(n, previous_end);
  if (options_.target.one_sighting_per_scan) SplitSharedScans(previous_end, n);
  for (int t = tracks_before_; t < tracks_now_; ++t) state_.blocks.push_back({t});
  state_.classes.assign(state_.blocks.size(), 0);
  state_.Canonicalize();
  // Warm start: the previous window's solution, its trajectory continued
  // by the odometry.
  StateEvaluation seed;
  if (previous_) {
    seed = *previous_;
    auto extended = std::make_shared<GeometricSlamResult>();
    extended->trajectory =
        ExtendByOdometry(previous_->solution->trajectory, window_dataset_->dead_reckoning);
    seed.solution = std::move(extended);
  }
  current_ = evaluator_->Refine(state_, previous_ ? &seed : nullptr);
  if (!current_->valid)
    throw Error::InFile(data_->path,
                        "the solve of the first " + std::to_string(n) + " poses failed");
}

void LandmarkAssociation::OpenWindowProblem(int n, int previous_end) {
  const LandmarkDataset& data = *data_;
  std::vector<int> kept;
  auto prefix = std::make_unique<LandmarkDataset>(PosePrefix(data, n, &kept));
  std::vector<int> to_prefix(data.sightings.size(), -1);
  for (size_t i = 0; i < kept.size(); ++i) to_prefix[kept[i]] = static_cast<int>(i);
  auto target_data = std::make_unique<LandmarkTargetData>();
  target_data->data = prefix.get();
  for (int t = 0; t < tracks_now_; ++t) {
    std::vector<int> in;
    for (int k : result_.tracks[t])
      if (to_prefix[k] >= 0) in.push_back(to_prefix[k]);
    target_data->tracks.push_back(in);
  }
  LandmarkTargetOptions window_target = options_.target;
  if (options_.free_poses > 0)
    window_target.slam.held_poses = std::min(previous_end, std::max(0, n - options_.free_poses));
  held_poses_ = window_target.slam.held_poses;
  auto window_evaluator = std::make_unique<LandmarkEvaluator>(*target_data, window_target);
  // The old evaluator goes before the data it refers to.
  evaluator_ = std::move(window_evaluator);
  window_data_ = std::move(target_data);
  window_dataset_ = std::move(prefix);
}

// Tracks merged in an earlier window may both go on into this one and be
// seen in one scan: the landmark would have two sightings of it (P = 0). Its
// tracks stay together, earliest first, while they share no scan; a track
// that does starts a new landmark (which the targeted merges may join
// elsewhere).
void LandmarkAssociation::SplitSharedScans(int previous_end, int n) {
  const LandmarkDataset& data = *data_;
  std::vector<std::vector<int>> blocks;
  for (const auto& block : state_.blocks) {
    const bool goes_on = std::any_of(block.begin(), block.end(), [&](int t) {
      return data.sightings[result_.tracks[t].back()].pose >= previous_end;
    });
    if (block.size() < 2 || !goes_on) {  // no new scan can be shared
      blocks.push_back(block);
      continue;
    }
    std::vector<std::vector<int>> parts;
    std::vector<std::set<int>> scans;  // poses seen per part
    for (int t : block) {
      std::vector<int> poses;
      for (int k : result_.tracks[t])
        if (data.sightings[k].pose < n) poses.push_back(data.sightings[k].pose);
      size_t p = 0;
      while (p < parts.size() && std::any_of(poses.begin(), poses.end(),
                                             [&](int pose) { return scans[p].count(pose) > 0; }))
        ++p;
      if (p == parts.size()) {
        parts.emplace_back();
        scans.emplace_back();
      }
      parts[p].push_back(t);
      scans[p].insert(poses.begin(), poses.end());
    }
    result_.scan_splits += static_cast<long>(parts.size()) - 1;
    blocks.insert(blocks.end(), parts.begin(), parts.end());
  }
  state_.blocks = std::move(blocks);
}

long LandmarkAssociation::HillClimb(long steps) {
  long accepted = 0;
  for (long step = 1; step <= steps; ++step) {
    const EvaluationPtr before = current_;
    StepRule climb;
    climb.greedy = true;
    current_ = MetropolisStep(current_, climb, *evaluator_, *model_, options_.moves,
                              options_.hill_climb_moves, rng_, &stats_);
    if (current_ != before) ++accepted;
    const bool resolve =
        current_ != before && options_.target.mode == LandmarkEvaluationMode::kMarginal;
    if (resolve || step % options_.refine_every == 0 || step == steps) {
      const EvaluationPtr refined = Refine(current_->state, current_.get());
      if (refined->valid) current_ = refined;
    }
  }
  result_.proposals += steps;
  result_.accepted += accepted;
  return accepted;
}

// ---- targeted merges and the duplicate sweep ----

long LandmarkAssociation::TargetedMerges(int first_new) {
  return MergeRounds(first_new, 0);
}

long LandmarkAssociation::DuplicateSweep() {
  return MergeRounds(0, options_.sweep_radius_m);
}

// Rounds of BestMerges and MakeMerges until nothing pays.
long LandmarkAssociation::MergeRounds(int first_new, double sweep_m) {
  long merges = 0;
  for (int round = 0; round < 1000; ++round) {
    const std::vector<MergeCandidate> best = BestMerges(first_new, sweep_m);
    if (best.empty()) break;
    int made = 0;
    if (!MakeMerges(best, sweep_m, &made)) break;
    merges += made;
    result_.accepted += made;
  }
  return merges;
}

// The landmarks block j may merge with, (distance, block): those within
// the targeted radius (each pair of new landmarks once), or every later one
// within sweep_m; at most targeted_max_candidates, the nearest.
std::vector<std::pair<double, int>> LandmarkAssociation::MergeCandidatesOf(size_t j, int first_new,
                                                                           double sweep_m) const {
  const AssociationState& s = current_->state;
  std::vector<std::pair<double, int>> candidates;
  for (size_t k = sweep_m > 0 ? j + 1 : 0; k < s.blocks.size(); ++k) {
    if (k == j || (sweep_m <= 0 && s.blocks[k].back() >= first_new && k < j))
      continue;  // each pair once
    const double d = (current_->locations[j] - current_->locations[k]).norm();
    if (d <= (sweep_m > 0 ? sweep_m : options_.targeted_radius_m))
      candidates.push_back({d, static_cast<int>(k)});
  }
  const size_t cap = static_cast<size_t>(options_.targeted_max_candidates);
  if (cap > 0 && candidates.size() > cap) {
    std::nth_element(candidates.begin(), candidates.begin() + cap, candidates.end());
    candidates.resize(cap);
    std::sort(candidates.begin(), candidates.end(),
              [](const auto& x, const auto& y) { return x.second < y.second; });
  }
  return candidates;
}

// The best paying merge of each landmark concerned, best first.
std::vector<LandmarkAssociation::MergeCandidate> LandmarkAssociation::BestMerges(int first_new,
                                                                                 double sweep_m) {
  const AssociationState& s = current_->state;
  const double base = current_->log_target;
  // The candidates of every landmark concerned first, so that the
  // covariance roots of all of them are computed in one batch.
  std::vector<std::vector<std::pair<double, int>>> candidates(s.blocks.size());
  std::vector<int> involved;
  for (size_t j = 0; j < s.blocks.size(); ++j) {
    if (sweep_m <= 0 && s.blocks[j].back() < first_new) continue;  // no new track
    candidates[j] = MergeCandidatesOf(j, first_new, sweep_m);
    if (candidates[j].empty()) continue;
    involved.push_back(static_cast<int>(j));
    for (const auto& c : candidates[j]) involved.push_back(c.second);
  }
  {
    const auto t = std::chrono::steady_clock::now();
    evaluator_->PrepareMerges(involved);
    result_.targeted_time_s += SecondsSince(t);
  }
  std::vector<MergeCandidate> best;
  for (size_t j = 0; j < s.blocks.size(); ++j) {
    MergeCandidate c{0, -1, -1, nullptr};
    for (const auto& [distance, kk] : candidates[j]) {
      const size_t k = static_cast<size_t>(kk);
      AssociationState merged = s;
      merged.blocks[j].insert(merged.blocks[j].end(), s.blocks[k].begin(), s.blocks[k].end());
      std::sort(merged.blocks[j].begin(), merged.blocks[j].end());
      merged.blocks.erase(merged.blocks.begin() + k);
      merged.classes.pop_back();
      merged.Canonicalize();
      const auto t = std::chrono::steady_clock::now();
      const EvaluationPtr e = evaluator_->Evaluate(merged, current_.get());
      result_.targeted_time_s += SecondsSince(t);
      ++result_.proposals;
      if (e->valid && e->log_target - base > c.delta)
        c = {e->log_target - base, static_cast<int>(j), static_cast<int>(k), e};
    }
    if (c.evaluation) best.push_back(c);
  }
  std::sort(best.begin(), best.end(),
            [](const MergeCandidate& x, const MergeCandidate& y) { return x.delta > y.delta; });
  return best;
}

// All non-conflicting merges of `best` at once, re-solved; if the target
// fell, only the single best (from dead reckoning when its gain is large).
// False, with the state before restored, when even that fell.
bool LandmarkAssociation::MakeMerges(const std::vector<MergeCandidate>& best, double sweep_m,
                                     int* made) {
  const EvaluationPtr before = current_;
  const AssociationState& s = before->state;
  const double base = before->log_target;
  AssociationState merged = s;
  std::vector<char> used(s.blocks.size(), 0);
  *made = 0;
  for (const MergeCandidate& c : best) {
    if (used[c.a] || used[c.b]) continue;
    used[c.a] = used[c.b] = 1;
    merged.blocks[c.a].insert(merged.blocks[c.a].end(), s.blocks[c.b].begin(), s.blocks[c.b].end());
    merged.blocks[c.b].clear();
    ++*made;
  }
  merged.blocks.erase(std::remove_if(merged.blocks.begin(), merged.blocks.end(),
                                     [](const std::vector<int>& b) { return b.empty(); }),
                      merged.blocks.end());
  merged.classes.assign(merged.blocks.size(), 0);
  for (auto& b : merged.blocks) std::sort(b.begin(), b.end());
  merged.Canonicalize();
  EvaluationPtr refined = Refine(merged, best.front().evaluation.get());
  auto fell = [&] { return !refined->valid || refined->log_target <= base; };
  if (fell() && *made > 1) {  // only the single best merge
    refined = Refine(best.front().evaluation->state, best.front().evaluation.get());
    *made = 1;
  }
  if (fell() && best.front().delta > options_.cold_retry_gain) {
    // A strong loop closure the warm re-solve could not pull in: solve
    // from dead reckoning (staged), away from the unclosed trajectory.
    ++result_.cold_retries;
    refined = Refine(best.front().evaluation->state, nullptr);
  }
  if (sweep_m > 0)
    Say(Format("sweep: %.0f landmarks with a paying merge, %.0f made, log target %.1f -> %.1f",
               double(best.size()), double(*made), base,
               refined->valid ? refined->log_target : -1e300));
  if (fell()) {
    // The linearised gain did not hold: back to the state before.
    current_ = Refine(before->state, before.get());
    return false;
  }
  current_ = refined;
  return true;
}

// ---- joint re-entry merges (see UnknownAssociationOptions::joint_*) ----

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
  const std::optional<JointAlignment> alignment = AlignRecentOntoOld(*before, n);
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
std::optional<LandmarkAssociation::JointAlignment> LandmarkAssociation::AlignRecentOntoOld(
    const StateEvaluation& before, int n) {
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
  if (static_cast<int>(units.recent.size()) < options_.joint_min_inliers) return std::nullopt;
  RigidRansacOptions ransac;
  ransac.search_m = options_.joint_search_m;
  ransac.inlier_m = options_.joint_inlier_m;
  ransac.max_rotation_rad = options_.joint_max_rotation_rad;
  ransac.max_shift_m = options_.joint_max_shift_m;
  ransac.iterations = options_.joint_ransac_iterations;
  ransac.min_inliers = options_.joint_min_inliers;
  std::vector<Eigen::Vector2d> from, to;
  for (const Unit& u : units.recent) from.push_back(u.position_m);
  for (const Unit& u : units.old) to.push_back(u.position_m);
  ransac.score_std_m = options_.joint_score_std_m;
  RigidMatches matches = MatchRigidlyBothWays(from, to, ransac, rng_);
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
  for (const auto& block : seed.state.blocks) {
    // Where the block's earliest track was, when it is from before the
    // anchor; else where the moved trajectory puts its sightings.
    seed.locations.push_back(Eigen::Vector3d::Zero());
    seed.locations.back().head<2>() =
        first_pose_[block.front()] <= anchor
            ? Eigen::Vector2d(before.locations[before.state.BlockOf(block.front())].head<2>())
            : PlacedBy(block, moved->trajectory, n);
  }
  seed.solution = std::move(moved);
  const EvaluationPtr e = evaluator_->Trial(seed.state, &seed);
  ++result_.joint_tries;
  const EvaluationPtr repaired = e->valid ? WithoutMisfitPairs(e, alignment, n) : e;
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
                                                      const JointAlignment& alignment, int n) {
  split_pairs_ = 0;
  std::vector<bool> split(alignment.match.pairs.size(), false);
  for (int round = 0; round < options_.joint_repair_rounds && e->valid; ++round) {
    std::vector<std::pair<double, int>> misfits;  // (z, pair)
    for (size_t i = 0; i < alignment.match.pairs.size(); ++i) {
      if (split[i]) continue;
      const int t = alignment.recent[alignment.match.pairs[i].first].tracks.front();
      const int j = e->state.BlockOf(t);
      double sightings = 0;
      for (int u : e->state.blocks[j])
        for (int k : result_.tracks[u]) sightings += data_->sightings[k].pose < n;
      const double z = (e->residual2[j] - 2 * sightings) / std::sqrt(4 * std::max(sightings, 1.0));
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

// ---- after the windows ----

void LandmarkAssociation::FinalGlobalPass() {
  if (options_.free_poses > 0 && options_.free_poses < data_->num_poses) {
    // The windows held early poses: solve the whole problem once more.
    auto whole = std::make_unique<LandmarkEvaluator>(*window_data_, options_.target);
    const EvaluationPtr refined = whole->Refine(current_->state, current_.get());
    if (refined->valid) current_ = refined;
    evaluator_ = std::move(whole);
    Say(Format("all poses free: log target %.1f", current_->log_target));
  }
  if (options_.sweep_radius_m > 0) {
    // The whole trajectory relaxed: duplicates the windows could not join
    // (their drift needed bending poses held then) may be side by side now.
    const long merged = DuplicateSweep();
    Say(Format("final sweep: %.0f merges, %.0f landmarks, log target %.1f", double(merged),
               double(current_->state.blocks.size()), current_->log_target));
  }
  if (options_.final_hill_climb_steps > 0) {
    const auto pass_start = std::chrono::steady_clock::now();
    const long accepted = HillClimb(options_.final_hill_climb_steps);
    state_ = current_->state;
    Say(Format("global pass: %.0f steps (%.0f accepted) -> %.0f landmarks, log target %.1f, %.2f s",
               double(options_.final_hill_climb_steps), double(accepted),
               double(state_.blocks.size()), current_->log_target, SecondsSince(pass_start)));
  }
}

// ---- noise calibration and refinement (docs/method.md §16.3) ----

void LandmarkAssociation::CalibrateOnTracks() {
  std::vector<int> association(data_->sightings.size(), -1);
  for (int t = 0; t < num_tracks_; ++t)
    for (int k : result_.tracks[t]) association[k] = t;
  LandmarkSlamOptions slam = options_.target.slam;
  slam.held_poses = 0;
  const NoiseCalibrationResult c =
      CalibrateNoise(*stated_, association, slam, options_.calibration);
  result_.noise_scales = c.scales;
  calibrated_ = WithNoiseScales(*stated_, c.scales);
  data_ = &calibrated_;
  result_.calibration_time_s += c.time_s;
  Say(Format("noise calibration on the tracks: variance x %.3g range, %.3g bearing, %.3g "
             "point, %.3g odometry translation, %.3g heading",
             c.scales.range, c.scales.bearing, c.scales.point, c.scales.odometry_translation,
             c.scales.odometry_heading) +
      Format(" (%.0f outliers left out), %.1f s", double(c.outliers), c.time_s));
}

EvaluationPtr LandmarkAssociation::CalibrateAndRefine(EvaluationPtr best) {
  const auto start = std::chrono::steady_clock::now();
  for (int round = 0; round < options_.calibration_rounds; ++round) {
    current_ = best;
    // The calibration starts from the current solution.
    LandmarkSlamResult warm;
    warm.trajectory = current_->solution->trajectory;
    for (size_t j = 0; j < current_->state.blocks.size(); ++j) {
      MappedLandmark l;
      l.id = current_->state.blocks[j].front();
      l.position_m = current_->locations[j].head<2>();
      warm.landmarks.push_back(l);
    }
    std::sort(warm.landmarks.begin(), warm.landmarks.end(),
              [](const MappedLandmark& a, const MappedLandmark& b) { return a.id < b.id; });
    LandmarkSlamOptions slam = options_.target.slam;
    slam.held_poses = 0;
    const NoiseCalibrationResult c = CalibrateNoise(
        *data_, evaluator_->Association(current_->state), slam, options_.calibration, &warm);
    NoiseScales& total = result_.noise_scales;
    total.range *= c.scales.range;
    total.bearing *= c.scales.bearing;
    total.point *= c.scales.point;
    total.odometry_translation *= c.scales.odometry_translation;
    total.odometry_heading *= c.scales.odometry_heading;
    calibrated_ = WithNoiseScales(*stated_, total);
    data_ = &calibrated_;
    Say(Format("noise calibration %.0f at the association found: variance x %.3g range, %.3g "
               "bearing, %.3g point, %.3g odometry translation, %.3g heading",
               double(round + 1), c.scales.range, c.scales.bearing, c.scales.point,
               c.scales.odometry_translation, c.scales.odometry_heading) +
        Format(" (%.0f outliers left out), %.1f s", double(c.outliers), c.time_s));
    // The whole problem under the calibrated noise, from the calibration's
    // solution.
    OpenWindowProblem(data_->num_poses, 0);
    StateEvaluation seed = *current_;
    auto solution = std::make_shared<GeometricSlamResult>();
    solution->trajectory = c.solution.trajectory;
    seed.solution = std::move(solution);
    for (size_t j = 0; j < seed.state.blocks.size(); ++j) {
      const int id = seed.state.blocks[j].front();
      const auto it = std::lower_bound(c.solution.landmarks.begin(), c.solution.landmarks.end(), id,
                                       [](const MappedLandmark& l, int v) { return l.id < v; });
      if (it != c.solution.landmarks.end() && it->id == id)
        seed.locations[j].head<2>() = it->position_m;
    }
    current_ = Refine(current_->state, &seed);
    if (!current_->valid)
      throw Error::InFile(data_->path, "the solve under the calibrated noise failed");
    const double before = current_->log_target;
    for (int sweep = 0; sweep < options_.refine_sweeps; ++sweep) {
      const long splits = SplitSweep();
      const long merges =
          options_.refine_radius_m > 0 ? MergeRounds(0, options_.refine_radius_m) : 0;
      result_.refine_splits += splits;
      result_.refine_merges += merges;
      Say(
          Format("refinement sweep %.0f: %.0f splits, %.0f merges -> %.0f landmarks, log target "
                 "%.1f",
                 double(sweep + 1), double(splits), double(merges),
                 double(current_->state.blocks.size()), current_->log_target));
      if (splits + merges == 0) break;
    }
    Say(Format("refinement: log target %.1f -> %.1f", before, current_->log_target));
    best = current_;
  }
  result_.calibration_time_s += SecondsSince(start);
  return best;
}

long LandmarkAssociation::SplitSweep() {
  struct Split {
    double delta;
    int block, track;
    EvaluationPtr evaluation;
  };
  long made = 0;
  for (int round = 0; round < 100; ++round) {
    const EvaluationPtr before = current_;
    const AssociationState& s = before->state;
    const double base = before->log_target;
    std::vector<Split> best;
    for (size_t j = 0; j < s.blocks.size(); ++j) {
      if (s.blocks[j].size() < 2) continue;
      Split b{0, -1, -1, nullptr};
      for (int t : s.blocks[j]) {
        AssociationState split = s;
        auto& block = split.blocks[j];
        block.erase(std::find(block.begin(), block.end(), t));
        split.blocks.push_back({t});
        split.classes.assign(split.blocks.size(), 0);
        split.Canonicalize();
        const EvaluationPtr e = evaluator_->Evaluate(split, before.get());
        ++result_.proposals;
        if (e->valid && e->log_target - base > b.delta)
          b = {e->log_target - base, static_cast<int>(j), t, e};
      }
      if (b.evaluation) best.push_back(b);
    }
    if (best.empty()) break;
    std::sort(best.begin(), best.end(),
              [](const Split& x, const Split& y) { return x.delta > y.delta; });
    AssociationState all = s;
    for (const Split& b : best) {
      auto& block = all.blocks[b.block];
      block.erase(std::find(block.begin(), block.end(), b.track));
      all.blocks.push_back({b.track});
    }
    all.classes.assign(all.blocks.size(), 0);
    all.Canonicalize();
    int count = static_cast<int>(best.size());
    EvaluationPtr refined = Refine(all, best.front().evaluation.get());
    auto fell = [&] { return !refined->valid || refined->log_target <= base; };
    if (fell() && count > 1) {
      refined = Refine(best.front().evaluation->state, best.front().evaluation.get());
      count = 1;
    }
    if (fell()) {
      current_ = Refine(before->state, before.get());
      break;
    }
    current_ = refined;
    made += count;
    result_.accepted += count;
  }
  return made;
}

EvaluationPtr LandmarkAssociation::SampleMc3(EvaluationPtr best) {
  const auto sampling_start = std::chrono::steady_clock::now();
  SamplerOptions sampler_options;
  sampler_options.hill_climb_steps = 0;
  sampler_options.hill_climb_sweeps = 0;  // the search above has climbed
  // The temperature step measured for landmark SLAM (docs/method.md §16).
  sampler_options.delta_temperature = 3.33;
  sampler_options.refine_every = options_.refine_every;
  sampler_options.sampling_moves = {0.5, 0.5, 0.0};  // one class: nothing to switch
  sampler_options.moves = options_.moves;
  sampler_options.num_chains = options_.num_chains;
  sampler_options.num_iterations = options_.samples;
  sampler_options.burn_in = options_.burn_in;
  sampler_options.seed = options_.seed;
  const LandmarkTargetData& full_data = *window_data_;
  const LandmarkTargetOptions target = options_.target;
  Sampler sampler(
      *model_,
      [&full_data, target]() -> std::unique_ptr<StateEvaluator> {
        return std::make_unique<LandmarkEvaluator>(full_data, target);
      },
      sampler_options);
  size_t last_report = 0;
  const SamplerResult sampled =
      sampler.Run(state_, [&](const char* stage, size_t done, size_t total) {
        if (done == total || done >= last_report + std::max<size_t>(1, total / 10)) {
          last_report = done;
          Say(std::string(stage) + Format(": %.0f/%.0f", double(done), double(total)));
        }
      });
  result_.sampler = sampled.summary;
  if (sampled.best && sampled.best->valid && sampled.best->log_target > best->log_target)
    best = sampled.best;
  result_.sampling_time_s = SecondsSince(sampling_start);
  Say(Format("MC3: %.0f iterations, %.0f chains, swaps %.0f/%.0f, %.2f s", double(options_.samples),
             double(options_.num_chains), double(sampled.summary.swaps_accepted),
             double(sampled.summary.swaps_proposed), result_.sampling_time_s));
  return best;
}

void LandmarkAssociation::FinalSolve(const EvaluationPtr& best) {
  result_.state = best->state;
  result_.association = evaluator_->Association(result_.state);
  result_.solution = evaluator_->Solve(result_.state, best.get());
  result_.log_target = result_.solution.evidence.log_evidence;
  result_.total_time_s = SecondsSince(start_);
  Say(Format("final solve: %.0f landmarks, log evidence %.1f, total %.2f s",
             double(result_.solution.landmarks.size()), result_.log_target, result_.total_time_s));
}

}  // namespace oslam

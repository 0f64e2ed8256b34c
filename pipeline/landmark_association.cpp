#include "pipeline/landmark_association.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include "core/angles.h"
#include "core/error.h"
#include "core/text.h"
#include "slam/landmark_factors.h"
#include "slam/landmark_noise.h"
#include "solver/fill_reducing_ordering.h"

namespace oslam {

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
  if (threads < 0) {
    if (why) *why = "the thread count must be >= 0";
    return false;
  }
  if (calibration_rounds < 0 || !(refine_radius_m >= 0) || refine_sweeps < 0) {
    if (why) *why = "calibration rounds, the refine radius and sweeps must be >= 0";
    return false;
  }
  if (calibration_rounds > 0 && !calibration.Validate(why)) return false;
  if (!(sighting_split_gate >= 0) || sighting_split_rounds < 0 || !(shared_scan_join_gate >= 0)) {
    if (why) *why = "the sighting split and shared-scan join gates and the rounds must be >= 0";
    return false;
  }
  if (min_track_sightings < 1 || targeted_max_candidates < 0 || !(sweep_radius_m >= 0)) {
    if (why) *why = "tracks need >= 1 sighting and the candidate cap must be >= 0 (0: none)";
    return false;
  }
  if (probation_windows < 0 || !(probation_max_gain >= 0) || !(probation_shift_spacing >= 0)) {
    if (why) *why = "the probation's windows, gain and shift must be >= 0";
    return false;
  }
  if (targeted_repair_rounds < 0) {
    if (why) *why = "the targeted merges' repair rounds must be >= 0";
    return false;
  }
  if (window_poses < 0 || !(window_drift_spacing >= 0) || free_poses < 0 ||
      !(targeted_radius_m >= 0) || !(hill_climb_steps_per_track >= 0) ||
      final_hill_climb_steps < 0 || refine_every < 1 || samples < 0 || num_chains < 1 ||
      burn_in < 0 || (samples > 0 && burn_in >= samples)) {
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
  if (joint_screen_candidates < 0 ||
      (joint_screen_candidates > 0 &&
       (joint_screen_min_inliers < 3 || !(joint_screen_min_score >= 0) ||
        !std::isfinite(joint_screen_min_gain)))) {
    if (why)
      *why =
          "the joint-merge screen needs >= 0 candidates (0: off) and, when on, >= 3 inliers, a "
          "least score >= 0 and a finite least gain";
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
  options_.target.slam.solver.threads = options.threads;
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
  PlanWindows();
  climb_start_ = std::chrono::steady_clock::now();
  RunWindows();
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
  if (options_.landmark_density_from_data) {
    const double density = SightingDensityPerM2(data);
    if (!(density > 0)) throw Error::InFile(data.path, "no sighting to estimate the density from");
    options_.target.slam.landmark_density_per_m2 = density;
    options_.target.slam.landmark_prior_std_m = 0;
    Say(Format("landmark density from the sightings: %.3g per m2", density));
  }
  result_.slam_options = options_.target.slam;
  result_.slam_options.compute_landmark_covariances = false;
  result_.slam_options.compute_pose_covariances = false;
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
}

// After the calibration: the drift bound uses the odometry noise searched under.
void LandmarkAssociation::PlanWindows() {
  const bool needs_spacing = options_.window_drift_spacing > 0 || options_.probation_windows > 0;
  spacing_m_ = needs_spacing ? MedianCoVisibleSpacing(*data_) : 0.0;
  const double spacing_m = spacing_m_;
  const double max_drift_m = options_.window_drift_spacing * spacing_m;
  ends_ = SearchWindowEnds(*data_, options_.window_poses, max_drift_m);
  if (max_drift_m > 0)
    Say(
        Format("windows: %.0f of at most %.0f poses, ended where the drift reaches %.2f m (%.2f "
               "of the landmarks' spacing, %.2f m)",
               double(ends_.size()), double(options_.window_poses), max_drift_m,
               options_.window_drift_spacing, spacing_m));
}

EvaluationPtr LandmarkAssociation::Refine(const AssociationState& state,
                                          const StateEvaluation* from) {
  const auto t = std::chrono::steady_clock::now();
  EvaluationPtr e = evaluator_->Refine(state, from);
  result_.refine_time_s += SecondsSince(t);
  ++result_.refines;
  return e;
}

// ---- the windows, weak loop closures on probation ----

void LandmarkAssociation::RunWindows() {
  for (size_t w = 0; w < ends_.size(); ++w) {
    std::optional<WindowStart> start;
    if (options_.probation_windows > 0 && !probation_) start = SaveWindowStart(w);
    weak_closures_.clear();
    RunWindow(w);
    if (start && !weak_closures_.empty())
      probation_ = Probation{std::move(*start), weak_closures_,
                             w + static_cast<size_t>(options_.probation_windows)};
    if (probation_ && (w >= probation_->decide_after || w + 1 == ends_.size())) DecideProbation(w);
  }
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
  Say(Format("%swindow %.0f/%.0f: %.0f poses, %.0f tracks, %.0f steps (%.0f accepted) -> "
             "%.0f landmarks,",
             replaying_ ? "again: " : "", double(w + 1), double(ends_.size()), double(n),
             double(tracks_now_), double(steps), double(accepted), double(state_.blocks.size())) +
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
  NoteOrdering(n, *current_);
}

// Each window has a new evaluator, whose solver would compare the ordering
// kinds (AMD, CAMD, METIS) afresh: 7 % of the 10k world's time went to
// METIS alone. The winner is kept until the problem has grown by a 50th
// (as the solver does between similar problems, FillReducingOrdering).
OrderingType LandmarkAssociation::WindowOrdering(int n) const {
  const OrderingType requested = options_.target.slam.solver.ordering;
  if (requested != OrderingType::kAutomatic || ordering_compared_poses_ < 0 ||
      n > ordering_compared_poses_ * (1 + FillReducingOrdering::kSimilarProblemFraction))
    return requested;
  return compared_ordering_;
}

void LandmarkAssociation::NoteOrdering(int n, const StateEvaluation& solved) {
  if (options_.target.slam.solver.ordering != OrderingType::kAutomatic ||
      WindowOrdering(n) != OrderingType::kAutomatic || !solved.solution ||
      solved.solution->summary.ordering == OrderingType::kAutomatic)
    return;  // not compared in this window
  compared_ordering_ = solved.solution->summary.ordering;
  ordering_compared_poses_ = n;
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
  window_target.slam.solver.ordering = WindowOrdering(n);
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
    // The periodic re-solve is for states the moves evaluated locally; the
    // last full solve's state needs none (on the 10k world 351 of 779 window
    // solves were of such states, at the end of climbs that changed nothing).
    const bool periodic =
        (step % options_.refine_every == 0 || step == steps) && !evaluator_->IsReference(*current_);
    if (resolve || periodic) {
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
  std::set<std::pair<int, int>> barred;  // pairs of blocks
  for (const auto& [ta, tb] : barred_) {
    const int a = ta < tracks_now_ ? s.BlockOf(ta) : -1, b = tb < tracks_now_ ? s.BlockOf(tb) : -1;
    if (a >= 0 && b >= 0 && a != b) barred.insert(std::minmax(a, b));
  }
  std::vector<MergeCandidate> best;
  const auto t = std::chrono::steady_clock::now();
  for (size_t j = 0; j < s.blocks.size(); ++j) {
    MergeCandidate c{0, -1, -1, nullptr};
    for (const auto& [distance, k] : candidates[j]) {
      if (!barred.empty() && barred.count(std::minmax(static_cast<int>(j), k))) continue;
      ++result_.proposals;
      // Most pairs in closed form; the state itself only where that fails.
      double gain = 0;
      EvaluationPtr e;
      if (!evaluator_->MergeGain(*current_, static_cast<int>(j), k, &gain)) {
        e = evaluator_->Evaluate(s.WithBlocksMerged(static_cast<int>(j), k), current_.get());
        gain = e->valid ? e->log_target - base : -std::numeric_limits<double>::infinity();
      }
      if (gain > c.delta) c = {gain, static_cast<int>(j), k, e};
    }
    if (c.a >= 0) best.push_back(c);
  }
  std::sort(best.begin(), best.end(),
            [](const MergeCandidate& x, const MergeCandidate& y) { return x.delta > y.delta; });
  // The best one's evaluation warm-starts the re-solve.
  if (!best.empty() && !best.front().evaluation)
    best.front().evaluation =
        evaluator_->Evaluate(s.WithBlocksMerged(best.front().a, best.front().b), current_.get());
  result_.targeted_time_s += SecondsSince(t);
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
  std::vector<char> used(s.blocks.size(), 0);
  std::vector<std::pair<int, int>> pairs;  // the merges made, blocks of s
  for (const MergeCandidate& c : best) {
    if (used[c.a] || used[c.b]) continue;
    used[c.a] = used[c.b] = 1;
    pairs.push_back({c.a, c.b});
  }
  *made = static_cast<int>(pairs.size());
  EvaluationPtr refined = Refine(WithBlockPairsMerged(s, pairs), best.front().evaluation.get());
  auto fell = [&] { return !refined->valid || refined->log_target <= base; };
  if (fell() && *made > 1) refined = WithoutMisfitMerges(refined, s, &pairs, made);
  if (fell() && *made > 1) {  // only the single best merge
    refined = Refine(best.front().evaluation->state, best.front().evaluation.get());
    *made = 1;
    pairs = {{best.front().a, best.front().b}};
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
  if (sweep_m <= 0) NoteWeakClosure(*before, *refined, pairs);
  current_ = refined;
  return true;
}

// `s` with block b of each pair (a, b) moved into block a, canonical.
AssociationState LandmarkAssociation::WithBlockPairsMerged(
    const AssociationState& s, const std::vector<std::pair<int, int>>& pairs) {
  AssociationState merged = s;
  for (const auto& [a, b] : pairs) {
    merged.blocks[a].insert(merged.blocks[a].end(), s.blocks[b].begin(), s.blocks[b].end());
    merged.blocks[b].clear();
  }
  merged.blocks.erase(std::remove_if(merged.blocks.begin(), merged.blocks.end(),
                                     [](const std::vector<int>& b) { return b.empty(); }),
                      merged.blocks.end());
  for (auto& b : merged.blocks) std::sort(b.begin(), b.end());
  merged.classes.assign(merged.blocks.size(), 0);
  merged.Canonicalize();
  return merged;
}

// How badly landmark j of `e` fits its sightings in the window: the squared
// whitened residual r2 of its n sightings standardised as
// (r2 - 2n) / sqrt(4n), the chi-square's mean and spread.
double LandmarkAssociation::MisfitZ(const StateEvaluation& e, int j) const {
  double sightings = 0;
  for (int t : e.state.blocks[j]) sightings += double(window_data_->tracks[t].size());
  return (e.residual2[j] - 2 * sightings) / std::sqrt(4 * std::max(sightings, 1.0));
}

// A batch of merges whose re-solve lowered the target: as the joint
// merges' repair (WithoutMisfitPairs), the merges whose landmark misfits
// after the solve (z of its squared whitened residual above
// joint_misfit_z and at least half the worst) are undone and the rest
// re-solved, at most targeted_repair_rounds times while the target stays
// below the state before. A re-entry's batch with one wrong pair among
// right ones then keeps the right ones (the wrong pair bends the solve, so
// the right ones near it misfit too, though less); otherwise the caller
// falls back to the single best merge.
EvaluationPtr LandmarkAssociation::WithoutMisfitMerges(EvaluationPtr e,
                                                       const AssociationState& before,
                                                       std::vector<std::pair<int, int>>* pairs,
                                                       int* made) {
  const double base = current_->log_target;
  for (int round = 0; round < options_.targeted_repair_rounds && e->valid; ++round) {
    std::vector<std::pair<double, size_t>> misfits;  // (z, pair)
    for (size_t i = 0; i < pairs->size(); ++i) {
      const double z = MisfitZ(*e, e->state.BlockOf(before.blocks[(*pairs)[i].second].front()));
      if (z > options_.joint_misfit_z) misfits.push_back({z, i});
    }
    if (misfits.empty()) break;
    const double worst_z = std::max_element(misfits.begin(), misfits.end())->first;
    std::vector<char> undo(pairs->size(), 0);
    for (const auto& [z, i] : misfits) undo[i] = z >= worst_z / 2;
    std::vector<std::pair<int, int>> kept;
    for (size_t i = 0; i < pairs->size(); ++i)
      if (!undo[i]) kept.push_back((*pairs)[i]);
    e = Refine(WithBlockPairsMerged(before, kept), e.get());
    *pairs = std::move(kept);
    *made = static_cast<int>(pairs->size());
    if (e->valid && e->log_target > base) break;
  }
  return e;
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
  NoiseCalibrationOptions calibration = options_.calibration;
  calibration.final_solve = false;  // only the scales are used
  const NoiseCalibrationResult c = CalibrateNoise(*stated_, association, slam, calibration);
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
    const LandmarkSlamResult warm = evaluator_->WarmStart(*current_);
    LandmarkSlamOptions slam = options_.target.slam;
    slam.held_poses = 0;
    // Only the calibration's solution itself seeds the re-solve below.
    slam.compute_landmark_covariances = slam.compute_pose_covariances = false;
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
      if (const MappedLandmark* landmark = c.solution.FindLandmark(id))
        seed.locations[j].head<2>() = landmark->position_m;
    }
    current_ = Refine(current_->state, &seed);
    if (!current_->valid)
      throw Error::InFile(data_->path, "the solve under the calibrated noise failed");
    const double before = current_->log_target;
    for (int sweep = 0; sweep < options_.refine_sweeps; ++sweep) {
      const long splits = SplitSweep() + LeverageSplits();
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
        ++result_.proposals;
        // Most splits from the reference's local values; the state itself
        // only where that does not apply.
        double gain = 0;
        EvaluationPtr e;
        if (!evaluator_->SplitGain(*before, static_cast<int>(j), t, &gain)) {
          e = evaluator_->Evaluate(s.WithTrackMoved(t, -1, 0), before.get());
          gain = e->valid ? e->log_target - base : -std::numeric_limits<double>::infinity();
        }
        if (gain > b.delta) b = {gain, static_cast<int>(j), t, e};
      }
      if (b.block >= 0) best.push_back(b);
    }
    if (best.empty()) break;
    std::sort(best.begin(), best.end(),
              [](const Split& x, const Split& y) { return x.delta > y.delta; });
    // The best one's evaluation warm-starts the re-solve.
    if (!best.front().evaluation)
      best.front().evaluation =
          evaluator_->Evaluate(s.WithTrackMoved(best.front().track, -1, 0), before.get());
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
  // The track scan and the cold chain's 2 steps were measured on O-SLAM
  // scenes only (docs/method.md §9.4); landmark MC3 keeps the sampler it had.
  sampler_options.cold_chain_steps = 3;
  sampler_options.track_scan_max = 0;
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
  if (SightingSplitsOn()) SplitMisfitSightings();
  result_.total_time_s = SecondsSince(start_);
  Say(Format("final solve: %.0f landmarks, log evidence %.1f, total %.2f s",
             double(result_.solution.landmarks.size()), result_.log_target, result_.total_time_s));
}

}  // namespace oslam

// The probation of weak loop closures in LandmarkAssociation (docs/method.md
// §16.2): a window's start saved, the search's path taken aside and put back,
// and the windows since a weak closure run again without it.
#include "pipeline/landmark_association.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/text.h"

namespace oslam {

LandmarkAssociation::WindowStart LandmarkAssociation::SaveWindowStart(size_t w) const {
  return {w,
          state_,
          previous_,
          tracks_before_,
          rng_,
          compared_ordering_,
          ordering_compared_poses_,
          last_ransac_,
          joint_needed_score_,
          last_failure_};
}

void LandmarkAssociation::RestoreWindowStart(const WindowStart& start) {
  state_ = start.state;
  previous_ = start.previous;
  tracks_before_ = start.tracks_before;
  rng_ = start.rng;
  compared_ordering_ = start.compared_ordering;
  ordering_compared_poses_ = start.ordering_compared_poses;
  last_ransac_ = start.last_ransac;
  joint_needed_score_ = start.joint_needed_score;
  last_failure_ = start.last_failure;
}

LandmarkAssociation::SearchPath LandmarkAssociation::TakePath() {
  SearchPath path;
  path.start = SaveWindowStart(0);
  path.current = std::move(current_);
  path.tracks_now = tracks_now_;
  path.held_poses = held_poses_;
  path.split_pairs = split_pairs_;
  path.evaluator = std::move(evaluator_);  // before the data it refers to
  path.window_data = std::move(window_data_);
  path.window_dataset = std::move(window_dataset_);
  return path;
}

void LandmarkAssociation::PutPath(SearchPath path) {
  RestoreWindowStart(path.start);
  current_ = std::move(path.current);
  tracks_now_ = path.tracks_now;
  held_poses_ = path.held_poses;
  split_pairs_ = path.split_pairs;
  evaluator_ = std::move(path.evaluator);
  window_data_ = std::move(path.window_data);
  window_dataset_ = std::move(path.window_dataset);
}

// After window w: the windows from the probation's own run again with its
// merges barred; the path with the higher target at window w's end (the
// same poses, tracks and model: comparable) goes on.
void LandmarkAssociation::DecideProbation(size_t w) {
  Probation probation = std::move(*probation_);
  probation_.reset();
  const double kept_target = current_->log_target;
  SearchPath kept = TakePath();
  const size_t barred_before = barred_.size();
  barred_.insert(barred_.end(), probation.pairs.begin(), probation.pairs.end());
  RestoreWindowStart(probation.start);
  replaying_ = true;
  for (size_t v = probation.start.window; v <= w; ++v) RunWindow(v);
  replaying_ = false;
  ++result_.probations;
  // A tie (both paths made the same merges another way: a joint merge, a
  // later window's) keeps the path as it was.
  constexpr double kTieNats = 0.01;
  const bool undone = current_->valid && current_->log_target > kept_target + kTieNats;
  Say(
      Format("probation of %.0f merges from window %.0f: log target %.1f with them, %.1f without "
             "-> %s",
             double(probation.pairs.size()), double(probation.start.window + 1), kept_target,
             current_->valid ? current_->log_target : -1e300, undone ? "undone" : "kept"));
  if (undone) {
    ++result_.probations_undone;
    return;
  }
  barred_.resize(barred_before);
  PutPath(std::move(kept));
}

void LandmarkAssociation::NoteWeakClosure(const StateEvaluation& before,
                                          const StateEvaluation& after,
                                          const std::vector<std::pair<int, int>>& pairs) {
  if (options_.probation_windows <= 0 || replaying_ || probation_ || !before.solution ||
      !after.solution || !(after.log_target - before.log_target < options_.probation_max_gain))
    return;
  const auto& from = before.solution->trajectory;
  const auto& to = after.solution->trajectory;
  double shift_m = 0;
  for (size_t i = 0; i < std::min(from.size(), to.size()); ++i)
    shift_m = std::max(shift_m, std::hypot(to[i].x - from[i].x, to[i].y - from[i].y));
  if (!(shift_m > options_.probation_shift_spacing * spacing_m_)) return;
  for (const auto& [a, b] : pairs)
    weak_closures_.push_back({before.state.blocks[a].front(), before.state.blocks[b].front()});
  Say(Format("probation: %.0f merges gaining %.2f moved a pose by %.1f m", double(pairs.size()),
             after.log_target - before.log_target, shift_m));
}

}  // namespace oslam

// The sighting-level phase of LandmarkAssociation (docs/method.md §16.2):
// high-leverage one-sighting tracks split off in the refinement, and after
// the final solve landmarks joined across a shared scan, misfit sightings
// and high-leverage ones split off, each kept on the evidence.
#include "pipeline/landmark_association.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <tuple>
#include <utility>

#include "core/text.h"
#include "slam/landmark_factors.h"
#include "slam/landmark_reference.h"

namespace oslam {

// Not with per-track diameters: a track's one diameter would go with the
// sighting that carries it.
bool LandmarkAssociation::SightingSplitsOn() const {
  return options_.sighting_split_gate > 0 && options_.sighting_split_rounds > 0 &&
         !options_.diameter_per_track;
}

long LandmarkAssociation::LeverageSplits() {
  if (!SightingSplitsOn()) return 0;
  LandmarkSlamOptions slam_options = options_.target.slam;
  slam_options.compute_landmark_covariances = slam_options.compute_pose_covariances = false;
  LandmarkSlam slam(slam_options);
  const LandmarkSlamResult warm = evaluator_->WarmStart(*current_);
  const std::vector<int> flagged =
      HighLeverageTracks(&slam, evaluator_->Association(current_->state), &warm);
  long made = 0;
  EvaluationPtr reference = current_;  // the evaluator's reference
  for (size_t i = 0; i < flagged.size() && static_cast<int>(i) < options_.sighting_split_rounds;
       ++i) {
    const int track = flagged[i];
    reference = Refine(current_->state.WithTrackMoved(track, -1, 0), current_.get());
    if (reference->valid && reference->log_target > current_->log_target) {
      current_ = reference;
      ++made;
    }
  }
  if (reference != current_) current_ = Refine(current_->state, current_.get());
  return made;
}

// A sighting that alone ties a landmark to a stretch of the drive has high
// leverage: a wrong one (a clutter return) turns the whole map to fit it, so
// its own residual stays small and only its deleted residual shows it
// (DeletedSightingErrors; docs/method.md §16.2).
std::vector<int> LandmarkAssociation::HighLeverageTracks(LandmarkSlam* slam,
                                                         const std::vector<int>& association,
                                                         const LandmarkSlamResult* warm_start) {
  const LandmarkDataset& data = *data_;
  const LandmarkSlamResult solved = slam->Solve(data, association, warm_start);
  if (!solved.summary.IsUsable()) return {};
  std::map<int, int> count;
  for (int id : association)
    if (id >= 0) ++count[id];
  std::vector<int> candidates, sightings;  // tracks of one sighting in a landmark with others
  for (int t = 0; t < num_tracks_; ++t) {
    const std::vector<int>& track = result_.tracks[t];
    if (track.size() == 1 && association[track.front()] >= 0 &&
        count[association[track.front()]] >= 2) {
      candidates.push_back(t);
      sightings.push_back(track.front());
    }
  }
  const std::vector<SightingErrors> errors =
      DeletedSightingErrors(data, association, solved, slam, sightings, slam->options().held_poses);
  std::vector<std::pair<double, int>> leveraged;  // (deleted error, track)
  for (size_t c = 0; c < candidates.size(); ++c)
    // Above the gate only once deleted: the residual rounds judge the rest.
    if (errors[c].at_solve <= options_.sighting_split_gate &&
        errors[c].deleted > options_.sighting_split_gate)
      leveraged.push_back({errors[c].deleted, candidates[c]});
  std::sort(leveraged.rbegin(), leveraged.rend());
  std::vector<int> tracks;
  for (const auto& l : leveraged) tracks.push_back(l.second);
  return tracks;
}

bool LandmarkAssociation::KeepIfBetter(LandmarkSlam* slam, std::vector<int> trial, long splits) {
  LandmarkSlamResult solved = slam->Solve(*data_, trial, &result_.solution);
  if (!solved.summary.IsUsable() || !solved.evidence.valid ||
      !(solved.evidence.log_evidence > result_.log_target))
    return false;
  result_.association = std::move(trial);
  result_.solution = std::move(solved);
  result_.log_target = result_.solution.evidence.log_evidence;
  result_.sighting_splits += splits;
  return true;
}

long LandmarkAssociation::JoinAcrossSharedScans(LandmarkSlam* slam, int* next_id) {
  const LandmarkDataset& data = *data_;
  std::map<int, std::vector<int>> members;  // landmark -> its sightings
  for (size_t k = 0; k < result_.association.size(); ++k)
    if (result_.association[k] >= 0) members[result_.association[k]].push_back(int(k));
  auto poses_of = [&](int id) {
    std::map<int, int> at;  // pose -> sighting
    for (int k : members[id]) at[data.sightings[k].pose] = k;
    return at;
  };
  // Pairs whose positions agree within the gate and that share a scan. Two
  // landmarks seen from the same scans are placed relative to each other by
  // their sightings alone (the poses' uncertainty is common to both): the
  // gate takes each one's covariance given the poses, not its marginal,
  // which the drive's drift makes metres wide.
  std::vector<std::tuple<double, int, int>> pairs;  // (squared distance in sigmas, a, b)
  const std::vector<MappedLandmark>& marks = result_.solution.landmarks;
  std::vector<Eigen::Matrix2d> given_poses(marks.size(), Eigen::Matrix2d::Zero());
  for (size_t i = 0; i < marks.size(); ++i) {
    Eigen::Matrix2d information = Eigen::Matrix2d::Zero();
    for (int k : members[marks[i].id])
      information += SightingInformation(data.sightings[k],
                                         result_.solution.trajectory[data.sightings[k].pose],
                                         marks[i].position_m, data.sensor_offset_m);
    if (std::abs(information.determinant()) > 0) given_poses[i] = information.inverse();
  }
  for (size_t i = 0; i < marks.size(); ++i)
    for (size_t j = i + 1; j < marks.size(); ++j) {
      const Eigen::Vector2d d = marks[i].position_m - marks[j].position_m;
      const Eigen::Matrix2d s = given_poses[i] + given_poses[j];
      const Eigen::LLT<Eigen::Matrix2d> llt(s);
      if (llt.info() != Eigen::Success || !(s.determinant() > 0)) continue;
      const double m2 = d.dot(llt.solve(d));
      if (!(m2 <= options_.shared_scan_join_gate)) continue;
      const std::map<int, int> a = poses_of(marks[i].id), b = poses_of(marks[j].id);
      bool shared = false;
      for (const auto& entry : b) shared = shared || a.count(entry.first);
      if (shared) pairs.emplace_back(m2, marks[i].id, marks[j].id);
    }
  std::sort(pairs.begin(), pairs.end());
  std::set<int> touched;
  long joined = 0;
  for (const auto& [m2, a, b] : pairs) {
    if (touched.count(a) || touched.count(b)) continue;
    const MappedLandmark* la = result_.solution.FindLandmark(a);
    const MappedLandmark* lb = result_.solution.FindLandmark(b);
    if (!la || !lb) continue;
    const double na = double(members[a].size()), nb = double(members[b].size());
    const Eigen::Vector2d joint = (na * la->position_m + nb * lb->position_m) / (na + nb);
    std::vector<int> trial = result_.association;
    for (int k : members[b]) trial[k] = a;
    const std::map<int, int> at_a = poses_of(a), at_b = poses_of(b);
    int split = 0;
    for (const auto& [pose, kb] : at_b) {
      const auto ka = at_a.find(pose);
      if (ka == at_a.end()) continue;
      // The one of the scan's two sightings farther from the joint place goes.
      auto error = [&](int k) {
        return SightingSquaredError(data.sightings[k], result_.solution.trajectory[pose], joint,
                                    data.sensor_offset_m);
      };
      trial[error(ka->second) > error(kb) ? ka->second : kb] = *next_id + split++;
    }
    // Every sighting of one of them split off again: no join, only new ids.
    const auto kept_of = [&](int id) {
      int kept = 0;
      for (int k : members[id]) kept += trial[k] == a;
      return kept;
    };
    if (kept_of(a) == 0 || kept_of(b) == 0) continue;
    if (!KeepIfBetter(slam, std::move(trial), split)) continue;
    *next_id += split;
    touched.insert(a);
    touched.insert(b);
    ++joined;
  }
  return joined;
}

void LandmarkAssociation::SplitMisfitSightings() {
  // The trials go without covariances; the result gets them at the end.
  LandmarkSlam slam(result_.slam_options);
  const double before = result_.log_target;
  int next_id = num_tracks_;
  for (const int id : result_.association) next_id = std::max(next_id, id + 1);
  result_.shared_scan_joins = JoinAcrossSharedScans(&slam, &next_id);
  for (int round = 0; round < options_.sighting_split_rounds; ++round) {
    const std::vector<int> misfits = WorstMisfitSightings(
        *data_, result_.association, result_.solution, options_.sighting_split_gate, 2);
    if (misfits.empty()) break;
    // All of the round's misfits, else the worst alone.
    bool kept = false;
    for (const size_t n : {misfits.size(), size_t{1}}) {
      std::vector<int> trial = result_.association;
      for (size_t j = 0; j < n; ++j) trial[misfits[j]] = next_id + static_cast<int>(j);
      if (KeepIfBetter(&slam, std::move(trial), static_cast<long>(n))) {
        next_id += static_cast<int>(n);
        kept = true;
        break;
      }
      if (misfits.size() == 1) break;
    }
    if (!kept) break;
  }
  int tried = 0;
  for (const int t : HighLeverageTracks(&slam, result_.association, &result_.solution)) {
    if (tried++ == options_.sighting_split_rounds) break;
    std::vector<int> trial = result_.association;
    trial[result_.tracks[t].front()] = next_id;
    if (KeepIfBetter(&slam, std::move(trial), 1)) {
      ++next_id;
      ++result_.leverage_splits;
    }
  }
  if (result_.sighting_splits == 0) return;
  LandmarkSlamOptions with_covariances = result_.slam_options;
  with_covariances.compute_landmark_covariances = true;
  result_.solution =
      LandmarkSlam(with_covariances).Solve(*data_, result_.association, &result_.solution);
  result_.log_target = result_.solution.evidence.log_evidence;
  Say(
      Format("sighting splits: %.0f sightings split off their tracks (%.0f of high leverage; "
             "%.0f landmarks joined across a shared scan), log target %.1f -> %.1f",
             double(result_.sighting_splits), double(result_.leverage_splits),
             double(result_.shared_scan_joins), before, result_.log_target));
}

}  // namespace oslam

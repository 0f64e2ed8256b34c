#include "association/tracks.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "core/angles.h"
#include "core/error.h"

namespace oslam {

bool TrackOptions::Validate(std::string* why) const {
  auto fail = [why](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (!(max_radius_change_px > 0)) return fail("the track radius gate must be > 0 px");
  if (!(max_angle_change_rad > 0)) return fail("the track angle gate must be > 0 rad");
  if (!(max_relative_size_change > 0)) return fail("the track size gate must be > 0");
  if (min_length < 1) return fail("the minimum track length must be >= 1");
  if (max_gap_frames < 0) return fail("the track gap must be >= 0 frames");
  return true;
}

bool PassesTrackGate(const BoundingSlice& a, const BoundingSlice& b, const TrackOptions& options) {
  const double ds_r = std::abs(a.s_r_px - b.s_r_px);
  const double ds_phi = std::abs(a.s_phi_rad - b.s_phi_rad);
  return std::abs(a.u_r_px - b.u_r_px) < options.max_radius_change_px &&
         std::abs(WrapAngle(a.u_phi_rad - b.u_phi_rad)) < options.max_angle_change_rad &&
         ds_r < options.max_relative_size_change * std::min(a.s_r_px, b.s_r_px) &&
         ds_phi < options.max_relative_size_change * std::min(a.s_phi_rad, b.s_phi_rad);
}

namespace {

// Gate distance normalised by the gate widths: ranks candidates for kNearest.
double GateDistance(const BoundingSlice& a, const BoundingSlice& b, const TrackOptions& options) {
  const double dr = (a.u_r_px - b.u_r_px) / options.max_radius_change_px;
  const double dphi = WrapAngle(a.u_phi_rad - b.u_phi_rad) / options.max_angle_change_rad;
  return std::sqrt(dr * dr + dphi * dphi);
}

struct Candidate {
  double distance;
  int from, to;
};

// Links between the detections of frame f (from) and frame f+1 (to).
std::vector<std::pair<int, int>> LinkFrames(const std::vector<ClassedSlice>& detections,
                                            const std::vector<int>& from,
                                            const std::vector<int>& to, const TrackOptions& options,
                                            TrackSummary* summary) {
  std::vector<Candidate> candidates;
  std::map<int, int> count;
  for (int a : from)
    for (int b : to)
      if (detections[a].class_index == detections[b].class_index &&
          PassesTrackGate(detections[a].slice, detections[b].slice, options)) {
        candidates.push_back(
            {GateDistance(detections[a].slice, detections[b].slice, options), a, b});
        ++count[a];
        ++count[b];
      }
  for (const auto& [index, n] : count)
    if (n > 1) ++summary->num_ambiguous;
  // Closest first, ties by index, so the result does not depend on sort stability.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
    return std::tie(x.distance, x.from, x.to) < std::tie(y.distance, y.from, y.to);
  });
  std::vector<std::pair<int, int>> links;
  std::map<int, bool> used;
  for (const Candidate& c : candidates) {
    if (used[c.from] || used[c.to]) continue;
    if (options.link_rule == TrackLinkRule::kRefuseAmbiguous &&
        (count[c.from] > 1 || count[c.to] > 1))
      continue;
    used[c.from] = used[c.to] = true;
    links.push_back({c.from, c.to});
  }
  return links;
}

}  // namespace

TrackSet BuildTracks(const std::vector<ClassedSlice>& detections, const TrackOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error(why);
  TrackSet result;
  result.summary.num_detections = static_cast<int>(detections.size());
  std::map<long, std::vector<int>> by_frame;
  for (int i = 0; i < static_cast<int>(detections.size()); ++i)
    by_frame[detections[i].frame].push_back(i);

  // next[i] = the detection that continues i's track in the next frame.
  std::vector<int> next(detections.size(), -1), previous(detections.size(), -1);
  for (const auto& [frame, members] : by_frame) {
    const auto following = by_frame.find(frame + 1);
    if (following == by_frame.end()) continue;
    for (const auto& [a, b] :
         LinkFrames(detections, members, following->second, options, &result.summary)) {
      next[a] = b;
      previous[b] = a;
      ++result.summary.num_links;
    }
  }
  // Joins across 1..max_gap_frames missed frames (docs/method.md §9.7), shortest gap
  // first: track ends at frame f and track starts at f + 1 + gap, with the
  // gate widths multiplied by the frame difference.
  for (int gap = 1; gap <= options.max_gap_frames; ++gap) {
    TrackOptions widened = options;
    const double scale = gap + 1.0;
    widened.max_radius_change_px *= scale;
    widened.max_angle_change_rad *= scale;
    widened.max_relative_size_change *= scale;
    TrackSummary ignored;
    for (const auto& [frame, members] : by_frame) {
      const auto later = by_frame.find(frame + 1 + gap);
      if (later == by_frame.end()) continue;
      std::vector<int> ends, starts;
      for (int a : members)
        if (next[a] < 0) ends.push_back(a);
      for (int b : later->second)
        if (previous[b] < 0) starts.push_back(b);
      if (ends.empty() || starts.empty()) continue;
      for (const auto& [a, b] : LinkFrames(detections, ends, starts, widened, &ignored)) {
        next[a] = b;
        previous[b] = a;
        ++result.summary.num_links;
        ++result.summary.num_gap_links;
      }
    }
  }
  // Walk the chains from their heads, in frame order (map) then index order.
  for (const auto& [frame, members] : by_frame)
    for (int head : members) {
      if (previous[head] >= 0) continue;
      Track track;
      track.class_index = detections[head].class_index;
      for (int i = head; i >= 0; i = next[i]) track.detections.push_back(i);
      ++result.summary.num_tracks_before_filter;
      if (static_cast<int>(track.detections.size()) < options.min_length) {
        result.summary.num_dropped_detections += static_cast<int>(track.detections.size());
        continue;
      }
      track.id = static_cast<int>(result.tracks.size());
      result.tracks.push_back(std::move(track));
    }
  return result;
}

}  // namespace oslam

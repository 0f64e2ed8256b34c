#include "association/landmark_tracks.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "core/error.h"
#include "slam/landmark_factors.h"

namespace oslam {

bool LandmarkTrackOptions::Validate(std::string* why) const {
  if (!(gate_m > 0) || !std::isfinite(gate_m)) {
    if (why) *why = "the track gate must be > 0 m and finite";
    return false;
  }
  if (max_pose_gap < 1) {
    if (why) *why = "the track's pose gap must be >= 1";
    return false;
  }
  return true;
}

std::vector<std::vector<int>> BuildLandmarkTracks(const LandmarkDataset& data,
                                                  const std::vector<Pose2>& trajectory,
                                                  const LandmarkTrackOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("landmark tracks: " + why);
  if (static_cast<int>(trajectory.size()) != data.num_poses)
    throw Error("landmark tracks: the trajectory has " + std::to_string(trajectory.size()) +
                " poses for " + std::to_string(data.num_poses));
  std::vector<int> order;
  for (size_t k = 0; k < data.sightings.size(); ++k)
    if (data.sightings[k].range_m > 0) order.push_back(static_cast<int>(k));
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return data.sightings[a].pose < data.sightings[b].pose; });
  struct Active {
    int track, last_pose;
    Eigen::Vector2d last_m;
  };
  std::vector<std::vector<int>> tracks;
  std::vector<Active> active;
  const double gate2 = options.gate_m * options.gate_m;
  for (size_t begin = 0; begin < order.size();) {
    const int pose = data.sightings[order[begin]].pose;
    size_t end = begin;
    while (end < order.size() && data.sightings[order[end]].pose == pose) ++end;
    active.erase(
        std::remove_if(active.begin(), active.end(),
                       [&](const Active& a) { return pose - a.last_pose > options.max_pose_gap; }),
        active.end());
    const size_t n = end - begin;
    std::vector<Eigen::Vector2d> world(n);
    std::vector<int> claim(n, -1);  // index into `active`
    std::vector<int> claims(active.size(), 0);
    for (size_t i = 0; i < n; ++i) {
      const LandmarkSighting& s = data.sightings[order[begin + i]];
      world[i] = LandmarkFromRangeBearing(trajectory[pose], s.range_m, s.bearing_rad,
                                          data.sensor_offset_m);
      int candidates = 0;
      for (size_t a = 0; a < active.size(); ++a)
        if ((active[a].last_m - world[i]).squaredNorm() <= gate2) {
          ++candidates;
          claim[i] = static_cast<int>(a);
        }
      if (candidates != 1) claim[i] = -1;  // none, or ambiguous
      if (claim[i] >= 0) ++claims[claim[i]];
    }
    std::vector<Active> next;
    for (size_t i = 0; i < n; ++i) {
      const int k = order[begin + i];
      if (claim[i] >= 0 && claims[claim[i]] == 1) {
        Active& a = active[claim[i]];
        tracks[a.track].push_back(k);
        a.last_pose = pose;
        a.last_m = world[i];
      } else {
        tracks.push_back({k});
        next.push_back({static_cast<int>(tracks.size()) - 1, pose, world[i]});
      }
    }
    active.insert(active.end(), next.begin(), next.end());
    begin = end;
  }
  return tracks;
}

}  // namespace oslam

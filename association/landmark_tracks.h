// Pre-association of planar landmark sightings into tracks: the atoms the
// landmark sampler's state partitions (it merges tracks, never splits one).
#pragma once

#include <string>
#include <vector>

#include "core/pose2.h"
#include "slam/landmark_data.h"

namespace oslam {

// A sighting joins a track when the track's last sighting is from an earlier
// pose at most max_pose_gap poses back and its world position (sighting
// placed by the trajectory) is within gate_m of the track's last one. A
// sighting with two or more tracks inside the gate, or a track claimed by two
// sightings of one scan, starts afresh (tracks must be certain; the sampler
// merges what is left apart).
struct LandmarkTrackOptions {
  double gate_m = 1.0;
  int max_pose_gap = 20;

  bool Validate(std::string* why) const;
};

// Sighting indices per track in pose order, tracks ordered by their first
// sighting. Sightings at range 0 (no bearing) are in no track. Throws
// oslam::Error when the trajectory does not cover the data set's poses.
std::vector<std::vector<int>> BuildLandmarkTracks(const LandmarkDataset& data,
                                                  const std::vector<Pose2>& trajectory,
                                                  const LandmarkTrackOptions& options);

// How far apart neighbouring landmarks typically stand, measured where no
// odometry enters: per sighting, the distance to the nearest other sighting
// of the same scan (both placed in the robot frame); the median over every
// scan with two or more. 0 when no scan has two.
double MedianCoVisibleSpacing(const LandmarkDataset& data);

// The landmarks per square metre the sensor's view suggests, for a location
// prior that matches the data (docs/method.md §16.2): sightings per scan
// over the area one scan sees, the ring sector between the 1st and 99th
// percentiles of the range and of the bearing (2 pi at most). Every scan
// counts, empty ones too. A lower bound where the sensor misses landmarks in
// view. 0 when no sighting has a range > 0.
double SightingDensityPerM2(const LandmarkDataset& data);

// The growing windows of the unknown-association search (docs/method.md
// §16.2), as pose counts (each window ends before its count; the last is
// num_poses). A window holds at most max_poses poses; with max_drift_m > 0 it
// ends earlier, at the first pose whose dead-reckoned sightings, relative to
// the pose before the window, have a predicted position std above
// max_drift_m: sqrt(largest eigenvalue of the position covariance +
// (median range * heading std)^2), the odometry's covariances composed along
// the chain (first order). max_poses 0: one window unless the drift ends it.
std::vector<int> SearchWindowEnds(const LandmarkDataset& data, int max_poses, double max_drift_m);

}  // namespace oslam

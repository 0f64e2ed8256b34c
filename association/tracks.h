// Pre-association of detections into atomic tracks (docs/method.md §9.7, eq. 6.1,
// Algorithm 9 steps 1-2): detections of the same detected class in
// consecutive frames are linked when all four gates hold; chains of links
// form tracks, and tracks shorter than a minimum length are dropped as
// spurious. The sampler never splits a track.
#pragma once

#include <string>
#include <vector>

#include "core/bounding_slice.h"

namespace oslam {

// A detection as mapping needs it (detect::Detection without the pixels).
struct ClassedSlice {
  long frame = 0;
  int class_index = 0;  // detected class a_ik
  BoundingSlice slice;
};

// When several candidates pass the gate (docs/method.md §13 #20, [G]).
enum class TrackLinkRule {
  kNearest,          // one-to-one, closest pairs (normalised gate distance) first
  kRefuseAmbiguous,  // link only pairs where both sides have a single candidate
};

struct TrackOptions {
  double max_radius_change_px = 30.0;      // |du_r| (eq. 6.1)
  double max_angle_change_rad = 0.349066;  // |du_phi|, 20 degrees ("20" read as degrees, #20)
  double max_relative_size_change = 0.2;   // |ds| < 0.2 min(s, s') for s_r and s_phi
  int min_length = 3;                      // N_min (3 in the class-confusion runs, 2 in §6.2)
  TrackLinkRule link_rule = TrackLinkRule::kNearest;
  // Beyond the thesis (docs/method.md §9.7): a track that ends and one that
  // starts up to this many missed frames later (an occlusion, a missed
  // detection) are joined when they have the same detected class and pass
  // the eq. 6.1 gate widened by the frame difference; shortest gaps first,
  // one-to-one, before the short-track filter. 0 = the thesis (consecutive
  // frames only).
  int max_gap_frames = 0;

  bool Validate(std::string* why) const;
};

struct Track {
  int id = 0;                   // index in TrackSet::tracks, ordered by (first frame, first index)
  int class_index = 0;          // the detected class shared by all its detections
  std::vector<int> detections;  // indices into the input, in frame order
};

struct TrackSummary {
  int num_detections = 0;
  int num_links = 0;
  int num_gap_links = 0;  // of num_links: joins across missed frames (max_gap_frames)
  int num_ambiguous = 0;  // detections with more than one gated candidate
  int num_tracks_before_filter = 0;
  int num_dropped_detections = 0;  // in tracks shorter than min_length
};

struct TrackSet {
  std::vector<Track> tracks;
  TrackSummary summary;
};

// Whether two detections in consecutive frames pass the eq. 6.1 gate (class
// is not checked here).
bool PassesTrackGate(const BoundingSlice& a, const BoundingSlice& b, const TrackOptions& options);

// Throws oslam::Error on invalid options. Detections may come in any order.
TrackSet BuildTracks(const std::vector<ClassedSlice>& detections, const TrackOptions& options);

}  // namespace oslam

// The parameters of `oslam slam` (and `oslam map`, `oslam run`'s slam
// section): declared once as command-line options whose defaults come from
// the mapping code's option structs, and turned back into those structs.
// Kept apart from the command so tests can check that every option reaches
// its field.
#pragma once

#include "apps/arguments.h"
#include "association/nn_baseline.h"
#include "association/omap_fusion.h"
#include "association/sampler.h"
#include "association/slam_target.h"
#include "association/tracks.h"

namespace oslam {

struct SlamSettings {
  TrackOptions tracks;
  SlamTargetOptions target;  // E, motion noise Q, solver, P(C, J)
  SamplerOptions sampler;    // MC3, moves
  FusionOptions fusion;      // spurious model, identity merging
  NearestNeighbourOptions baseline;
  double confusion_floor = 1e-3;                            // smallest P(a | c) (spec §13 #12)
  double location_std_xy_m = 10.0, location_std_z_m = 2.0;  // Gamma(c) (spec §13 #7)
  bool known_classes = false;
  // log P(a | c) counted once per track (default) or once per detection
  // (eq. 4.32 as printed). A track's detections are one object seen frame
  // after frame in the same light, so the detector's class decisions within
  // it are not independent draws; counting each one made the class term
  // outweigh the size prior and the geometry (long_loop: classes 8/11 ->
  // 10/11 per track; lab: 6/7 -> 7/7 and the door no longer mapped twice).
  bool class_likelihood_per_detection = false;
};

// Declares every O-SLAM parameter (not RUN_DIR, -o, --detections, --quiet).
void AddSlamOptions(Arguments* arguments);

// The options structs of a parsed command line. Throws UsageError (one line,
// naming the option) for malformed or invalid values.
SlamSettings SlamSettingsFrom(const Arguments& arguments);

}  // namespace oslam

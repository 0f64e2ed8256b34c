// The parameters of `oslam slam` (and `oslam map`, `oslam run`'s slam
// section): declared once as command-line options whose defaults come from
// the mapping code's option structs, and turned back into those structs.
// Kept apart from the command so tests can check that every option reaches
// its field.
#pragma once

#include "apps/arguments.h"
#include "mapping/nn_baseline.h"
#include "mapping/omap_fusion.h"
#include "mapping/sampler.h"
#include "mapping/slam_target.h"
#include "mapping/tracks.h"

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
};

// Declares every O-SLAM parameter (not RUN_DIR, -o, --detections, --quiet).
void AddSlamOptions(Arguments* arguments);

// The options structs of a parsed command line. Throws UsageError (one line,
// naming the option) for malformed or invalid values.
SlamSettings SlamSettingsFrom(const Arguments& arguments);

}  // namespace oslam

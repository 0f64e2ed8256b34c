// Baseline for comparison with O-SLAM (docs/method.md §7.3): gated nearest-neighbour data
// association of the tracks followed by one geometric solve. Each track, in
// time order, joins the nearest object of its detected class whose current
// location (mean of its tracks' locations in the all-separate solution) is
// within the gate, or starts a new object.
#pragma once

#include "association/association_state.h"

namespace oslam {

struct NearestNeighbourOptions {
  double gate_m = 0.5;  // 3-D distance, the same scale as the merge threshold d_thr
  bool Validate(std::string* why) const;
};

// `separate` is the evaluation of the all-tracks-separate state.
AssociationState NearestNeighbourAssociation(const StateEvaluation& separate,
                                             const NearestNeighbourOptions& options);

}  // namespace oslam

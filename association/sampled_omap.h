// O-SLAM's fused samples as an O-Map (docs/omap-format.md, "O-SLAM
// fields"): each object with its class histogram, identity and the sample
// identities combined into it, and the sampler's convergence report
// ("sampler").
#pragma once

#include "association/omap_fusion.h"
#include "association/sampler.h"
#include "omap/omap.h"

namespace oslam {

// `summary` may be null (the nearest-neighbour baseline): no "sampler" report.
OMap ToOMap(const FusionResult& fused, const OMapSource& source, const SamplerSummary* summary);

}  // namespace oslam

// The O-Map of O-SLAM as JSON: the format of docs/omap-format.md (readable by
// ReadOMap) with each object's existence probability and class histogram,
// and a "sampler" section (docs/omap-format.md, "O-SLAM fields").
#pragma once

#include <string>

#include "omap/omap.h"
#include "association/omap_fusion.h"
#include "association/sampler.h"

namespace oslam {

struct SampledOMapSource {
  std::string run_dir;
  std::string detections;
  std::string association;  // "o-slam (MC3)", "nearest neighbour"
  unsigned long seed = 0;
};

// summary may be null (baseline). Non-finite numbers become null.
std::string SampledOMapToJson(const FusionResult& fused, const SampledOMapSource& source,
                              const SamplerSummary* summary);
void WriteSampledOMap(const std::string& path, const FusionResult& fused,
                      const SampledOMapSource& source, const SamplerSummary* summary);

}  // namespace oslam

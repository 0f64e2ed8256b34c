// The O-Map as JSON (docs/omap-format.md): the one reader and writer of
// omap.json, whichever method made the map.
#pragma once

#include <string>

#include "omap/omap.h"

namespace oslam {

// Whether the map's timing (OMap::timing) goes into the file, as the member
// "timing". Left out by default: the file is then the same for the same
// input and seed.
enum class OMapTiming { kOmit, kInclude };

// The file's text. Non-finite numbers become null (JSON has no NaN); the
// reports are written as they are after the trajectory. Throws oslam::Error
// when a report is not valid JSON or its name is taken by another member.
std::string OMapToJson(const OMap& map, OMapTiming timing = OMapTiming::kOmit);

// Written atomically.
void WriteOMap(const std::string& path, const OMap& map, OMapTiming timing = OMapTiming::kOmit);

// Reads what WriteOMap writes (and hand-made maps that leave out the
// optional members). Throws oslam::Error naming the file and the field on
// anything malformed.
OMap ReadOMap(const std::string& path);

}  // namespace oslam

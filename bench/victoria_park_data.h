// The real Victoria Park data for the landmark benchmarks: GTSAM's
// victoria_park.txt (with its landmark ids) read once, or null when
// ../shared/data is absent (the benchmarks then skip with a message).
#pragma once

#include <filesystem>

#include "slam/landmark_data.h"

namespace oslam {

inline const LandmarkDataset* VictoriaPark() {
  static const LandmarkDataset* data = []() -> const LandmarkDataset* {
    const std::filesystem::path path = std::filesystem::path(OSLAM_SOURCE_DIR).parent_path() /
                                       "shared/data/victoria_park/with_ids/victoria_park.txt";
    if (!std::filesystem::exists(path)) return nullptr;
    return new LandmarkDataset(ReadGtsamLandmarks(path.string()));
  }();
  return data;
}

}  // namespace oslam

// The classes of a simulated run trained as `oslam train-colors
// --from-ground-truth` trains them: colour boxes from the ground truth's
// pixels at 3 sigma, then the image shapes and the detector's arc errors.
#pragma once

#include <string>
#include <vector>

#include "core/run_folder.h"
#include "detect/colour_training.h"

namespace oslam {

inline std::vector<ObjectClass> ClassesTrainedOnGroundTruth(const std::string& run) {
  const std::vector<ObjectClass> untrained = ReadClasses(run + "/classes.yaml");
  return MeasureDetectorErrors(
      LearnImageShapes(TrainColourModels(untrained, ExamplesFromGroundTruth(run, untrained), 3.0),
                       run),
      run);
}

}  // namespace oslam

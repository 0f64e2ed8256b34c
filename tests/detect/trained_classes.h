// The classes of a simulated run trained as `oslam train-colors
// --from-ground-truth` trains them: colour boxes from the ground truth's
// pixels at 3 sigma, then the image shapes and the detector's arc errors and
// blob colours; and a detector scored on such a run.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "calib/camera_io.h"
#include "core/run_folder.h"
#include "detect/blob_detector.h"
#include "detect/colour_training.h"
#include "detect/evaluation.h"

namespace oslam {

inline std::vector<ObjectClass> ClassesTrainedOnGroundTruth(const std::string& run) {
  const std::vector<ObjectClass> untrained = ReadClasses(run + "/classes.yaml");
  return MeasureDetectorErrors(
      LearnImageShapes(TrainColourModels(untrained, ExamplesFromGroundTruth(run, untrained), 3.0),
                       run),
      run);
}

// The blob detector with `options` over every frame of a simulated run,
// scored against its ground truth.
inline DetectionEvaluation EvaluateDetectorOnRun(const std::string& run,
                                                 const std::vector<ObjectClass>& classes,
                                                 const BlobDetectorOptions& options) {
  const std::unique_ptr<CameraModel> camera = LoadCamera(run + "/camera.yaml");
  const BlobDetector detector(*camera, classes, options);
  const FrameSource frames(run);
  std::vector<Detection> all;
  for (size_t i = 0; i < frames.size(); ++i)
    for (const Detection& d : detector.Detect(frames.Read(i), static_cast<long>(i)))
      all.push_back(d);
  return EvaluateDetections(all, *ReadGroundTruth(run), classes);
}

}  // namespace oslam

// oslam eval-detect: a run's detections against its ground truth.
#include <cstdio>
#include <memory>

#include "apps/arguments.h"
#include "apps/bindings.h"
#include "apps/commands.h"
#include "calib/camera_io.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "detect/evaluation.h"

namespace oslam {

int RunEvalDetectCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam eval-detect RUN_DIR [--detections FILE] [--json FILE]",
                      "Precision and recall per class and bounding-slice errors of a run's "
                      "detections,\nagainst the run's ground_truth/ (simulated runs).");
  arguments.AddPositional("RUN_DIR", "the run folder (with ground_truth/)");
  arguments.AddOption("detections", "", "FILE", "detections CSV", "RUN_DIR/detections.csv");
  DetectionEvaluationOptions options;
  Bindings bindings;
  bindings.Add(&options.max_range_m, "max-range", "M",
               "objects farther than this do not count for recall");
  bindings.Add(&options.min_visible_fraction, "min-visible", "F",
               "sightings less visible do not count for recall");
  bindings.Declare(&arguments);
  arguments.AddOption("json", "", "FILE", "also write the figures as JSON");
  arguments.AddOption("write-confusion", "", "CLASSES.yaml",
                      "store the measured class confusion P(detected | true) in this classes "
                      "file (the one O-SLAM reads)");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  bindings.Apply(arguments);
  const std::string run_dir = arguments.Get("RUN_DIR");

  const std::optional<GroundTruth> truth = ReadGroundTruth(run_dir);
  if (!truth) throw Error::InFile(run_dir, "no ground_truth/ folder");
  const std::vector<ObjectClass> classes = ReadClasses(RunFolderPaths::Of(run_dir).classes);
  const std::string detections_path = arguments.Has("detections")
                                          ? arguments.Get("detections")
                                          : RunFolderPaths::Of(run_dir).detections;
  const DetectionEvaluation evaluation =
      EvaluateDetections(ReadDetections(detections_path, classes), *truth, classes, options);
  // Signed slice errors per class: the detector's share against the visible
  // pixels, the models' against the truth (docs/detection.md).
  const std::vector<VisibleSlice> visible = ReadVisibleSlices(run_dir);
  std::vector<ClassSliceErrors> signed_errors;
  if (!visible.empty()) {
    const std::unique_ptr<CameraModel> camera = LoadCamera(RunFolderPaths::Of(run_dir).camera);
    signed_errors = SignedSliceErrorsPerClass(ReadDetections(detections_path, classes), *truth,
                                              visible, classes, *camera, options);
  }
  if (!arguments.Flag("quiet")) {
    std::fputs(evaluation.Table().c_str(), stdout);
    if (!signed_errors.empty()) std::fputs(SignedSliceErrorsTable(signed_errors).c_str(), stdout);
  }
  if (arguments.Has("json")) {
    std::string json = evaluation.Json();
    if (!signed_errors.empty()) {
      // The object's closing brace: add the per-class signed errors before it.
      json.erase(json.rfind('}'));
      while (!json.empty() && (json.back() == '\n' || json.back() == ' ')) json.pop_back();
      json += ",\n  \"signed_slice_errors\": " + SignedSliceErrorsJson(signed_errors) + "\n}\n";
    }
    WriteTextFileAtomically(arguments.Get("json"), json);
  }
  if (arguments.Has("write-confusion")) {
    const std::string path = arguments.Get("write-confusion");
    const std::vector<ObjectClass> target = ReadClasses(path);
    if (target.size() != classes.size())
      throw Error::InFile(path, "has " + std::to_string(target.size()) + " classes, the run has " +
                                    std::to_string(classes.size()));
    for (size_t c = 0; c < classes.size(); ++c)
      if (target[c].name != classes[c].name)
        throw Error::InFile(path, "class " + std::to_string(c) + " is '" + target[c].name +
                                      "', the run's is '" + classes[c].name + "'");
    const ConfusionMatrix confusion = ConfusionFromCounts(evaluation.confusion_counts);
    WriteClasses(target, path, confusion);
    if (!arguments.Flag("quiet"))
      std::printf("wrote the measured confusion into %s\n", path.c_str());
  }
  return 0;
}

}  // namespace oslam

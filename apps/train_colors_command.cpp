// oslam train-colors: learn the classes' YUV colour boxes from example regions
// and store them, with the class-confusion matrix, in classes.yaml.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "calib/camera_io.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "core/text.h"
#include "detect/colour_classifier.h"
#include "detect/colour_training.h"

namespace oslam {

int RunTrainColorsCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam train-colors CLASSES.yaml --examples EXAMPLES.yaml [-o OUT.yaml]",
                      "Learns each class's colour model (YUV mean and standard deviation of its "
                      "example pixels;\nbox = mean ± k·σ) and the class-confusion matrix, and "
                      "writes them into classes.yaml.");
  arguments.AddPositional("CLASSES.yaml", "the classes to train (updated in place unless -o)");
  arguments.AddOption("examples", "", "EXAMPLES.yaml",
                      "example regions per class (docs/detection.md, Training)");
  arguments.AddOption("camera", "", "CAMERA.yaml",
                      "with --examples marked outline: 1, the camera of their images\n"
                      "(default: camera.yaml beside CLASSES.yaml)");
  arguments.AddOption(
      "from-ground-truth", "", "RUN_DIR",
      "instead of --examples: ROIs on the ground-truth objects of a simulated run;\n"
      "also learns each class's image shape (slice elongation) from its views");
  arguments.AddOption("k-sigma", "", "K", "half-width of the colour box in standard deviations",
                      "3");
  arguments.AddOption("blob-colour-floor", "", "F",
                      "least spread of the learnt blob colour, as a share of the colour box's\n"
                      "(docs/detection.md, Verification by the blob's mean colour)",
                      Format("%g", kDefaultBlobChromaFloor));
  arguments.AddOption("output", "-o", "OUT.yaml", "where to write (default: CLASSES.yaml)");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (arguments.Has("examples") == arguments.Has("from-ground-truth"))
    throw UsageError("give exactly one of --examples and --from-ground-truth");
  const double k_sigma = arguments.GetDouble("k-sigma");
  if (!(k_sigma > 0)) throw UsageError("--k-sigma must be positive");
  const double blob_colour_floor = arguments.GetDouble("blob-colour-floor");
  if (!(blob_colour_floor > 0) || std::isinf(blob_colour_floor))
    throw UsageError("--blob-colour-floor must be positive");
  if (arguments.Has("camera") && !arguments.Has("examples"))
    throw UsageError("--camera applies only with --examples (outline examples)");

  const std::string classes_path = arguments.Get("CLASSES.yaml");
  const std::vector<ObjectClass> classes = ReadClasses(classes_path);
  const std::vector<ColourExample> examples =
      arguments.Has("examples")
          ? ReadColourExamples(arguments.Get("examples"), classes)
          : ExamplesFromGroundTruth(arguments.Get("from-ground-truth"), classes);
  std::vector<ObjectClass> trained = TrainColourModels(classes, examples, k_sigma);
  const bool has_outlines = std::any_of(examples.begin(), examples.end(),
                                        [](const ColourExample& e) { return e.outline; });
  if (arguments.Has("examples") && has_outlines) {
    const std::string camera_path =
        arguments.Has("camera")
            ? arguments.Get("camera")
            : (std::filesystem::path(classes_path).parent_path() / "camera.yaml").string();
    if (!std::filesystem::exists(camera_path))
      throw Error::InFile(
          camera_path, "not found: outline examples need the camera (give --camera CAMERA.yaml)");
    const std::unique_ptr<CameraModel> camera = LoadCamera(camera_path);
    trained =
        MeasureDetectorErrorsFromExamples(LearnImageShapesFromExamples(trained, examples, *camera),
                                          examples, *camera, 3, blob_colour_floor);
  }
  if (arguments.Has("from-ground-truth")) {
    const std::string run_dir = arguments.Get("from-ground-truth");
    // Runs simulated before visible_slices.csv existed still train colours.
    if (std::filesystem::exists(run_dir + "/ground_truth/visible_slices.csv"))
      trained =
          MeasureDetectorErrors(LearnImageShapes(trained, run_dir), run_dir, 5, blob_colour_floor);
    else if (!arguments.Flag("quiet"))
      std::fprintf(
          stderr,
          "warning: %s/ground_truth/visible_slices.csv is missing: no image shapes learnt\n",
          run_dir.c_str());
  }
  const ConfusionMatrix confusion = ColourConfusion(trained);
  const std::string output = arguments.Has("output") ? arguments.Get("output") : classes_path;
  WriteClasses(trained, output, confusion);
  if (!arguments.Flag("quiet")) {
    for (size_t c = 0; c < trained.size(); ++c) {
      if (!trained[c].colour) {
        std::printf("%-16s no colour model\n", trained[c].name.c_str());
        continue;
      }
      const ColourBox& box = *trained[c].colour;
      std::printf("%-16s YUV mean (%.1f, %.1f, %.1f) std (%.1f, %.1f, %.1f)  P(correct) %.3f",
                  trained[c].name.c_str(), box.yuv_mean[0], box.yuv_mean[1], box.yuv_mean[2],
                  box.yuv_std[0], box.yuv_std[1], box.yuv_std[2], confusion[c][c]);
      if (const auto& shape = trained[c].image_shape) {
        std::printf("  elongation %.2f ± %.2f", shape->elongation_mean, shape->elongation_std);
        // 0: not measured (too few views matched by a blob), not a perfect detector.
        if (shape->arc_error_px > 0) std::printf(", arc error %.1f px", shape->arc_error_px);
      }
      if (const auto& blob = box.blob_chroma)
        std::printf("  blob chroma (%.1f, %.1f) ± (%.1f, %.1f)", blob->mean[0], blob->mean[1],
                    blob->std[0], blob->std[1]);
      std::printf("\n");
    }
    std::printf("wrote %s\n", output.c_str());
    // The confusion written is the colour models' estimate; a run's detector
    // (image shapes, view and blob-colour checks) confuses classes less.
    std::printf(
        "class confusion: estimated from the colours; measure it on a run's detections with "
        "'oslam eval-detect RUN --write-confusion %s' (docs/detection.md)\n",
        output.c_str());
  }
  return 0;
}

}  // namespace oslam

// Colour-blob detection speed on rendered `lab` frames (one thread): the
// issue's goal is >= 500 frames/s at 640x480.
#include <filesystem>
#include <limits>

#include <benchmark/benchmark.h>

#include "calib/camera_io.h"
#include "core/run_folder.h"
#include "detect/blob_detector.h"
#include "detect/colour_training.h"
#include "detect/sift_verifier.h"
#include "samples/scene.h"
#include "samples/simulator.h"

namespace oslam {
namespace {

struct LabFrames {
  std::unique_ptr<CameraModel> camera;
  std::vector<ObjectClass> classes;
  std::vector<cv::Mat> frames;

  LabFrames() {
    const std::string run_dir =
        (std::filesystem::temp_directory_path() / "oslam_detect_bench_lab").string();
    std::filesystem::remove_all(run_dir);
    SimulationOptions options;
    options.max_frames = 20;
    Simulate(LoadScene(std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/lab.yaml"), run_dir,
             options);
    camera = LoadCamera(run_dir + "/camera.yaml");
    const std::vector<ObjectClass> untrained = ReadClasses(run_dir + "/classes.yaml");
    classes = MeasureDetectorErrors(
        LearnImageShapes(
            TrainColourModels(untrained, ExamplesFromGroundTruth(run_dir, untrained), 3.0),
            run_dir),
        run_dir);
    const FrameSource source(run_dir);
    for (size_t i = 0; i < source.size(); ++i) frames.push_back(source.Read(i));
    std::filesystem::remove_all(run_dir);
  }
};

const LabFrames& Lab() {
  static const LabFrames lab;
  return lab;
}

// Args: opening radius; 1 = separate look-alike classes by image shape (the
// default); 1 = view checks (size standing on the floor and image shape, the
// default); 1 = the check of each blob's mean colour (the default).
void BM_ColourBlobDetection640x480(benchmark::State& state) {
  const LabFrames& lab = Lab();
  BlobDetectorOptions options;
  options.opening_radius_px = static_cast<int>(state.range(0));
  options.separate_look_alikes = state.range(1) != 0;
  if (state.range(2) == 0) options.max_view_distance = std::numeric_limits<double>::infinity();
  if (state.range(3) == 0)
    options.max_blob_colour_distance = std::numeric_limits<double>::infinity();
  const BlobDetector detector(*lab.camera, lab.classes, options);
  size_t i = 0, detections = 0;
  for (auto _ : state) {
    const std::vector<Detection> found = detector.Detect(lab.frames[i % lab.frames.size()], 0);
    detections += found.size();
    ++i;
  }
  state.SetItemsProcessed(state.iterations());  // items = frames
  state.counters["detections_per_frame"] = double(detections) / state.iterations();
}
BENCHMARK(BM_ColourBlobDetection640x480)
    ->Args({0, 1, 1, 1})
    ->Args({1, 1, 1, 1})
    ->Args({0, 1, 1, 0})
    ->Args({0, 1, 0, 0})
    ->Args({0, 0, 0, 0})
    ->Unit(benchmark::kMicrosecond);

// Colour detection plus SIFT verification of every detection, on the SIFT
// test scene (a textured box and a same-coloured plain box; four templates).
// The goal: >= 30 frames/s.
void BM_ColourDetectionWithSiftVerification(benchmark::State& state) {
  const std::string run_dir =
      (std::filesystem::temp_directory_path() / "oslam_detect_bench_sift").string();
  std::filesystem::remove_all(run_dir);
  Simulate(LoadScene(std::string(OSLAM_SOURCE_DIR) + "/tests/data/sift_clutter.yaml"), run_dir,
           SimulationOptions{});
  const std::unique_ptr<CameraModel> camera = LoadCamera(run_dir + "/camera.yaml");
  const std::vector<ObjectClass> untrained = ReadClasses(run_dir + "/classes.yaml");
  const std::vector<ObjectClass> classes =
      TrainColourModels(untrained, ExamplesFromGroundTruth(run_dir, untrained), 3.0);
  const GroundTruth truth = *ReadGroundTruth(run_dir);
  const FrameSource source(run_dir);
  std::vector<cv::Mat> frames, templates;
  for (size_t i = 0; i < source.size(); ++i) frames.push_back(source.Read(i));
  for (const GroundTruthSighting& s : truth.sightings)
    if (s.object_id == 0 && s.frame % 5 == 0)
      templates.push_back(ExtractSlicePatch(
          frames[s.frame], *camera, {s.u_r_px, s.u_phi_rad, s.s_r_px, s.s_phi_rad}, -0.2, 96));
  std::filesystem::remove_all(run_dir);
  const BlobDetector detector(*camera, classes);
  const SiftVerifier verifier(std::vector<std::vector<cv::Mat>>{templates});
  size_t i = 0, checked = 0;
  for (auto _ : state) {
    const cv::Mat& frame = frames[i++ % frames.size()];
    const std::vector<Detection> detections = detector.Detect(frame, 0);
    checked += detections.size();
    benchmark::DoNotOptimize(verifier.Filter(frame, *camera, detections));
  }
  state.SetItemsProcessed(state.iterations());  // items = frames
  state.counters["verified_per_frame"] = double(checked) / state.iterations();
}
BENCHMARK(BM_ColourDetectionWithSiftVerification)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace oslam

// oslam detect: colour-blob detections (bounding slices) for every frame of a
// run folder.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "calib/camera_io.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "core/run_folder.h"
#include "detect/blob_detector.h"
#include "detect/sift_verifier.h"

namespace oslam {
namespace {

void SaveDebugImage(const cv::Mat& frame, const std::vector<Detection>& detections,
                    const CameraModel& camera, const std::vector<ObjectClass>& classes,
                    const std::string& path) {
  cv::Mat image = frame.clone();
  for (const Detection& d : detections) {
    const auto& rgb = classes[d.class_index].display_rgb;
    const cv::Scalar colour(rgb[2], rgb[1], rgb[0]);
    DrawSlice(&image, camera, d.slice, cv::Scalar(255, 255, 255), 3);
    DrawSlice(&image, camera, d.slice, colour, 1);
    const Eigen::Vector2d base = camera.PolarToPixel({d.slice.u_r_px, d.slice.u_phi_rad});
    cv::circle(image, cv::Point(cvRound(base.x()), cvRound(base.y())), 3, cv::Scalar(0, 0, 255),
               cv::FILLED);
    cv::putText(image, d.class_name, cv::Point(cvRound(base.x()) + 4, cvRound(base.y()) - 4),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
  WriteAtomically(path, [&](const std::string& temp) {
    if (!cv::imwrite(temp, image)) throw Error::InFile(path, "cannot write image");
  });
}

}  // namespace

int RunDetectCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam detect RUN_DIR [-o detections.csv] [options]",
                      "Detects objects by colour in every frame of RUN_DIR and writes their "
                      "bounding slices as CSV.\nNeeds camera.yaml and classes.yaml with colour "
                      "models (see 'oslam train-colors').");
  arguments.AddPositional("RUN_DIR", "the run folder");
  arguments.AddOption("output", "-o", "FILE", "detections CSV", "RUN_DIR/detections.csv");
  arguments.AddOption("debug-images", "", "DIR", "also write each frame with its slices drawn");
  arguments.AddOption("min-area", "", "PX", "smallest blob kept, in pixels", "40");
  arguments.AddOption("opening", "", "PX", "radius of the morphological opening, 0 = off", "1");
  arguments.AddOption("colour-box", "", "yuv|scaled",
                      "class colour region: 'yuv' = the thesis' mean ± k·σ box; 'scaled' = its "
                      "chroma scaled with brightness (robust to dim light)",
                      "scaled");
  arguments.AddOption("brightness-range", "", "R",
                      "with --colour-box scaled: accept brightness from 1/R to R times the "
                      "examples' range",
                      "2.5");
  arguments.AddFlag("keep-look-alikes",
                    "keep every class a blob's colour matches (the thesis); by default, where "
                    "two classes' blobs are the same pixels, only the one whose colour and "
                    "learnt image shape fit better is kept");
  arguments.AddOption("max-shape-distance", "", "SIGMAS",
                      "drop detections whose slice elongation is further than this from their "
                      "class's image shape (inf = off)",
                      "inf");
  arguments.AddOption("sift-templates", "", "FILE.yaml",
                      "keep a detection of a class with templates only if SIFT verifies it");
  arguments.AddFlag("skip-bad-frames", "warn about unreadable frames and go on");
  arguments.AddOption("threads", "", "N", "frames decoded and searched at once (0 = one per core)",
                      "2");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;

  const std::string run_dir = arguments.Get("RUN_DIR");
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  const std::string output =
      arguments.Has("output") ? arguments.Get("output") : run_dir + "/detections.csv";
  BlobDetectorOptions options;
  options.min_area_px = static_cast<int>(arguments.GetInt("min-area"));
  options.opening_radius_px = static_cast<int>(arguments.GetInt("opening"));
  if (!ParseColourBoxShape(arguments.Get("colour-box"), &options.colour.shape))
    throw UsageError("--colour-box must be 'yuv' or 'scaled'");
  options.colour.brightness_range = arguments.GetDouble("brightness-range");
  options.separate_look_alikes = !arguments.Flag("keep-look-alikes");
  options.max_shape_distance = arguments.GetDoubleOrInfinity("max-shape-distance");
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);
  const bool quiet = arguments.Flag("quiet");

  const FrameSource frames(run_dir);
  const std::unique_ptr<CameraModel> camera = LoadCamera(paths.camera);
  const std::vector<ObjectClass> classes = ReadClasses(paths.classes);
  if (std::none_of(classes.begin(), classes.end(),
                   [](const auto& c) { return c.colour.has_value(); }))
    throw Error::InFile(paths.classes,
                        "no class has a colour model (run 'oslam train-colors' first)");
  const BlobDetector detector(*camera, classes, options);
  std::optional<SiftVerifier> verifier;
  if (arguments.Has("sift-templates"))
    verifier.emplace(ReadSiftTemplates(arguments.Get("sift-templates"), classes));
  size_t rejected = 0;

  // Frames are decoded and searched in parallel, a block at a time; the
  // results are then taken in frame order, so the output, the warnings and
  // the first error reported do not depend on the threads.
  struct FrameResult {
    cv::Mat frame;  // kept only for the SIFT check and debug images
    std::vector<Detection> detections;
    std::exception_ptr read_error, error;
  };
  if (arguments.GetInt("threads") < 0) throw UsageError("--threads must be >= 0");
  const bool keep_frames = verifier.has_value() || arguments.Has("debug-images");
  const int threads = ThreadCount(static_cast<int>(arguments.GetInt("threads")), frames.size());
  const size_t block = 16 * static_cast<size_t>(threads);
  std::vector<Detection> all;
  size_t skipped = 0;
  Progress progress("detect", frames.size(), "frames", quiet);
  for (size_t first = 0; first < frames.size(); first += block) {
    const size_t last = std::min(frames.size(), first + block);
    std::vector<FrameResult> results(last - first);
    ParallelFor(first, last, threads, [&](size_t i) {
      FrameResult& result = results[i - first];
      cv::Mat frame;
      try {
        frame = frames.Read(i);
      } catch (const Error&) {
        result.read_error = std::current_exception();
        return;
      }
      try {
        if (frame.cols != camera->image_width() || frame.rows != camera->image_height())
          throw Error::InFile(frames.Name(i), "image is " + std::to_string(frame.cols) + "x" +
                                                  std::to_string(frame.rows) +
                                                  " but camera.yaml says " +
                                                  std::to_string(camera->image_width()) + "x" +
                                                  std::to_string(camera->image_height()));
        result.detections = detector.Detect(frame, static_cast<long>(i));
        if (keep_frames) result.frame = frame;
      } catch (...) {
        result.error = std::current_exception();
      }
    });
    for (size_t i = first; i < last; ++i) {
      FrameResult& result = results[i - first];
      if (result.read_error) {
        if (!arguments.Flag("skip-bad-frames")) std::rethrow_exception(result.read_error);
        try {
          std::rethrow_exception(result.read_error);
        } catch (const Error& e) {
          std::cerr << "oslam detect: warning: skipping frame " << i << ": " << e.what() << "\n";
        }
        ++skipped;
        continue;
      }
      if (result.error) std::rethrow_exception(result.error);
      std::vector<Detection>& detections = result.detections;
      if (verifier) {
        const size_t before = detections.size();
        detections = verifier->Filter(result.frame, *camera, detections);
        rejected += before - detections.size();
      }
      if (arguments.Has("debug-images")) {
        char name[32];
        std::snprintf(name, sizeof(name), "%06zu.png", i);
        SaveDebugImage(result.frame, detections, *camera, classes,
                       (std::filesystem::path(arguments.Get("debug-images")) / name).string());
      }
      all.insert(all.end(), detections.begin(), detections.end());
      result = FrameResult();
      progress.Update(i + 1);
    }
  }
  progress.Done(std::to_string(all.size()) + " detections" +
                (verifier ? ", " + std::to_string(rejected) + " rejected by SIFT" : "") +
                (skipped ? ", " + std::to_string(skipped) + " frames skipped" : ""));
  WriteDetections(all, output);
  if (!quiet) std::printf("wrote %s\n", output.c_str());
  return 0;
}

}  // namespace oslam

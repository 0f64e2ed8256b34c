#include "pipeline/detect_stage.h"

#include <algorithm>
#include <exception>
#include <filesystem>
#include <memory>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/camera_io.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_file.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "core/run_folder.h"
#include "core/text.h"
#include "detect/sift_verifier.h"
#include "detect/static_mask.h"

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
  WriteImage(path, image);
}

// One frame's outcome, computed on a worker thread.
struct FrameResult {
  cv::Mat frame;  // kept only for the SIFT check and debug images
  std::vector<Detection> detections;
  std::exception_ptr read_error, error;
};

FrameResult DetectInFrame(const FrameSource& frames, size_t i, const CameraModel& camera,
                          const BlobDetector& detector, bool keep_frame) {
  FrameResult result;
  cv::Mat frame;
  try {
    frame = frames.Read(i);
  } catch (const Error&) {
    result.read_error = std::current_exception();
    return result;
  }
  try {
    if (frame.cols != camera.image_width() || frame.rows != camera.image_height())
      throw Error::InFile(frames.Name(i), "image is " + std::to_string(frame.cols) + "x" +
                                              std::to_string(frame.rows) +
                                              " but camera.yaml says " +
                                              std::to_string(camera.image_width()) + "x" +
                                              std::to_string(camera.image_height()));
    result.detections = detector.Detect(frame, static_cast<long>(i));
    if (keep_frame) result.frame = frame;
  } catch (...) {
    result.error = std::current_exception();
  }
  return result;
}

// The static mask the options name (or the run's mask.png); empty for none.
cv::Mat LoadMask(const std::string& option, const RunFolderPaths& paths, const CameraModel& camera,
                 const StageOutput& output) {
  if (option == "none") return cv::Mat();
  const std::string path = option.empty() ? paths.mask : option;
  if (option.empty() && !std::filesystem::exists(path)) return cv::Mat();
  const cv::Mat mask = ReadStaticMask(path, camera.image_width(), camera.image_height());
  output.Print(Format("mask: %s ignores %.1f %% of the image", path.c_str(),
                      100.0 * (1.0 - cv::countNonZero(mask) / static_cast<double>(mask.total()))));
  return mask;
}

}  // namespace

bool DetectStageOptions::Validate(std::string* why) const {
  if (!detector.Validate(why)) return false;
  if (threads < 0) {
    if (why) *why = "the detection threads must be >= 0 (0 = one per core)";
    return false;
  }
  return true;
}

DetectStageResult RunDetectStage(const std::string& run_dir, const std::string& output_csv,
                                 const DetectStageOptions& options, const StageOutput& output) {
  std::string why;
  if (!options.Validate(&why)) throw Error("detect: " + why);
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  const FrameSource frames(run_dir);
  const std::unique_ptr<CameraModel> camera = LoadCamera(paths.camera);
  const std::vector<ObjectClass> classes = ReadClasses(paths.classes);
  if (std::none_of(classes.begin(), classes.end(),
                   [](const auto& c) { return c.colour.has_value(); }))
    throw Error::InFile(paths.classes,
                        "no class has a colour model (run 'oslam train-colors' first)");
  const cv::Mat mask = LoadMask(options.mask, paths, *camera, output);
  const BlobDetector detector(*camera, classes, options.detector, mask);
  std::optional<SiftVerifier> verifier;
  if (!options.sift_templates.empty())
    verifier.emplace(ReadSiftTemplates(options.sift_templates, classes));

  // Frames are decoded and searched in parallel, a block at a time; the
  // results are then taken in frame order, so the output, the warnings and
  // the first error reported do not depend on the threads.
  const bool keep_frames = verifier.has_value() || !options.debug_images_dir.empty();
  const int threads = ThreadCount(options.threads, frames.size());
  const size_t block = 16 * static_cast<size_t>(threads);
  DetectStageResult result;
  result.frames = frames.size();
  Progress progress("detect", frames.size(), "frames", output.quiet);
  for (size_t first = 0; first < frames.size(); first += block) {
    const size_t last = std::min(frames.size(), first + block);
    std::vector<FrameResult> results(last - first);
    ParallelFor(first, last, threads, [&](size_t i) {
      results[i - first] = DetectInFrame(frames, i, *camera, detector, keep_frames);
    });
    for (size_t i = first; i < last; ++i) {
      FrameResult& frame = results[i - first];
      if (frame.read_error) {
        if (!options.skip_bad_frames) std::rethrow_exception(frame.read_error);
        try {
          std::rethrow_exception(frame.read_error);
        } catch (const Error& e) {
          output.Warn("skipping frame " + std::to_string(i) + ": " + e.what());
        }
        ++result.skipped_frames;
        continue;
      }
      if (frame.error) std::rethrow_exception(frame.error);
      std::vector<Detection>& detections = frame.detections;
      if (verifier) {
        const size_t before = detections.size();
        detections = verifier->Filter(frame.frame, *camera, detections);
        result.sift_rejected += before - detections.size();
      }
      if (!options.debug_images_dir.empty())
        SaveDebugImage(
            frame.frame, detections, *camera, classes,
            (std::filesystem::path(options.debug_images_dir) / Format("%06zu.png", i)).string());
      result.detections.insert(result.detections.end(), detections.begin(), detections.end());
      frame = FrameResult();
      progress.Update(i + 1);
    }
  }
  progress.Done(
      std::to_string(result.detections.size()) + " detections" +
      (verifier ? ", " + std::to_string(result.sift_rejected) + " rejected by SIFT" : "") +
      (result.skipped_frames ? ", " + std::to_string(result.skipped_frames) + " frames skipped"
                             : ""));
  WriteDetections(result.detections, output_csv);
  output.Print("wrote " + output_csv);
  return result;
}

}  // namespace oslam

// The file-writing steps shared by `oslam export`, `oslam overlay` and
// `oslam render`: read a run folder's context, write the models, the figures
// and the reprojection overlays into an output folder, with progress lines.
// Every file is written atomically; errors name the file.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "core/run_folder.h"
#include "detect/blob_detector.h"
#include "export/export_scene.h"
#include "export/figures.h"

namespace oslam {

// Classes, odometry and ground truth of the run, those that exist. Throws
// oslam::Error naming `run_dir` when it is not a folder.
void ReadRunContext(const std::string& run_dir, ExportScene* scene);

// "0,5,10-20" -> {0, 5, 10, ..., 20}; every frame must be < frame_count.
// Throws UsageError (a --frames problem) otherwise.
std::vector<long> ParseFrameList(const std::string& text, long frame_count);

// Creates `out` (and parents); throws oslam::Error naming it when it cannot.
void CreateOutputFolder(const std::filesystem::path& out);

// map.glb, map.gltf, map.ply and, for the trajectories there are,
// trajectory.ply and the TUM files trajectory_estimated.txt,
// trajectory_odometry.txt and trajectory_truth.txt (docs/export.md).
void WriteModels(const ExportScene& scene, const ExportOptions& options,
                 const std::filesystem::path& out, bool ascii_ply, bool quiet);

// `out`/`stem`.png, .svg and .csv of a figure, atomically; returns their names.
std::vector<std::string> WriteFigureFiles(const Figure& figure, const std::filesystem::path& out,
                                          const std::string& stem);

// birdseye.{png,svg,csv}, perspective.png and, when the scene has ground
// truth, trajectories.{png,svg,csv}. Returns the names of the files written.
std::vector<std::string> WriteFigures(const ExportScene& scene, const FigureOptions& options,
                                      const std::filesystem::path& out, bool quiet);

// Everything the overlays need, read and checked before any file is written
// so a bad frame list is refused up front.
struct OverlayInput {
  std::unique_ptr<FrameSource> frames;
  std::unique_ptr<CameraModel> camera;
  std::vector<Detection> detections;  // empty when the run has no detections.csv
  std::vector<long> chosen;           // frames to draw, in order
};

// Frames and camera of `run_dir`, the detections of `detections_path` ("" =
// `run_dir`/detections.csv if it exists; a path given must exist), and the
// frames of `frame_list` ("" = every frame with an estimated pose).
OverlayInput PrepareOverlays(const ExportScene& scene, const std::string& run_dir,
                             const std::string& frame_list,
                             const std::string& detections_path = "");

// JPEG by default: the overlays are camera frames with thin drawings, for
// which quality 92 shows no artefacts and encodes about eight times faster
// than the fastest PNG (docs/benchmarks.md, "export"); PNG when the frames
// must stay lossless.
enum class OverlayFormat { kJpeg, kPng };

// "jpg" or "png"; nullopt otherwise.
std::optional<OverlayFormat> ParseOverlayFormat(const std::string& text);

// The bytes of an overlay image in `format` (JPEG quality 92, or PNG);
// empty on failure.
std::vector<unsigned char> EncodeOverlay(const cv::Mat& image, OverlayFormat format);

// One image per chosen frame: `overlays_dir`/NNNNNN.jpg (or .png; folder
// created), `threads` frames at a time (0 = one per core); the files do not
// depend on it. On an error the files of the frames before the failing one
// are written.
void WriteOverlays(const ExportScene& scene, const OverlayInput& input, double min_existence,
                   const std::filesystem::path& overlays_dir, bool quiet, int threads = 2,
                   OverlayFormat format = OverlayFormat::kJpeg);

// Everything `oslam export` writes: WriteModels and WriteFigures, and with
// `overlays` the overlays into `out`/overlays. The models and figures are
// made on a thread of their own while the overlays take `threads` others, so
// the whole takes about as long as the overlays alone.
void WriteExportFiles(const ExportScene& scene, const ExportOptions& models, bool ascii_ply,
                      const FigureOptions& figures, const OverlayInput* overlays,
                      OverlayFormat overlay_format, const std::filesystem::path& out, bool quiet,
                      int threads = 2);

}  // namespace oslam

#include "export/export_files.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <functional>
#include <mutex>
#include <sstream>
#include <thread>

#include <opencv2/imgcodecs.hpp>

#include "calib/camera_io.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "export/figures.h"
#include "export/gltf_writer.h"
#include "export/overlay.h"
#include "export/ply_writer.h"
#include "export/tum_writer.h"

namespace oslam {

namespace fs = std::filesystem;

void ReadRunContext(const std::string& run_dir, ExportScene* scene) {
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  if (!fs::is_directory(run_dir)) throw Error::InFile(run_dir, "no such run folder");
  if (fs::exists(paths.classes)) scene->classes = ReadClasses(paths.classes);
  if (fs::exists(paths.odometry)) scene->odometry = ReadOdometry(paths.odometry).poses;
  if (const auto truth = ReadGroundTruth(run_dir)) scene->ground_truth = truth->trajectory;
}

std::vector<long> ParseFrameList(const std::string& text, long frame_count) {
  std::vector<long> frames;
  std::stringstream items(text);
  std::string item;
  while (std::getline(items, item, ',')) {
    long first = 0, last = 0;
    char dash = 0, extra = 0;
    const int n = std::sscanf(item.c_str(), "%ld%c%ld%c", &first, &dash, &last, &extra);
    if (n == 1) {
      last = first;
    } else if (!(n == 3 && dash == '-')) {
      throw UsageError("--frames: '" + item + "' is not a frame number or a range like 10-20");
    }
    if (last < first) throw UsageError("--frames: '" + item + "' is a reversed range");
    if (first < 0 || last >= frame_count)
      throw UsageError("--frames: '" + item + "' is outside the run's frames 0-" +
                       std::to_string(frame_count - 1));
    for (long f = first; f <= last; ++f) frames.push_back(f);
  }
  if (frames.empty()) throw UsageError("--frames: no frames in '" + text + "'");
  return frames;
}

void CreateOutputFolder(const fs::path& out) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (!fs::is_directory(out)) throw Error::InFile(out.string(), "cannot create output folder");
}

void WriteModels(const ExportScene& scene, const ExportOptions& options, const fs::path& out,
                 bool ascii_ply, bool quiet) {
  std::string why;
  if (!options.Validate(&why)) throw Error("export: " + why);
  const DisplayScene display = BuildDisplayScene(scene, options);
  const PlyEncoding encoding = ascii_ply ? PlyEncoding::kAscii : PlyEncoding::kBinary;
  std::vector<std::pair<std::string, std::string>> files = {
      {"map.glb", GltfBytes(display, options, true)},
      {"map.gltf", GltfBytes(display, options, false)},
      {"map.ply", PlyMeshBytes(display, encoding)}};
  if (std::string trajectories = PlyTrajectoryBytes(display, scene, encoding);
      !trajectories.empty())
    files.emplace_back("trajectory.ply", std::move(trajectories));
  // TUM files for evo (docs/export.md).
  if (!scene.map.trajectory.empty())
    files.emplace_back("trajectory_estimated.txt", TumTrajectory(scene.map.trajectory));
  if (!scene.odometry.empty())
    files.emplace_back("trajectory_odometry.txt", TumTrajectory(scene.odometry));
  if (!scene.ground_truth.empty())
    files.emplace_back("trajectory_truth.txt", TumTrajectory(scene.ground_truth));
  Progress progress("models", files.size(), "files", quiet);
  std::string names;
  for (size_t i = 0; i < files.size(); ++i) {
    WriteFileAtomically((out / files[i].first).string(), files[i].second);
    names += (i ? ", " : "") + files[i].first;
    progress.Update(i + 1);
  }
  progress.Done(names);
}

std::vector<std::string> WriteFigureFiles(const Figure& figure, const fs::path& out,
                                          const std::string& stem) {
  std::vector<std::string> written;
  for (const auto& [extension, bytes] :
       {std::pair<std::string, std::string>{".png", EncodePng(figure.image)},
        {".svg", figure.svg},
        {".csv", figure.csv}}) {
    WriteFileAtomically((out / (stem + extension)).string(), bytes);
    written.push_back(stem + extension);
  }
  return written;
}

std::vector<std::string> WriteFigures(const ExportScene& scene, const FigureOptions& options,
                                      const fs::path& out, bool quiet) {
  Progress progress("figures", 3, "figures", quiet);
  std::vector<std::string> written;
  // A figure that cannot be drawn is an error about the file it was drawn for.
  auto write = [&](const std::string& stem, const std::function<Figure()>& draw) {
    Figure figure;
    try {
      figure = draw();
    } catch (const Error& e) {
      throw Error::InFile((out / (stem + ".png")).string(), e.what());
    }
    for (std::string& name : WriteFigureFiles(figure, out, stem)) written.push_back(name);
  };
  write("birdseye", [&] { return BirdsEyeFigure(scene, options); });
  progress.Update(1);
  // Without an EGL driver there is no off-screen OpenGL: the other files are
  // still worth having.
  try {
    WritePng(RenderPerspective(scene, options), (out / "perspective.png").string());
    written.push_back("perspective.png");
  } catch (const Error& e) {
    std::fprintf(stderr, "warning: perspective.png not written: %s\n", e.what());
  }
  progress.Update(2);
  std::string note;
  if (scene.ground_truth.empty()) {
    note = " (no ground truth: no trajectory error plot)";
  } else {
    FigureOptions plot = options;
    plot.height_px = std::max(200, options.height_px / 2);
    write("trajectories", [&] { return TrajectoryErrorFigure(scene, plot); });
  }
  progress.Update(3);
  progress.Done(std::to_string(written.size()) + " files" + note);
  return written;
}

OverlayInput PrepareOverlays(const ExportScene& scene, const std::string& run_dir,
                             const std::string& frame_list, const std::string& detections_path) {
  OverlayInput input;
  input.frames = std::make_unique<FrameSource>(run_dir);
  input.camera = LoadCamera(RunFolderPaths::Of(run_dir).camera);
  if (!detections_path.empty()) {
    input.detections = ReadDetections(detections_path, scene.classes);
  } else if (fs::exists(run_dir + "/detections.csv")) {
    input.detections = ReadDetections(run_dir + "/detections.csv", scene.classes);
  }
  const long count = static_cast<long>(std::min(input.frames->size(), scene.map.trajectory.size()));
  if (count == 0) throw Error::InFile(run_dir, "no frames with an estimated pose to overlay");
  if (frame_list.empty()) {
    for (long f = 0; f < count; ++f) input.chosen.push_back(f);
  } else {
    input.chosen = ParseFrameList(frame_list, count);
  }
  return input;
}

std::optional<OverlayFormat> ParseOverlayFormat(const std::string& text) {
  if (text == "jpg" || text == "jpeg") return OverlayFormat::kJpeg;
  if (text == "png") return OverlayFormat::kPng;
  return std::nullopt;
}

std::vector<unsigned char> EncodeOverlay(const cv::Mat& image, OverlayFormat format) {
  std::vector<unsigned char> bytes;
  const bool encoded = format == OverlayFormat::kJpeg
                           ? cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, 92})
                           : cv::imencode(".png", image, bytes);
  if (!encoded) bytes.clear();
  return bytes;
}

void WriteOverlays(const ExportScene& scene, const OverlayInput& input, double min_existence,
                   const fs::path& overlays_dir, bool quiet, int threads, OverlayFormat format) {
  CreateOutputFolder(overlays_dir);
  Progress progress("overlays", input.chosen.size(), "frames", quiet);
  std::mutex progress_mutex;
  size_t done = 0;
  const char* extension = format == OverlayFormat::kJpeg ? "jpg" : "png";
  // Every frame is independent: read (or taken from the frame cache), drawn,
  // encoded in memory and written by whichever thread takes it.
  ParallelFor(0, input.chosen.size(), threads, [&](size_t i) {
    const long frame = input.chosen[i];
    char name[32];
    std::snprintf(name, sizeof(name), "%06ld.%s", frame, extension);
    const cv::Mat image = DrawOverlay(input.frames->Read(frame), frame, *input.camera, scene,
                                      input.detections, min_existence);
    const std::string path = (overlays_dir / name).string();
    const std::vector<unsigned char> bytes = EncodeOverlay(image, format);
    if (bytes.empty()) throw Error::InFile(path, "cannot encode the overlay");
    WriteFileAtomically(path,
                        std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                        FileSync::kDeferred);
    const std::lock_guard<std::mutex> lock(progress_mutex);
    progress.Update(++done);
  });
  SyncFileSystem(overlays_dir.string());
  progress.Done(std::to_string(input.chosen.size()) + " overlays" +
                (input.detections.empty() ? " (no detections.csv: map only)" : ""));
}

void WriteExportFiles(const ExportScene& scene, const ExportOptions& models, bool ascii_ply,
                      const FigureOptions& figures, const OverlayInput* overlays,
                      OverlayFormat overlay_format, const fs::path& out, bool quiet, int threads) {
  if (overlays == nullptr) {
    WriteModels(scene, models, out, ascii_ply, quiet);
    WriteFigures(scene, figures, out, quiet);
    return;
  }
  // The models and figures on a thread of their own, quietly (two progress
  // lines updated at once would garble a terminal); their summary follows
  // the overlays'.
  std::exception_ptr failure;
  std::string summary;
  std::thread side([&] {
    try {
      const auto start = std::chrono::steady_clock::now();
      WriteModels(scene, models, out, ascii_ply, /*quiet=*/true);
      const std::vector<std::string> written = WriteFigures(scene, figures, out, /*quiet=*/true);
      char line[160];
      std::snprintf(
          line, sizeof(line),
          "[models, figures] %zu figure files and the 3D models in %.2f s, beside "
          "the overlays\n",
          written.size(),
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
      summary = line;
    } catch (...) {
      failure = std::current_exception();
    }
  });
  try {
    WriteOverlays(scene, *overlays, models.min_existence, out / "overlays", quiet, threads,
                  overlay_format);
  } catch (...) {
    side.join();
    throw;
  }
  side.join();
  if (failure) std::rethrow_exception(failure);
  if (!quiet) std::fputs(summary.c_str(), stderr);
}

}  // namespace oslam

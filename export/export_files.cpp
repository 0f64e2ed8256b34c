#include "export/export_files.h"

#include <algorithm>
#include <cstdio>
#include <mutex>
#include <sstream>

#include "calib/camera_io.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "export/gltf_writer.h"
#include "export/overlay.h"
#include "export/ply_writer.h"

namespace oslam {

namespace fs = std::filesystem;

void ReadRunContext(const std::string& run_dir, ExportScene* scene) {
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  if (!fs::is_directory(paths.dir)) throw Error::InFile(run_dir, "no such run folder");
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
  Progress progress("models", 4, "files", quiet);
  WriteGltf(scene, options, (out / "map.glb").string());
  progress.Update(1);
  WriteGltf(scene, options, (out / "map.gltf").string());
  progress.Update(2);
  const PlyEncoding encoding = ascii_ply ? PlyEncoding::kAscii : PlyEncoding::kBinary;
  WritePlyMesh(scene, options, (out / "map.ply").string(), encoding);
  progress.Update(3);
  if (!SceneTrajectories(scene).empty())
    WritePlyTrajectories(scene, (out / "trajectory.ply").string(), encoding);
  progress.Update(4);
  progress.Done("map.glb, map.gltf, map.ply, trajectory.ply");
}

std::vector<std::string> WriteFigures(const ExportScene& scene, const FigureOptions& options,
                                      const fs::path& out, bool quiet) {
  Progress progress("figures", 3, "figures", quiet);
  std::vector<std::string> written = {"birdseye.png", "perspective.png"};
  WritePng(RenderBirdsEye(scene, options), (out / written[0]).string());
  progress.Update(1);
  WritePng(RenderPerspective(scene, options), (out / written[1]).string());
  progress.Update(2);
  std::string note;
  if (scene.ground_truth.empty()) {
    note = " (no ground truth: trajectories.png skipped)";
  } else {
    FigureOptions plot = options;
    plot.height_px = std::max(200, options.height_px / 2);
    written.push_back("trajectories.png");
    WritePng(PlotTrajectoryErrors(scene, plot), (out / written[2]).string());
  }
  progress.Update(3);
  progress.Done("birdseye.png, perspective.png, trajectories.png" + note);
  return written;
}

OverlayInput PrepareOverlays(const ExportScene& scene, const std::string& run_dir,
                             const std::string& frame_list, const std::string& detections_path) {
  OverlayInput input;
  input.frames = std::make_unique<FrameSource>(run_dir);
  input.camera = LoadCamera(RunFolderPaths::Of(run_dir).camera);
  if (!detections_path.empty()) {
    input.detections = ReadDetections(detections_path, scene.classes);
  } else if (fs::exists(RunFolderPaths::Of(run_dir).detections)) {
    input.detections = ReadDetections(RunFolderPaths::Of(run_dir).detections, scene.classes);
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

void WriteOverlays(const ExportScene& scene, const OverlayInput& input, double min_existence,
                   const fs::path& overlays_dir, bool quiet, int threads) {
  CreateOutputFolder(overlays_dir);
  Progress progress("overlays", input.chosen.size(), "frames", quiet);
  std::mutex progress_mutex;
  size_t done = 0;
  // Every frame is independent: read (or taken from the frame cache), drawn
  // and written by whichever thread takes it.
  ParallelFor(0, input.chosen.size(), threads, [&](size_t i) {
    const long frame = input.chosen[i];
    char name[32];
    std::snprintf(name, sizeof(name), "%06ld.png", frame);
    const cv::Mat image = DrawOverlay(input.frames->Read(frame), frame, *input.camera, scene,
                                      input.detections, min_existence);
    WritePng(image, (overlays_dir / name).string(), FileSync::kDeferred);
    const std::lock_guard<std::mutex> lock(progress_mutex);
    progress.Update(++done);
  });
  SyncFileSystem(overlays_dir.string());
  progress.Done(std::to_string(input.chosen.size()) + " overlays" +
                (input.detections.empty() ? " (no detections.csv: map only)" : ""));
}

}  // namespace oslam

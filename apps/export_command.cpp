// oslam export: an O-Map as glTF (Blender), PLY (MeshLab), figures and
// optional reprojection overlays on the run's frames.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "calib/camera_io.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/run_folder.h"
#include "detect/blob_detector.h"
#include "export/figures.h"
#include "export/gltf_writer.h"
#include "export/overlay.h"
#include "export/ply_writer.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

// "0,5,10-20" -> {0, 5, 10, ..., 20}; every frame must exist.
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
  return frames;
}

// Classes, odometry and ground truth of the run, those that exist.
void ReadRunContext(const std::string& run_dir, ExportScene* scene) {
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  if (!fs::is_directory(run_dir)) throw Error::InFile(run_dir, "no such run folder");
  if (fs::exists(paths.classes)) scene->classes = ReadClasses(paths.classes);
  if (fs::exists(paths.odometry)) scene->odometry = ReadOdometry(paths.odometry).poses;
  if (const auto truth = ReadGroundTruth(run_dir)) scene->ground_truth = truth->trajectory;
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

void WriteFigures(const ExportScene& scene, const FigureOptions& options, const fs::path& out,
                  bool quiet) {
  Progress progress("figures", 3, "figures", quiet);
  WritePng(RenderBirdsEye(scene, options), (out / "birdseye.png").string());
  progress.Update(1);
  WritePng(RenderPerspective(scene, options), (out / "perspective.png").string());
  progress.Update(2);
  std::string note;
  if (scene.ground_truth.empty()) {
    note = " (no ground truth: trajectories.png skipped)";
  } else {
    FigureOptions plot = options;
    plot.height_px = std::max(200, options.height_px / 2);
    WritePng(PlotTrajectoryErrors(scene, plot), (out / "trajectories.png").string());
  }
  progress.Update(3);
  progress.Done("birdseye.png, perspective.png, trajectories.png" + note);
}

// Everything the overlays need, read and checked before any file is written
// so a bad --frames is refused up front.
struct OverlayInput {
  std::unique_ptr<FrameSource> frames;
  std::unique_ptr<CameraModel> camera;
  std::vector<Detection> detections;
  std::vector<long> chosen;
};

OverlayInput PrepareOverlays(const ExportScene& scene, const std::string& run_dir,
                             const std::string& frame_list) {
  OverlayInput input;
  input.frames = std::make_unique<FrameSource>(run_dir);
  input.camera = LoadCamera(RunFolderPaths::Of(run_dir).camera);
  const std::string detections_path = run_dir + "/detections.csv";
  if (fs::exists(detections_path))
    input.detections = ReadDetections(detections_path, scene.classes);
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
                   const fs::path& out, bool quiet) {
  fs::create_directories(out / "overlays");
  Progress progress("overlays", input.chosen.size(), "frames", quiet);
  for (size_t i = 0; i < input.chosen.size(); ++i) {
    const long frame = input.chosen[i];
    char name[32];
    std::snprintf(name, sizeof(name), "%06ld.png", frame);
    const cv::Mat image = DrawOverlay(input.frames->Read(frame), frame, *input.camera, scene,
                                      input.detections, min_existence);
    WritePng(image, (out / "overlays" / name).string());
    progress.Update(i + 1);
  }
  progress.Done(std::to_string(input.chosen.size()) + " overlays" +
                (input.detections.empty() ? " (no detections.csv: map only)" : ""));
}

}  // namespace

int RunExportCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam export OMAP.json -o OUT_DIR [--run RUN_DIR] [options]",
      "Writes an O-Map as map.glb and map.gltf (glTF 2.0, Y up, for Blender), map.ply and\n"
      "trajectory.ply (for MeshLab), and birdseye.png, perspective.png, trajectories.png.\n"
      "RUN_DIR supplies class colours, odometry, ground truth, and for --overlays the frames,\n"
      "camera and detections.");
  arguments.AddPositional("OMAP", "the O-Map JSON (oslam map)");
  arguments.AddOption("output", "-o", "DIR", "output folder (created)");
  arguments.AddOption("run", "", "RUN_DIR", "the run folder the map was made from");
  arguments.AddOption("min-existence", "", "P", "leave out objects with existence probability < P",
                      "0.1");
  arguments.AddOption("figure-size", "", "PX", "width and height of the figures", "800");
  arguments.AddFlag("no-grid", "no floor grid in the glTF");
  arguments.AddFlag("ascii-ply", "write ASCII PLY instead of binary");
  arguments.AddFlag("overlays", "also draw the map on the run's frames (overlays/NNNNNN.png)");
  arguments.AddOption("frames", "", "LIST", "overlay only these frames, e.g. 0,10,20-30");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("missing -o OUT_DIR");
  if (arguments.Flag("overlays") && !arguments.Has("run"))
    throw UsageError("--overlays needs --run RUN_DIR (frames and camera)");
  if (arguments.Has("frames") && !arguments.Flag("overlays"))
    throw UsageError("--frames applies to --overlays only");

  ExportOptions options;
  options.min_existence = arguments.GetDouble("min-existence");
  options.floor_grid = !arguments.Flag("no-grid");
  FigureOptions figures;
  figures.min_existence = options.min_existence;
  figures.width_px = figures.height_px = static_cast<int>(arguments.GetInt("figure-size"));
  std::string why;
  if (!options.Validate(&why) || !figures.Validate(&why)) throw UsageError(why);
  const bool quiet = arguments.Flag("quiet");

  ExportScene scene;
  scene.map = ReadOMap(arguments.Get("OMAP"));
  if (arguments.Has("run")) ReadRunContext(arguments.Get("run"), &scene);
  std::optional<OverlayInput> overlays;
  if (arguments.Flag("overlays"))
    overlays = PrepareOverlays(scene, arguments.Get("run"), arguments.Get("frames"));
  const fs::path out = arguments.Get("output");
  std::error_code ec;
  fs::create_directories(out, ec);
  if (!fs::is_directory(out)) throw Error::InFile(out.string(), "cannot create output folder");

  WriteModels(scene, options, out, arguments.Flag("ascii-ply"), quiet);
  WriteFigures(scene, figures, out, quiet);
  if (overlays) WriteOverlays(scene, *overlays, options.min_existence, out, quiet);
  if (!quiet) std::printf("wrote %s\n", out.string().c_str());
  return 0;
}

}  // namespace oslam

// The parts of the export stage (docs/benchmarks.md, "export"), on the lab
// run when it has been made (scripts/quickstart.sh; OSLAM_BENCH_RUN and
// OSLAM_BENCH_OMAP name another run folder and O-Map): the 3D view (VTK
// through EGL), the figures (PLplot), the glTF and PLY bytes, and one
// overlay drawn and encoded. CPU time is the steadier measure on a shared
// machine.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "calib/camera_io.h"
#include "core/run_folder.h"
#include "export/display_scene.h"
#include "export/export_files.h"
#include "export/figures.h"
#include "export/gltf_writer.h"
#include "export/overlay.h"
#include "export/ply_writer.h"
#include "export/vtk_view.h"
#include "omap/omap_json.h"

namespace oslam {
namespace {

std::string Setting(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return value ? value : fallback;
}

const std::string kRun = Setting("OSLAM_BENCH_RUN", OSLAM_SOURCE_DIR "/runs/lab");
const std::string kOMap = Setting("OSLAM_BENCH_OMAP", OSLAM_SOURCE_DIR "/runs/lab_out/omap.json");

bool Missing(benchmark::State& state) {
  if (std::filesystem::exists(kOMap) && std::filesystem::is_directory(kRun)) return false;
  state.SkipWithError(("no " + kOMap + " (run scripts/quickstart.sh)").c_str());
  return true;
}

ExportScene Scene() {
  ExportScene scene;
  scene.map = ReadOMap(kOMap);
  ReadRunContext(kRun, &scene);
  return scene;
}

void BM_RenderView(benchmark::State& state) {
  if (Missing(state)) return;
  const ExportScene scene = Scene();
  const DisplayScene display = BuildDisplayScene(scene, ExportOptions{});
  ViewOptions options;
  options.width_px = options.height_px = 800;
  for (auto _ : state) benchmark::DoNotOptimize(RenderView(scene, display, options));
}
// Process CPU time: Mesa's llvmpipe rasterises on threads of its own.
BENCHMARK(BM_RenderView)->Unit(benchmark::kMillisecond)->Iterations(5)->MeasureProcessCPUTime();

void BM_Figures(benchmark::State& state) {
  if (Missing(state)) return;
  const ExportScene scene = Scene();
  for (auto _ : state) {
    benchmark::DoNotOptimize(EncodePng(BirdsEyeFigure(scene, FigureOptions{}).image));
    FigureOptions plot;
    plot.height_px = 400;
    benchmark::DoNotOptimize(EncodePng(TrajectoryErrorFigure(scene, plot).image));
  }
}
BENCHMARK(BM_Figures)->Unit(benchmark::kMillisecond)->Iterations(5);

void BM_Models(benchmark::State& state) {
  if (Missing(state)) return;
  const ExportScene scene = Scene();
  const ExportOptions options;
  for (auto _ : state) {
    const DisplayScene display = BuildDisplayScene(scene, options);
    benchmark::DoNotOptimize(GltfBytes(display, options, true));
    benchmark::DoNotOptimize(GltfBytes(display, options, false));
    benchmark::DoNotOptimize(PlyMeshBytes(display, PlyEncoding::kBinary));
  }
}
BENCHMARK(BM_Models)->Unit(benchmark::kMillisecond)->Iterations(5);

// One overlay: drawn on a decoded frame (as `oslam run` has them cached),
// then (argument 1) encoded as JPEG, the default, or (2) as PNG.
void BM_Overlay(benchmark::State& state) {
  if (Missing(state)) return;
  const ExportScene scene = Scene();
  const std::unique_ptr<CameraModel> camera = LoadCamera(RunFolderPaths::Of(kRun).camera);
  const OverlayInput input = PrepareOverlays(scene, kRun, "", "");
  const cv::Mat frame = input.frames->Read(50);
  const long encode = state.range(0);
  for (auto _ : state) {
    const cv::Mat image = DrawOverlay(frame, 50, *camera, scene, input.detections, 0.1);
    if (encode > 0)
      benchmark::DoNotOptimize(
          EncodeOverlay(image, encode == 1 ? OverlayFormat::kJpeg : OverlayFormat::kPng));
  }
}
BENCHMARK(BM_Overlay)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace oslam

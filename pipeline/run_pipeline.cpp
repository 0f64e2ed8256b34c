#include "pipeline/run_pipeline.h"

#include <chrono>
#include <ctime>
#include <filesystem>

#include "calib/camera_io.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "core/text.h"
#include "omap/omap_json.h"
#include "pipeline/run_report.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

// Runs `body` as stage `index` of 3 and records its wall and CPU time.
template <typename Body>
void TimeStage(const std::string& name, int index, const RunPipelineCallbacks& callbacks,
               RunPipelineResult* result, const Body& body) {
  if (callbacks.stage_started) callbacks.stage_started(name, index, 3);
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  body();
  result->times.push_back(
      {name, SecondsSince(start), static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC});
}

}  // namespace

bool RunPipelineOptions::Validate(std::string* why) const {
  return detect.Validate(why) && slam.Validate(why) && export_.Validate(why) && eval.Validate(why);
}

StageTime RunPipelineResult::Total() const {
  StageTime total{"total", 0, 0};
  for (const StageTime& t : times) {
    total.seconds += t.seconds;
    total.cpu_seconds += t.cpu_seconds;
  }
  return total;
}

void CheckRunInputs(const std::string& run_dir) {
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  const FrameSource frames(run_dir);
  ReadOdometry(paths.odometry, static_cast<long>(frames.size()));
  LoadCamera(paths.camera);
  const std::vector<ObjectClass> classes = ReadClasses(paths.classes);
  bool any_colour = false;
  for (const ObjectClass& c : classes) any_colour |= c.colour.has_value();
  if (!any_colour)
    throw Error::InFile(paths.classes,
                        "no class has a colour model (run 'oslam train-colors' first)");
}

RunPipelineResult RunPipeline(const std::string& run_dir, const std::string& out_dir,
                              const RunPipelineOptions& options,
                              const RunPipelineCallbacks& callbacks) {
  std::string why;
  if (!options.Validate(&why)) throw Error("configuration: " + why);
  CheckRunInputs(run_dir);
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw Error::InFile(out_dir, "cannot create the output folder: " + ec.message());
  if (callbacks.ready) callbacks.ready();

  // The export stage's overlays reuse the frames the detect stage decoded
  // (1 GiB holds about 1100 frames of 640x480; beyond it frames are decoded
  // again).
  SetFrameCacheLimit(size_t{1} << 30);
  RunPipelineResult result;
  const fs::path out(out_dir);
  result.detections_path = (out / "detections.csv").string();
  result.omap_path = (out / "omap.json").string();
  const StageOutput& output = callbacks.output;
  TimeStage("detect", 1, callbacks, &result, [&] {
    result.detect = RunDetectStage(run_dir, result.detections_path, options.detect, output);
  });
  TimeStage("o-slam", 2, callbacks, &result, [&] {
    const SlamStageInput input{run_dir, result.detections_path, &result.detect.detections};
    result.slam = RunSlamStage(input, result.omap_path, options.slam, output);
  });
  // The overlays show this run's detections (the run folder may have none).
  TimeStage("export", 3, callbacks, &result, [&] {
    result.map = ReadOMap(result.omap_path);
    RunExportStage(result.map, {run_dir, result.detections_path}, out, options.export_, output);
  });

  const std::string eval_path = (out / "eval.json").string();
  result.metrics = RunEvalStage(result.map, run_dir, eval_path, options.eval);
  if (result.metrics) result.eval_path = eval_path;
  const std::string trace = options.slam.method == SlamMethod::kOSlam
                                ? WriteSamplerTrace(result.slam.sampler.summary, out_dir)
                                : "";
  result.report_path = (out / "report.md").string();
  WriteTextFileAtomically(result.report_path, RunReport(run_dir, options, result, trace));
  return result;
}

}  // namespace oslam

#include "pipeline/run_pipeline.h"

#include <chrono>
#include <ctime>
#include <filesystem>
#include <sstream>

#include <nlohmann/json.hpp>

#include "calib/camera_io.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "core/text.h"
#include "omap/omap_json.h"
#include "pipeline/timed_run.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

std::string Fixed(double value, int digits) {
  return Format("%.*f", digits, value);
}

std::string Report(const std::string& run_dir, const std::string& out_dir,
                   const RunPipelineOptions& options, const RunPipelineResult& result,
                   const nlohmann::json& omap_json) {
  std::ostringstream md;
  md << "# oslam run\n\nInput: `" << run_dir << "`";
  if (result.selection)
    md << " (odometry by time: " << result.selection->Summary() << ", run folder `run/`)";
  md << "; method: " << SlamMethodName(options.slam.method) << ", seed "
     << options.slam.sampler.seed << ". Configuration: `config.yaml`.\n\n";
  md << "![bird's-eye view](birdseye.png) ![perspective view](perspective.png)\n\n";
  if (fs::exists(fs::path(out_dir) / "trajectories.png"))
    md << "![trajectory error](trajectories.png)\n\n";
  md << "3D map: `map.glb` (Blender: File > Import > glTF 2.0), `map.ply` (MeshLab).\n\n";

  md << "## Timings\n\n| stage | seconds | CPU seconds |\n|---|---|---|\n";
  for (const StageTime& t : result.times)
    md << "| " << t.name << " | " << Fixed(t.seconds, 2) << " | " << Fixed(t.cpu_seconds, 2)
       << " |\n";
  const StageTime total = result.Total();
  md << "| total | " << Fixed(total.seconds, 2) << " | " << Fixed(total.cpu_seconds, 2) << " |\n\n";

  md << "## Objects\n\n| id | class | existence | x m | y m | z m | diameter m | height m | "
        "detections |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const OMapObject& o : result.map.objects) {
    md << "| " << o.id << " | " << o.class_name << " | " << Fixed(o.existence_probability, 2)
       << " | " << Fixed(o.base_world.x(), 2) << " | " << Fixed(o.base_world.y(), 2) << " | "
       << Fixed(o.base_world.z(), 2) << " | " << Fixed(o.diameter_m, 2) << " | "
       << Fixed(o.height_m, 2) << " | " << o.num_detections << " |\n";
  }
  if (omap_json.contains("sampler"))
    md << "\n## Sampler convergence\n\n```json\n" << omap_json["sampler"].dump(1) << "\n```\n";
  if (result.metrics)
    md << "\n## Against ground truth\n\n```\n" << result.metrics->Table() << "```\n";
  return md.str();
}

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
  return detect.Validate(why) && slam.Validate(why) && export_.Validate(why) &&
         eval.Validate(why) && frames.Validate(why);
}

StageTime RunPipelineResult::Total() const {
  StageTime total{"total", 0, 0};
  for (const StageTime& t : times) {
    total.seconds += t.seconds;
    total.cpu_seconds += t.cpu_seconds;
  }
  return total;
}

void CheckRunInputs(const std::string& run_dir, const FrameSelectionOptions& frame_options) {
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  const FrameSource frames(run_dir);
  if (fs::is_regular_file(paths.odometry) && IsTimedOdometry(paths.odometry)) {
    if (frames.times().empty())
      throw Error::InFile(paths.odometry,
                          "is by time (stamp_s) but the frames have no times: give "
                          "frame_times.csv (frame,stamp_s) or a video with a frame rate");
    try {
      SelectFrames(ReadTimedOdometry(paths.odometry), frames.times(), frame_options);
    } catch (const Error& e) {
      if (std::string(e.what()).rfind(paths.odometry, 0) == 0) throw;
      throw Error::InFile(paths.odometry, e.what());
    }
  } else {
    ReadOdometry(paths.odometry, static_cast<long>(frames.size()));
  }
  LoadCamera(paths.camera);
  const std::vector<ObjectClass> classes = ReadClasses(paths.classes);
  bool any_colour = false;
  for (const ObjectClass& c : classes) any_colour |= c.colour.has_value();
  if (!any_colour)
    throw Error::InFile(paths.classes,
                        "no class has a colour model (run 'oslam train-colors' first)");
}

RunPipelineResult RunPipeline(const std::string& source_run, const std::string& out_dir,
                              const RunPipelineOptions& options,
                              const RunPipelineCallbacks& callbacks) {
  std::string why;
  if (!options.Validate(&why)) throw Error("configuration: " + why);
  CheckRunInputs(source_run, options.frames);
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
  // Odometry by time: the stages run on the kept frames, written as a run
  // folder with one odometry row per frame.
  std::string run_dir = source_run;
  if (IsTimedOdometry(RunFolderPaths::Of(source_run).odometry)) {
    TimedRunResult timed =
        PrepareTimedRun(source_run, (out / "run").string(), options.frames, callbacks.output);
    callbacks.output.Print("frames: " + timed.selection.Summary());
    run_dir = result.timed_run_dir = timed.run_dir;
    result.selection = std::move(timed.selection);
  }
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
  // The raw JSON also carries the sampler's report.
  const nlohmann::json omap_json = nlohmann::json::parse(ReadTextFile(result.omap_path));
  result.report_path = (out / "report.md").string();
  WriteTextFileAtomically(result.report_path,
                          Report(source_run, out_dir, options, result, omap_json));
  return result;
}

}  // namespace oslam

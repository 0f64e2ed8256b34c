#include "pipeline/run_pipeline.h"

#include <chrono>
#include <ctime>
#include <filesystem>
#include <functional>
#include <optional>

#include "calib/camera_io.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "core/text.h"
#include "omap/omap_json.h"
#include "pipeline/run_report.h"
#include "pipeline/run_status.h"
#include "pipeline/timed_run.h"

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

namespace {

// The stages, each run or (with --resume) reused, then the evaluation and
// the report; `status` follows them.
RunPipelineResult RunStagesOf(const std::string& run_dir, const std::string& out_dir,
                              const RunPipelineOptions& options,
                              const RunPipelineCallbacks& callbacks,
                              const std::function<bool(const char*)>& reused, RunStatus* status,
                              const FrameSelection* selection) {
  // The export stage's overlays reuse the frames the detect stage decoded
  // (1 GiB holds about 1100 frames of 640x480; beyond it frames are decoded
  // again).
  SetFrameCacheLimit(size_t{1} << 30);
  RunPipelineResult result;
  if (selection) result.selection = *selection;
  const fs::path out(out_dir);
  result.detections_path = (out / "detections.csv").string();
  result.omap_path = (out / "omap.json").string();
  const StageOutput& output = callbacks.output;
  // Runs `body` as stage `name`, or takes it from the previous run.
  const auto stage = [&](const char* name, int index, const std::function<void()>& body,
                         const std::function<void()>& reuse) {
    if (reused(name)) {
      if (reuse) reuse();
      result.times.push_back({std::string(name) + " (reused)", 0, 0});
      status->Mark(name, "reused");
      return;
    }
    status->Mark(name, "running");
    TimeStage(name, index, callbacks, &result, body);
    status->Mark(name, "complete");
  };
  stage(
      "detect", 1,
      [&] {
        result.detect = RunDetectStage(run_dir, result.detections_path, options.detect, output);
      },
      [&] {
        result.detect.detections = ReadDetections(result.detections_path,
                                                  ReadClasses(RunFolderPaths::Of(run_dir).classes));
      });
  stage(
      "o-slam", 2,
      [&] {
        const SlamStageInput input{run_dir, result.detections_path, &result.detect.detections};
        result.slam = RunSlamStage(input, result.omap_path, options.slam, output);
      },
      nullptr);
  result.map = ReadOMap(result.omap_path);
  // The overlays show this run's detections (the run folder may have none).
  stage(
      "export", 3,
      [&] {
        RunExportStage(result.map, {run_dir, result.detections_path}, out, options.export_, output);
      },
      nullptr);

  const std::string eval_path = (out / "eval.json").string();
  status->Mark("eval", "running");
  result.metrics = RunEvalStage(result.map, run_dir, eval_path, options.eval);
  if (result.metrics) result.eval_path = eval_path;
  status->Mark("eval", "complete");
  status->Mark("report", "running");
  const std::string trace = options.slam.method == SlamMethod::kOSlam
                                ? WriteSamplerTrace(result.slam.sampler.summary, out_dir)
                                : "";
  result.report_path = (out / "report.md").string();
  WriteTextFileAtomically(result.report_path, RunReport(run_dir, options, result, trace));
  status->Mark("report", "complete");
  return result;
}

std::vector<RunStage> RunStages(const std::string& run_dir, const RunPipelineOptions& options) {
  const bool truth = fs::is_directory(fs::path(run_dir) / "ground_truth");
  std::vector<std::string> exported = {
      "map.glb",      "map.gltf",     "map.ply",      "trajectory.ply", "trajectory_estimated.txt",
      "birdseye.png", "birdseye.svg", "birdseye.csv", "perspective.png"};
  if (fs::exists(RunFolderPaths::Of(run_dir).odometry))
    exported.push_back("trajectory_odometry.txt");
  std::vector<std::string> stale_exports, stale_eval;
  for (const char* file :
       {"trajectory_truth.txt", "trajectories.png", "trajectories.svg", "trajectories.csv"})
    (truth ? exported : stale_exports).push_back(file);
  (options.export_.overlays ? exported : stale_exports).push_back("overlays/");
  if (!truth) stale_eval.push_back("eval.json");
  return {{"configuration", {"config.yaml"}},
          {"detect", {"detections.csv"}},
          {"o-slam", {"omap.json"}},
          {"export", exported, stale_exports},
          {"eval", truth ? std::vector<std::string>{"eval.json"} : std::vector<std::string>{},
           stale_eval},
          {"report", {"report.md", "sampler_trace.png", "sampler_trace.svg", "sampler_trace.csv"}}};
}

}  // namespace

RunPipelineResult RunPipeline(const std::string& run_dir, const std::string& out_dir,
                              const RunPipelineOptions& options,
                              const RunPipelineCallbacks& callbacks) {
  std::string why;
  if (!options.Validate(&why)) throw Error("configuration: " + why);
  CheckRunInputs(run_dir, options.frames);
  if (options.export_.overlays) CheckOutputSubfolder(out_dir, "overlays");
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw Error::InFile(out_dir, "cannot create the output folder: " + ec.message());

  // run.json marks the folder from here on: running, then complete or
  // failed. A re-run first removes what it will write (--resume: all but
  // the stages it reuses).
  const std::vector<RunStage> stages = RunStages(run_dir, options);
  const std::string fingerprint = RunFingerprint(run_dir, options.settings);
  const std::vector<std::string> reused = options.resume
                                              ? RunStatus::Reusable(out_dir, fingerprint, stages)
                                              : std::vector<std::string>();
  const auto is_reused = [&](const char* stage) {
    return std::find(reused.begin(), reused.end(), stage) != reused.end();
  };
  RunStatus status(out_dir, run_dir, fingerprint, stages);
  status.Start(reused);
  try {
    if (callbacks.ready) callbacks.ready();
    status.Mark("configuration", "complete");
    // Odometry by time: the stages run on the kept frames, written as a run
    // folder with one odometry row per frame (OUT_DIR/run).
    std::string stage_run = run_dir;
    std::optional<TimedRunResult> timed;
    if (IsTimedOdometry(RunFolderPaths::Of(run_dir).odometry)) {
      timed = PrepareTimedRun(run_dir, (fs::path(out_dir) / "run").string(), options.frames,
                              callbacks.output);
      callbacks.output.Print("frames: " + timed->selection.Summary());
      stage_run = timed->run_dir;
    }
    RunPipelineResult result = RunStagesOf(stage_run, out_dir, options, callbacks, is_reused,
                                           &status, timed ? &timed->selection : nullptr);
    if (timed) result.timed_run_dir = timed->run_dir;
    status.Complete();
    return result;
  } catch (const std::exception& e) {
    status.Fail(e.what());
    throw;
  }
}

}  // namespace oslam

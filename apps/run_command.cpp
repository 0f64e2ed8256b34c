// oslam run: one command from a video folder to an O-Map. Chains the stage
// commands (detect, slam, export) with one configuration, then evaluates
// against ground truth when the folder has it, and writes a short report.
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "apps/run_config.h"
#include "calib/camera_io.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "omap/evaluation.h"
#include "omap/omap_json.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

struct StageTime {
  std::string name;
  double seconds = 0;
  // CPU time of all the process' threads: next to the wall time it shows
  // how parallel a stage ran, and on a shared machine it is the steadier
  // measure.
  double cpu_seconds = 0;
};

// Everything a run needs, checked before anything is written.
void CheckInputs(const std::string& run_dir) {
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

std::string Fixed(double value, int digits) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
  return buffer;
}

std::string Report(const std::string& run_dir, const std::string& out_dir, const RunConfig& config,
                   const std::vector<StageTime>& times, const OMap& map,
                   const nlohmann::json& omap_json, const MapMetrics* metrics) {
  std::ostringstream md;
  md << "# oslam run\n\nInput: `" << run_dir << "`; method: " << config.Get("slam", "method")
     << ", seed " << config.Get("slam", "seed") << ". Configuration: `config.yaml`.\n\n";
  md << "![bird's-eye view](birdseye.png) ![perspective view](perspective.png)\n\n";
  if (fs::exists(fs::path(out_dir) / "trajectories.png")) md << "![trajectory error](trajectories.png)\n\n";
  md << "3D map: `map.glb` (Blender: File > Import > glTF 2.0), `map.ply` (MeshLab).\n\n";

  md << "## Timings\n\n| stage | seconds | CPU seconds |\n|---|---|---|\n";
  double total = 0, total_cpu = 0;
  for (const StageTime& t : times) {
    md << "| " << t.name << " | " << Fixed(t.seconds, 2) << " | " << Fixed(t.cpu_seconds, 2)
       << " |\n";
    total += t.seconds;
    total_cpu += t.cpu_seconds;
  }
  md << "| total | " << Fixed(total, 2) << " | " << Fixed(total_cpu, 2) << " |\n\n";

  md << "## Objects\n\n| id | class | existence | x m | y m | z m | diameter m | height m | detections |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
  for (const OMapObject& o : map.objects) {
    md << "| " << o.id << " | " << o.class_name << " | " << Fixed(o.existence_probability, 2)
       << " | " << Fixed(o.base_world.x(), 2) << " | " << Fixed(o.base_world.y(), 2) << " | "
       << Fixed(o.base_world.z(), 2) << " | " << Fixed(o.diameter_m, 2) << " | "
       << Fixed(o.height_m, 2) << " | " << o.num_detections << " |\n";
  }
  if (omap_json.contains("sampler")) {
    md << "\n## Sampler convergence\n\n```json\n" << omap_json["sampler"].dump(1) << "\n```\n";
  }
  if (metrics) md << "\n## Against ground truth\n\n```\n" << metrics->Table() << "```\n";
  return md.str();
}

}  // namespace

int RunRunCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam run VIDEO_DIR -o OUT_DIR [--config oslam.yaml] [--set KEY=VALUE]",
                      "Detects objects in every frame, runs O-SLAM, and exports the O-Map "
                      "(omap.json, map.glb, map.ply,\nfigures, overlays) with a report; evaluates "
                      "against ground_truth/ when present.\nParameters: 'oslam config "
                      "--print-defaults'.");
  arguments.AddPositional("VIDEO_DIR", "the run folder (frames, odometry.csv, camera.yaml, classes.yaml)");
  arguments.AddOption("output", "-o", "OUT_DIR", "where everything is written (created)");
  arguments.AddOption("config", "", "FILE.yaml", "configuration (unknown keys are errors)");
  arguments.AddRepeatedOption("set", "SECTION.KEY=VALUE", "override one configuration value");
  arguments.AddOption("seed", "", "N", "seed of the sampler (same as --set slam.seed=N)");
  arguments.AddFlag("quiet", "print nothing but errors");
  arguments.AddFlag("verbose", "also print the resolved configuration");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("give the output folder with -o OUT_DIR");
  if (arguments.Flag("quiet") && arguments.Flag("verbose"))
    throw UsageError("--quiet and --verbose exclude each other");

  RunConfig config;
  if (arguments.Has("config")) config.LoadYaml(arguments.Get("config"));
  for (const std::string& assignment : arguments.GetAll("set")) config.Override(assignment);
  if (arguments.Has("seed")) config.Override("slam.seed=" + arguments.Get("seed"));
  config.Check();
  const std::string method = config.Get("slam", "method");

  const std::string run_dir = arguments.Get("VIDEO_DIR");
  const std::string out_dir = arguments.Get("output");
  const bool quiet = arguments.Flag("quiet"), verbose = arguments.Flag("verbose");
  CheckInputs(run_dir);
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw Error::InFile(out_dir, "cannot create the output folder: " + ec.message());
  WriteTextFileAtomically((fs::path(out_dir) / "config.yaml").string(), config.ToYaml());
  if (verbose) std::fputs(config.ToYaml().c_str(), stdout);

  // The export stage's overlays reuse the frames the detect stage decoded
  // (1 GiB holds about 1100 frames of 640x480; beyond it frames are decoded
  // again).
  SetFrameCacheLimit(size_t{1} << 30);
  const std::string detections = (fs::path(out_dir) / "detections.csv").string();
  const std::string omap = (fs::path(out_dir) / "omap.json").string();
  std::vector<StageTime> times;
  auto stage = [&](const std::string& name, int index,
                   const std::function<int(const std::vector<std::string>&)>& command,
                   std::vector<std::string> stage_args, const std::string& section) {
    if (!quiet) std::fprintf(stderr, "[run] stage %d/3: %s\n", index, name.c_str());
    const std::vector<std::string> options = config.OptionsFor(section);
    stage_args.insert(stage_args.end(), options.begin(), options.end());
    if (quiet) stage_args.push_back("--quiet");
    const auto start = std::chrono::steady_clock::now();
    const std::clock_t cpu_start = std::clock();
    const int code = command(stage_args);
    times.push_back(
        {name, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
         static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC});
    if (code != 0) throw Error("stage " + name + " failed (exit code " + std::to_string(code) + ")");
  };
  stage("detect", 1, RunDetectCommand, {run_dir, "-o", detections}, "detect");
  std::vector<std::string> slam_args = {run_dir, "--detections", detections, "-o", omap};
  if (method == "nn") {
    slam_args.push_back("--baseline");
    slam_args.push_back("nn");
  }
  stage("o-slam", 2, RunSlamCommand, slam_args, "slam");
  // The overlays show this run's detections (the run folder may have none).
  std::vector<std::string> export_args = {omap, "--run", run_dir, "-o", out_dir};
  if (config.Get("export", "overlays") == "1") {
    export_args.push_back("--detections");
    export_args.push_back(detections);
  }
  stage("export", 3, RunExportCommand, export_args, "export");

  // ReadOMap checks the file; the raw JSON also carries the sampler's report.
  const OMap map = ReadOMap(omap);
  const nlohmann::json omap_json = nlohmann::json::parse(ReadTextFile(omap));
  std::optional<MapMetrics> metrics;
  if (const std::optional<GroundTruth> truth = ReadGroundTruth(run_dir)) {
    MapMetricsOptions options;
    options.existence_threshold = std::stod(config.Get("eval", "threshold"));
    options.match_gate_m = std::stod(config.Get("eval", "gate_m"));
    const Odometry odometry = ReadOdometry(RunFolderPaths::Of(run_dir).odometry);
    metrics = EvaluateMap(map, odometry.poses, *truth, options);
    WriteTextFileAtomically((fs::path(out_dir) / "eval.json").string(), metrics->Json());
  }
  const std::string report = (fs::path(out_dir) / "report.md").string();
  WriteTextFileAtomically(report, Report(run_dir, out_dir, config, times, map, omap_json,
                                         metrics ? &*metrics : nullptr));
  if (!quiet) {
    double total = 0, total_cpu = 0;
    for (const StageTime& t : times) {
      std::printf("%-8s %6.2f s  (CPU %.2f s)\n", t.name.c_str(), t.seconds, t.cpu_seconds);
      total += t.seconds;
      total_cpu += t.cpu_seconds;
    }
    std::printf("%-8s %6.2f s  (CPU %.2f s)\n", "total", total, total_cpu);
    if (metrics) std::fputs(metrics->Table().c_str(), stdout);
    std::printf("O-Map: %s/map.glb (open in Blender: File > Import > glTF 2.0); report: %s\n",
                out_dir.c_str(), report.c_str());
  }
  return 0;
}

int RunConfigCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam config --print-defaults | --check FILE.yaml",
                      "Prints the default configuration of 'oslam run', or checks a "
                      "configuration file.");
  arguments.AddFlag("print-defaults", "print every parameter with its default and meaning");
  arguments.AddOption("check", "", "FILE.yaml", "read a configuration and print it resolved");
  if (!arguments.Parse(args)) return 0;
  if (arguments.Flag("print-defaults") == arguments.Has("check"))
    throw UsageError("give exactly one of --print-defaults and --check");
  RunConfig config;
  if (arguments.Has("check")) {
    config.LoadYaml(arguments.Get("check"));
    config.Check();
  }
  std::fputs(config.ToYaml().c_str(), stdout);
  return 0;
}

}  // namespace oslam

// oslam run: one command from a video folder to an O-Map
// (pipeline/run_pipeline.h) with one configuration (apps/run_config.h);
// and oslam config, which prints or checks that configuration.
#include <cstdio>
#include <filesystem>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "apps/run_config.h"
#include "apps/stage_bindings.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "pipeline/run_report.h"

namespace oslam {
namespace {

void PrintTime(const StageTime& t) {
  std::printf("%-8s %6.2f s  (CPU %.2f s)\n", t.name.c_str(), t.seconds, t.cpu_seconds);
}

}  // namespace

int RunRunCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam run VIDEO_DIR -o OUT_DIR [--config oslam.yaml] [--set KEY=VALUE]",
                      "Detects objects in every frame, runs O-SLAM, and exports the O-Map "
                      "(omap.json, map.glb, map.ply,\nfigures, overlays) with a report; evaluates "
                      "against ground_truth/ when present.\nParameters: 'oslam config "
                      "--print-defaults'.");
  arguments.AddPositional("VIDEO_DIR",
                          "the run folder (frames, odometry.csv, camera.yaml, classes.yaml)");
  arguments.AddOption("output", "-o", "OUT_DIR", "where everything is written (created)");
  arguments.AddOption("config", "", "FILE.yaml", "configuration (unknown keys are errors)");
  arguments.AddRepeatedOption("set", "SECTION.KEY=VALUE", "override one configuration value");
  arguments.AddOption("seed", "", "N", "seed of the sampler (same as --set slam.seed=N)");
  arguments.AddFlag("resume",
                    "reuse the stages the last run into OUT_DIR completed with the same "
                    "configuration and inputs (run.json)");
  arguments.AddFlag("quiet", "print nothing but errors");
  arguments.AddFlag("verbose", "also print the resolved configuration");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("give the output folder with -o OUT_DIR");
  const bool quiet = arguments.Flag("quiet"), verbose = arguments.Flag("verbose");
  if (quiet && verbose) throw UsageError("--quiet and --verbose exclude each other");

  RunConfig config;
  if (arguments.Has("config")) config.LoadYaml(arguments.Get("config"));
  for (const std::string& assignment : arguments.GetAll("set")) config.Override(assignment);
  if (arguments.Has("seed")) config.Override("slam.seed=" + arguments.Get("seed"));
  config.Check();

  const std::string out_dir = arguments.Get("output");
  RunPipelineOptions options = config.options();
  options.resume = arguments.Flag("resume");
  options.settings = config.ToYaml();
  RunPipelineCallbacks callbacks;
  callbacks.ready = [&] {
    WriteTextFileAtomically((std::filesystem::path(out_dir) / "config.yaml").string(),
                            config.ToYaml());
    if (verbose) std::fputs(config.ToYaml().c_str(), stdout);
  };
  callbacks.stage_started = [quiet](const std::string& name, int index, int count) {
    if (!quiet) std::fprintf(stderr, "[run] stage %d/%d: %s\n", index, count, name.c_str());
  };
  callbacks.output = CommandOutput("run", quiet);
  const RunPipelineResult result =
      RunPipeline(arguments.Get("VIDEO_DIR"), out_dir, options, callbacks);
  if (!quiet) {
    std::printf("input: %s\n", InputSummary(result).c_str());
    for (const StageTime& t : result.times) PrintTime(t);
    PrintTime(result.Total());
    if (result.metrics) std::fputs(result.metrics->Table().c_str(), stdout);
    std::printf("O-Map: %s/map.glb (open in Blender: File > Import > glTF 2.0); report: %s\n",
                out_dir.c_str(), result.report_path.c_str());
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

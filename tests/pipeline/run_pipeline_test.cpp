// The run pipeline on a small simulated run: the files it writes, the
// callbacks in order, the same detections, O-Map, scores and models as the
// single commands (oslam detect, slam, export, eval) given the same
// options, and invalid options or input refused before anything is written.
#include "pipeline/run_pipeline.h"

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "simulated_run.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;
using testing::Oslam;
using testing::ReadFile;

nlohmann::json Json(const std::string& path) {
  return nlohmann::json::parse(ReadFile(path));
}

size_t Count(const std::string& text, const std::string& part) {
  size_t n = 0;
  for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

// Everything `oslam run` writes on the simulated run (16 frames, ground truth).
const std::vector<std::string> kRunFiles = {"detections.csv",
                                            "omap.json",
                                            "map.glb",
                                            "map.gltf",
                                            "map.ply",
                                            "trajectory.ply",
                                            "trajectory_estimated.txt",
                                            "trajectory_odometry.txt",
                                            "trajectory_truth.txt",
                                            "birdseye.png",
                                            "birdseye.svg",
                                            "birdseye.csv",
                                            "perspective.png",
                                            "trajectories.png",
                                            "trajectories.svg",
                                            "trajectories.csv",
                                            "overlays/000000.jpg",
                                            "overlays/000015.jpg",
                                            "sampler_trace.png",
                                            "sampler_trace.svg",
                                            "sampler_trace.csv",
                                            "eval.json",
                                            "report.md"};

TEST(RunPipeline, WritesEveryFileAndEqualsTheSingleCommands) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  const std::string out = dir.Path("out");
  RunPipelineOptions options;
  testing::MakeFast(&options.slam);
  options.slam.sampler.seed = 3;
  std::vector<std::string> events;
  std::vector<std::string> lines;
  RunPipelineCallbacks callbacks;
  callbacks.ready = [&] {
    EXPECT_TRUE(fs::is_directory(out));
    events.push_back("ready");
  };
  callbacks.stage_started = [&](const std::string& stage, int index, int count) {
    events.push_back(stage + " " + std::to_string(index) + "/" + std::to_string(count));
  };
  callbacks.output.quiet = true;
  callbacks.output.print = [&](const std::string& line) { lines.push_back(line); };
  const RunPipelineResult result = RunPipeline(run, out, options, callbacks);

  EXPECT_EQ(events, (std::vector<std::string>{"ready", "detect 1/3", "o-slam 2/3", "export 3/3"}));
  EXPECT_TRUE(lines.empty()) << "quiet, yet " << lines.front();
  ASSERT_EQ(result.times.size(), 3u);
  EXPECT_EQ(result.times[1].name, "o-slam");
  EXPECT_EQ(result.Total().seconds,
            result.times[0].seconds + result.times[1].seconds + result.times[2].seconds);
  for (const std::string& file : kRunFiles)
    EXPECT_TRUE(fs::is_regular_file(fs::path(out) / file)) << file;
  EXPECT_EQ(result.eval_path, out + "/eval.json");
  ASSERT_TRUE(result.metrics.has_value());
  EXPECT_EQ(result.metrics->true_objects_total, 1);
  EXPECT_EQ(result.map.trajectory.size(), 16u);
  // The report: the input counts, the sampler as a plot and numbers (no
  // raw trace), every score named once with its definition.
  const std::string report = ReadFile(result.report_path);
  EXPECT_NE(report.find("| frames | 16 |"), std::string::npos) << report;
  EXPECT_NE(report.find("| detections | " + std::to_string(result.detect.detections.size()) + " |"),
            std::string::npos);
  const SamplerOptions& sampler = options.slam.sampler;
  EXPECT_NE(report.find(std::to_string(sampler.num_chains) + " chains, " +
                        std::to_string(sampler.num_iterations) + " iterations (the first " +
                        std::to_string(sampler.burn_in) + " burn-in), seed 3"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("oslam " OSLAM_VERSION), std::string::npos);
  EXPECT_NE(report.find("![sampler trace](sampler_trace.png)"), std::string::npos);
  EXPECT_NE(report.find("| effective sample size | "), std::string::npos);
  EXPECT_EQ(report.find("cold_chain_log_target"), std::string::npos);
  for (const char* name : {"3D position error, median", "horizontal position error, median"})
    EXPECT_EQ(Count(report, name), 1u) << name;
  EXPECT_EQ(Count(ReadFile(out + "/sampler_trace.csv"), "\n"),
            1 + result.slam.sampler.summary.hill_climb_trace.size() +
                result.slam.sampler.summary.cold_trace.size());

  // The single commands, given the same options as flags.
  const std::string single = dir.Path("single");
  fs::create_directories(single);
  ASSERT_EQ(Oslam("detect " + run + " -o " + single + "/detections.csv --quiet").exit_code, 0);
  EXPECT_EQ(ReadFile(single + "/detections.csv"), ReadFile(result.detections_path));
  const std::string csv = ReadFile(result.detections_path);
  EXPECT_EQ(result.detect.detections.size() + 1,
            static_cast<size_t>(std::count(csv.begin(), csv.end(), '\n')));

  ASSERT_EQ(Oslam("slam " + run + " --detections " + result.detections_path + " -o " + single +
                  "/omap.json --seed 3 --quiet" + testing::kFastFlags)
                .exit_code,
            0);
  const nlohmann::json piped = Json(result.omap_path), alone = Json(single + "/omap.json");
  for (const char* part : {"objects", "trajectory"}) EXPECT_EQ(piped[part], alone[part]) << part;
  EXPECT_EQ(piped["sampler"]["cold_chain_log_target"], alone["sampler"]["cold_chain_log_target"]);
  EXPECT_EQ(piped["source"], alone["source"]);

  ASSERT_EQ(
      Oslam("export " + result.omap_path + " --run " + run + " -o " + single + "/export --quiet")
          .exit_code,
      0);
  for (const char* file : {"map.gltf", "map.ply", "trajectory.ply", "trajectory_estimated.txt"})
    EXPECT_EQ(ReadFile(single + "/export/" + file), ReadFile(out + "/" + file)) << file;

  const testing::CommandResult eval =
      Oslam("eval " + result.omap_path + " " + run + "/ground_truth --json");
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_EQ(eval.out, ReadFile(out + "/eval.json"));
}

TEST(RunPipeline, NearestNeighbourMethodAndNoOverlays) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  RunPipelineOptions options;
  options.slam.method = SlamMethod::kNearestNeighbour;
  options.export_.overlays = false;
  const RunPipelineResult result = RunPipeline(run, dir.Path("nn"), options);
  EXPECT_FALSE(fs::exists(dir.Path("nn/overlays")));
  EXPECT_EQ(Json(result.omap_path)["source"]["association"], "nearest neighbour (gated, 0.5 m)");
  EXPECT_FALSE(Json(result.omap_path).contains("sampler"));
  EXPECT_NE(ReadFile(result.report_path).find("| method | nn |"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir.Path("nn/sampler_trace.png")));
}

TEST(RunPipeline, InvalidOptionsAndInputAreRefusedBeforeAnythingIsWritten) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  RunPipelineOptions options;
  options.slam.sampler.burn_in = options.slam.sampler.num_iterations;
  std::string why;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_NE(why.find("burn-in"), std::string::npos) << why;
  EXPECT_THROW(RunPipeline(run, dir.Path("bad_options"), options), Error);
  EXPECT_FALSE(fs::exists(dir.Path("bad_options")));

  options = RunPipelineOptions();
  options.export_.figure_size_px = 0;
  EXPECT_FALSE(options.Validate(&why));
  options = RunPipelineOptions();
  options.detect.threads = -1;
  EXPECT_FALSE(options.Validate(&why));

  bool ready = false;
  RunPipelineCallbacks callbacks;
  callbacks.ready = [&] { ready = true; };
  try {
    RunPipeline(dir.Path("no_such_run"), dir.Path("bad_input"), RunPipelineOptions(), callbacks);
    ADD_FAILURE() << "a missing run folder passed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_run"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(ready);
  EXPECT_FALSE(fs::exists(dir.Path("bad_input")));
}

}  // namespace
}  // namespace oslam

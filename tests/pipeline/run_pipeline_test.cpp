// The run pipeline on a small simulated run: the files it writes, the
// callbacks in order, the same detections, O-Map, scores and models as the
// single commands (oslam detect, slam, export, eval) given the same
// options, and invalid options or input refused before anything is written.
#include "pipeline/run_pipeline.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "core/text.h"
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

// The same simulated frames as an mp4 video: the pipeline takes the video
// file itself (its folder is the run folder), decodes it once per stage, and
// the lossy compression changes the detections little.
TEST(RunPipeline, AVideoFileIsARunWithNearlyThePngRunsDetections) {
  const std::string png_run = testing::SimulatedRun();
  ASSERT_FALSE(png_run.empty());
  testing::TempDir dir;
  const std::string video_run = dir.Path("video_run");
  ASSERT_EQ(Oslam("simulate " + std::string(OSLAM_SOURCE_DIR) +
                  "/tests/data/sift_clutter.yaml -o " + video_run + " --video 30 --quiet")
                .exit_code,
            0);
  ASSERT_TRUE(fs::is_regular_file(video_run + "/video.mp4"));
  EXPECT_FALSE(fs::exists(video_run + "/frames"));
  EXPECT_FALSE(fs::exists(video_run + "/video.partial.mp4"));
  // The colour models trained on the PNG frames of the same scene.
  fs::copy_file(png_run + "/classes.yaml", video_run + "/classes.yaml",
                fs::copy_options::overwrite_existing);
  RunPipelineOptions options;
  testing::MakeFast(&options.slam);
  RunPipelineCallbacks callbacks;
  callbacks.output.quiet = true;
  const RunPipelineResult png = RunPipeline(png_run, dir.Path("png_out"), options, callbacks);
  const RunPipelineResult video =
      RunPipeline(video_run + "/video.mp4", dir.Path("video_out"), options, callbacks);
  EXPECT_EQ(video.map.trajectory.size(), 16u);
  EXPECT_TRUE(fs::is_regular_file(dir.Path("video_out/overlays/000015.jpg")));
  ASSERT_TRUE(video.metrics.has_value());
  ASSERT_TRUE(png.metrics.has_value());
  const double png_count = static_cast<double>(png.detect.detections.size());
  const double video_count = static_cast<double>(video.detect.detections.size());
  std::printf("detections: %.0f from PNG frames, %.0f from the mp4; found %d / %d\n", png_count,
              video_count, png.metrics->true_objects_found, video.metrics->true_objects_found);
  EXPECT_GT(png_count, 0);
  EXPECT_NEAR(video_count / png_count, 1.0, 0.2);
  EXPECT_EQ(video.metrics->true_objects_found, png.metrics->true_objects_found);
}

// Odometry by time: the simulated run's odometry as rows stamped on the
// odometry's clock, 0.25 s ahead of the frames' (30 frames/s from 100 s),
// starting only at frame 3 (stamps computed as frame time + offset, so the
// rows fall exactly on frames). The frames before the span are dropped and
// reported; the stages run on the kept frames with their poses.
TEST(RunPipeline, OdometryByTimeKeepsTheFramesInItsSpanWithTheirPoses) {
  const std::string source = testing::SimulatedRun();
  ASSERT_FALSE(source.empty());
  testing::TempDir dir;
  const std::string run = testing::CopyOfRun(source, dir.Path("timed"));
  const std::vector<Pose2> poses = ReadOdometry(source + "/odometry.csv").poses;
  ASSERT_EQ(poses.size(), 16u);
  std::ostringstream times, odometry;
  times << "frame,stamp_s\n";
  odometry << "stamp_s,x_m,y_m,theta_rad\n";
  for (size_t i = 0; i < poses.size(); ++i) {
    times << i << ',' << Number(100.0 + i / 30.0) << '\n';
    if (i >= 3)
      odometry << Number((100.0 + i / 30.0) + 0.25) << ',' << Number(poses[i].x) << ','
               << Number(poses[i].y) << ',' << Number(poses[i].theta) << '\n';
  }
  WriteTextFileAtomically(run + "/frame_times.csv", times.str());
  WriteTextFileAtomically(run + "/odometry.csv", odometry.str());

  RunPipelineOptions options;
  testing::MakeFast(&options.slam);
  options.frames.time_offset_s = 0.25;
  options.frames.stride = 1;
  RunPipelineCallbacks callbacks;
  callbacks.output.quiet = true;
  const RunPipelineResult all = RunPipeline(run, dir.Path("all"), options, callbacks);
  ASSERT_TRUE(all.selection.has_value());
  EXPECT_EQ(all.selection->before_odometry, 3);
  EXPECT_EQ(all.selection->after_odometry, 0);
  ASSERT_EQ(all.selection->frames.size(), 13u);
  EXPECT_EQ(all.timed_run_dir, dir.Path("all/run"));
  const std::vector<Pose2> kept = ReadOdometry(all.timed_run_dir + "/odometry.csv").poses;
  ASSERT_EQ(kept.size(), 13u);
  for (size_t k = 0; k < kept.size(); ++k) {
    EXPECT_NEAR(kept[k].x, poses[k + 3].x, 1e-9) << k;
    EXPECT_NEAR(kept[k].y, poses[k + 3].y, 1e-9) << k;
  }
  // The kept run's first frame is source frame 3, its ground truth too.
  const cv::Mat first = cv::imread(all.timed_run_dir + "/frames/000000.png");
  const cv::Mat source_frame = cv::imread(source + "/frames/000003.png");
  ASSERT_FALSE(first.empty());
  EXPECT_EQ(cv::norm(first, source_frame, cv::NORM_INF), 0.0);
  const std::optional<GroundTruth> truth = ReadGroundTruth(all.timed_run_dir);
  ASSERT_TRUE(truth.has_value());
  EXPECT_EQ(truth->trajectory.size(), 13u);
  EXPECT_EQ(truth->trajectory[0].x, ReadGroundTruth(source)->trajectory[3].x);
  EXPECT_EQ(all.map.trajectory.size(), 13u);
  EXPECT_TRUE(all.metrics.has_value());
  EXPECT_NE(ReadFile(all.report_path).find("kept 13 of 16 frames"), std::string::npos);

  // The default selection: a frame per 0.2 m or 10 degrees, give or take the
  // step tolerance (5 %).
  options.frames.stride = 0;
  const RunPipelineResult thinned = RunPipeline(run, dir.Path("thinned"), options, callbacks);
  ASSERT_TRUE(thinned.selection.has_value());
  const FrameSelection& selection = *thinned.selection;
  EXPECT_LT(selection.frames.size(), 13u);
  EXPECT_EQ(selection.frames.size() + static_cast<size_t>(selection.thinned), 13u);
  for (size_t k = 1; k < selection.frames.size(); ++k) {
    const Pose2& a = selection.poses[k - 1];
    const Pose2& b = selection.poses[k];
    const double reach = 1.0 - options.frames.step_tolerance;
    EXPECT_TRUE(std::hypot(b.x - a.x, b.y - a.y) >= reach * 0.2 ||
                std::abs(WrapAngle(b.theta - a.theta)) >= reach * DegToRad(10.0))
        << k;
  }
  EXPECT_EQ(thinned.map.trajectory.size(), selection.frames.size());

  // Refused before anything is written: frames without times, no frame in
  // the odometry's span.
  std::filesystem::remove(run + "/frame_times.csv");
  try {
    RunPipeline(run, dir.Path("no_times"), options, callbacks);
    ADD_FAILURE() << "frames without times were taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "odometry.csv: is by time (stamp_s) but the frames have no times"),
              std::string::npos)
        << e.what();
  }
  WriteTextFileAtomically(run + "/frame_times.csv", times.str());
  options.frames.time_offset_s = 50.0;
  try {
    RunPipeline(run, dir.Path("no_overlap"), options, callbacks);
    ADD_FAILURE() << "no frame in the odometry's span, yet it ran";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no frame lies within the odometry's time span"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.Path("no_times")));
  EXPECT_FALSE(fs::exists(dir.Path("no_overlap")));
}

}  // namespace
}  // namespace oslam

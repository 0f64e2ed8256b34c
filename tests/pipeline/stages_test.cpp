// The stages one by one on a small simulated run: detect (the same
// detections on any number of threads; unreadable frames named, or skipped
// with a warning), O-SLAM (detections in memory or from the file give the
// same O-Map; known classes change the sampler's moves), export (the files;
// overlays need the run) and eval (nothing without ground truth).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "pipeline/detect_stage.h"
#include "pipeline/eval_stage.h"
#include "pipeline/export_stage.h"
#include "pipeline/slam_stage.h"
#include "simulated_run.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;
using testing::ReadFile;

std::string CopyOf(const std::string& run, const std::string& copy) {
  fs::remove_all(copy);
  fs::copy(run, copy, fs::copy_options::recursive);
  return copy;
}

TEST(DetectStage, SameDetectionsOnAnyNumberOfThreads) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  DetectStageOptions options;
  options.threads = 1;
  std::vector<std::string> printed;
  StageOutput output;
  output.print = [&](const std::string& line) { printed.push_back(line); };
  const DetectStageResult one = RunDetectStage(run, dir.Path("one.csv"), options, output);
  options.threads = 3;
  const DetectStageResult three = RunDetectStage(run, dir.Path("three.csv"), options, {});
  EXPECT_EQ(one.frames, 16u);
  EXPECT_GT(one.detections.size(), 10u);
  EXPECT_EQ(ReadFile(dir.Path("one.csv")), ReadFile(dir.Path("three.csv")));
  ASSERT_EQ(one.detections.size(), three.detections.size());
  for (size_t i = 0; i < one.detections.size(); ++i) {
    EXPECT_EQ(one.detections[i].frame, three.detections[i].frame);
    EXPECT_EQ(one.detections[i].slice.u_phi_rad, three.detections[i].slice.u_phi_rad);
  }
  EXPECT_EQ(printed, std::vector<std::string>{"wrote " + dir.Path("one.csv")});

  options.threads = -1;
  std::string why;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_THROW(RunDetectStage(run, dir.Path("never.csv"), options, {}), Error);
  EXPECT_FALSE(fs::exists(dir.Path("never.csv")));
}

TEST(DetectStage, UnreadableFrameIsNamedUnlessSkipped) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  const std::string broken = CopyOf(run, dir.Path("broken"));
  std::ofstream(broken + "/frames/000004.png") << "not a png";
  DetectStageOptions options;
  try {
    RunDetectStage(broken, dir.Path("d.csv"), options, {});
    ADD_FAILURE() << "a corrupt frame passed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("000004.png: cannot read image"), std::string::npos)
        << e.what();
  }
  options.skip_bad_frames = true;
  std::vector<std::string> warnings;
  StageOutput output;
  output.quiet = true;  // warnings are given all the same
  output.warn = [&](const std::string& message) { warnings.push_back(message); };
  const DetectStageResult result = RunDetectStage(broken, dir.Path("d.csv"), options, output);
  EXPECT_EQ(result.skipped_frames, 1u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].rfind("skipping frame 4: ", 0), 0u) << warnings[0];
}

TEST(SlamStage, DetectionsInMemoryOrFromTheFileGiveTheSameMap) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  const DetectStageResult detected = RunDetectStage(run, dir.Path("d.csv"), {}, {});
  SlamStageOptions options;
  testing::MakeFast(&options);
  std::vector<std::string> lines;
  StageOutput output;
  output.print = [&](const std::string& line) { lines.push_back(line); };
  const SlamStageResult in_memory = RunSlamStage({run, dir.Path("d.csv"), &detected.detections},
                                                 dir.Path("a.json"), options, output);
  const SlamStageResult from_file =
      RunSlamStage({run, dir.Path("d.csv"), nullptr}, dir.Path("b.json"), options, {});
  const auto a = nlohmann::json::parse(ReadFile(dir.Path("a.json")));
  const auto b = nlohmann::json::parse(ReadFile(dir.Path("b.json")));
  EXPECT_EQ(a["objects"], b["objects"]);
  EXPECT_EQ(a["sampler"]["cold_chain_log_target"], b["sampler"]["cold_chain_log_target"]);
  EXPECT_EQ(in_memory.sampler.samples.size(), 50u);  // after the burn-in
  EXPECT_EQ(in_memory.fused.map.objects.size(), from_file.fused.map.objects.size());
  EXPECT_EQ(in_memory.source.association, "o-slam (MC3)");
  // The report: tracks first, the map's file last.
  ASSERT_GE(lines.size(), 3u);
  EXPECT_NE(lines.front().find(" tracks ("), std::string::npos) << lines.front();
  EXPECT_EQ(lines.back(), "wrote " + dir.Path("a.json"));
}

TEST(SlamStage, KnownClassesMoveTheSwitchShareAndValidateNamesTheProblem) {
  SlamStageOptions options;
  EXPECT_EQ(options.tracks.max_gap_frames, 2);
  options.known_classes = true;
  const SamplerOptions sampler = options.EffectiveSampler();
  EXPECT_EQ(sampler.sampling_moves.switch_class, 0.0);
  EXPECT_DOUBLE_EQ(sampler.sampling_moves.merge, 0.5);
  EXPECT_TRUE(std::isinf(sampler.moves.class_mismatch_penalty));
  EXPECT_EQ(options.sampler.sampling_moves.switch_class, 0.2);  // the options stay as set
  std::string why;
  options.confusion_floor = 1;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_NE(why.find("confusion floor"), std::string::npos) << why;
  options = SlamStageOptions();
  options.location_std_z_m = 0;
  EXPECT_FALSE(options.Validate(&why));
  options = SlamStageOptions();
  options.sampler.num_chains = 0;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_TRUE(SlamStageOptions().Validate(&why)) << why;
}

TEST(ExportAndEvalStages, FilesScoresAndWhatTheyNeed) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  RunDetectStage(run, dir.Path("d.csv"), {}, {});
  SlamStageOptions slam;
  testing::MakeFast(&slam);
  RunSlamStage({run, dir.Path("d.csv"), nullptr}, dir.Path("omap.json"), slam, {});
  const OMap map = ReadOMap(dir.Path("omap.json"));

  ExportStageOptions options;
  options.overlays = true;
  options.overlay_frames = "0,3";
  EXPECT_THROW(RunExportStage(map, {}, dir.Path("no_run"), options, {}), Error);
  EXPECT_FALSE(fs::exists(dir.Path("no_run")));
  RunExportStage(map, {run, dir.Path("d.csv")}, dir.Path("export"), options, {});
  for (const char* file : {"map.glb", "map.ply", "birdseye.png", "trajectories.png",
                           "overlays/000000.png", "overlays/000003.png"})
    EXPECT_TRUE(fs::is_regular_file(dir.Path("export/") + file)) << file;
  EXPECT_FALSE(fs::exists(dir.Path("export/overlays/000001.png")));
  options.figure_size_px = 1;
  std::string why;
  EXPECT_FALSE(options.Validate(&why));

  EvalStageOptions eval;
  const auto metrics = RunEvalStage(map, run, dir.Path("eval.json"), eval);
  ASSERT_TRUE(metrics.has_value());
  EXPECT_EQ(ReadFile(dir.Path("eval.json")), metrics->Json());
  const std::string no_truth = CopyOf(run, dir.Path("no_truth"));
  fs::remove_all(no_truth + "/ground_truth");
  EXPECT_FALSE(RunEvalStage(map, no_truth, dir.Path("eval2.json"), eval).has_value());
  EXPECT_FALSE(fs::exists(dir.Path("eval2.json")));
}

}  // namespace
}  // namespace oslam

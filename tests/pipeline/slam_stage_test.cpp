// The O-SLAM stage: detections in memory or from the file give the same
// O-Map and report; known classes change the moves the sampler runs with;
// Validate names what is wrong.
#include "pipeline/slam_stage.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "pipeline/detect_stage.h"
#include "simulated_run.h"

namespace oslam {
namespace {

using testing::ReadFile;

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

}  // namespace
}  // namespace oslam

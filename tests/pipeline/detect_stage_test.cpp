// The detect stage on a small simulated run: the same detections on any
// number of threads; an unreadable frame named, or skipped with a warning.
#include "pipeline/detect_stage.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "simulated_run.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;
using testing::ReadFile;

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
  const std::string broken = testing::CopyOfRun(run, dir.Path("broken"));
  std::ofstream(broken + "/frames/000004.png") << "not a png";
  DetectStageOptions options;
  try {
    RunDetectStage(broken, dir.Path("d.csv"), options, {});
    ADD_FAILURE() << "a corrupt frame passed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("000004.png: not an image"), std::string::npos)
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

}  // namespace
}  // namespace oslam

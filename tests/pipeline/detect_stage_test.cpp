// The detect stage on a small simulated run: the same detections on any
// number of threads; an unreadable frame named, or skipped with a warning.
#include "pipeline/detect_stage.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "calib/camera_io.h"
#include "core/error.h"
#include "core/image_file.h"
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

// RUN/mask.png: black pixels are not searched. Masking the image's left half
// leaves only detections whose every pixel is on the right; a mask of
// another size is named; detect.mask=none ignores it.
TEST(DetectStage, MaskedPixelsAreNotSearched) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  const std::string masked = testing::CopyOfRun(run, dir.Path("masked"));
  const std::unique_ptr<CameraModel> camera = LoadCamera(masked + "/camera.yaml");
  const int width = camera->image_width(), height = camera->image_height();
  const DetectStageResult all = RunDetectStage(masked, dir.Path("all.csv"), {}, {});
  cv::Mat mask(height, width, CV_8UC1, cv::Scalar(255));
  mask(cv::Rect(0, 0, width / 2, height)).setTo(0);
  WriteImage(masked + "/mask.png", mask);
  std::vector<std::string> printed;
  StageOutput output;
  output.print = [&](const std::string& line) { printed.push_back(line); };
  const DetectStageResult right = RunDetectStage(masked, dir.Path("right.csv"), {}, output);
  ASSERT_FALSE(printed.empty());
  EXPECT_NE(printed[0].find("mask.png ignores 50.0 % of the image"), std::string::npos)
      << printed[0];
  EXPECT_GT(right.detections.size(), 0u);
  EXPECT_LT(right.detections.size(), all.detections.size());
  for (const Detection& d : right.detections) {
    // Every pixel of the blob lies right of the middle: so do the slice's
    // corners (its outline).
    for (const cv::Point& p : SliceOutline(*camera, d.slice))
      EXPECT_GE(p.x, width / 2 - 1) << d.frame << " " << d.class_name;
  }
  DetectStageOptions none;
  none.mask = "none";
  EXPECT_EQ(RunDetectStage(masked, dir.Path("none.csv"), none, {}).detections.size(),
            all.detections.size());

  WriteImage(masked + "/mask.png", cv::Mat(height / 2, width / 2, CV_8UC1, cv::Scalar(255)));
  try {
    RunDetectStage(masked, dir.Path("never.csv"), {}, {});
    ADD_FAILURE() << "a mask of the wrong size passed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("mask.png: mask is"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.Path("never.csv")));
}

}  // namespace
}  // namespace oslam

// The oslam command as a user meets it: exit codes 0 / 1 (runtime error) /
// 2 (usage error), one-line errors on stderr, --help and --version.
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "core/run_folder.h"

#include "test_util.h"

namespace oslam {
namespace {

using Result = testing::CommandResult;

Result RunOslam(const std::string& arguments) {
  return testing::RunShellCommand(std::string(OSLAM_BINARY) + " " + arguments);
}

int Lines(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

TEST(Cli, HelpAndVersion) {
  const Result help = RunOslam("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("commands:"), std::string::npos);
  EXPECT_NE(help.out.find("camera"), std::string::npos);
  const Result version = RunOslam("--version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_EQ(version.out, std::string("oslam ") + OSLAM_VERSION + "\n");
  const Result command_help = RunOslam("camera --help");
  EXPECT_EQ(command_help.exit_code, 0);
  EXPECT_NE(command_help.out.find("--preset"), std::string::npos);
}

TEST(Cli, UsageErrorsExitWithTwo) {
  for (const char* arguments : {"", "nonsense", "camera --bogus", "camera", "camera --preset",
                                "camera --preset lpa --from x.yaml", "camera --preset mars"}) {
    const Result result = RunOslam(arguments);
    EXPECT_EQ(result.exit_code, 2) << arguments;
    EXPECT_EQ(Lines(result.err), 1) << arguments << ": " << result.err;
  }
}

// The mount is not seen by boards: calibrate asks for it instead of writing
// a default that would look calibrated.
TEST(Cli, CalibrateRequiresTheMeasuredMount) {
  const std::string base = "calibrate /nonexistent --pattern 7x6 --square 0.03 -o c.yaml";
  const Result no_height = RunOslam(base + " --mount-yaw 0");
  EXPECT_EQ(no_height.exit_code, 2);
  EXPECT_NE(no_height.err.find("missing --focus-height METRES"), std::string::npos)
      << no_height.err;
  const Result no_yaw = RunOslam(base + " --focus-height 0.8");
  EXPECT_EQ(no_yaw.exit_code, 2);
  EXPECT_NE(no_yaw.err.find("missing --mount-yaw RAD"), std::string::npos) << no_yaw.err;
  EXPECT_EQ(Lines(no_yaw.err), 1);
}

TEST(Cli, RuntimeErrorsExitWithOneAndNameTheFile) {
  const Result missing = RunOslam("camera --from /nonexistent/camera.yaml");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_EQ(missing.err, "oslam camera: error: /nonexistent/camera.yaml: file not found\n");
  testing::TempDir dir;
  std::ofstream(dir.Path("camera.yaml")) << "model: hyperbolic\nimage_width: [\n";
  const Result corrupt = RunOslam("camera --from " + dir.Path("camera.yaml"));
  EXPECT_EQ(corrupt.exit_code, 1);
  EXPECT_EQ(Lines(corrupt.err), 1);
  EXPECT_NE(corrupt.err.find(dir.Path("camera.yaml") + ": YAML syntax error"), std::string::npos);
}

TEST(Cli, CameraPresetIsWrittenAndReadBack) {
  testing::TempDir dir;
  const std::string path = dir.Path("sub/camera.yaml");
  const Result write = RunOslam("camera --preset cogniron --quiet -o " + path);
  ASSERT_EQ(write.exit_code, 0) << write.err;
  EXPECT_EQ(write.out, "");
  const Result read = RunOslam("camera --from " + path + " --project 3,0,0");
  ASSERT_EQ(read.exit_code, 0) << read.err;
  EXPECT_NE(read.out.find("polar (184.488 px, 0.00000 rad)"), std::string::npos) << read.out;
}

// Outline examples whose camera.yaml is not beside classes.yaml: --camera
// names it; the classes come back with readable numbers and a learnt shape.
TEST(Cli, TrainColorsTakesTheCameraOfOutlineExamples) {
  testing::TempDir dir;
  ASSERT_EQ(RunOslam("camera --preset lpa --quiet -o " + dir.Path("rig/camera.yaml")).exit_code, 0);
  ObjectClass ball;
  ball.name = "orange ball";
  ball.diameter_mean_m = 0.2;
  ball.diameter_std_m = 0.05;
  ball.height_mean_m = 0.2;
  ball.height_std_m = 0.05;
  WriteClasses({ball}, dir.Path("classes.yaml"));
  std::string examples = "examples:\n";
  for (int i = 0; i < 3; ++i) {  // three whole silhouettes: enough for a shape model
    cv::Mat image(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
    cv::Mat mask(480, 640, CV_8UC1, cv::Scalar(0));
    const cv::Point centre(200 + 60 * i, 150 + 20 * i);
    cv::circle(image, centre, 12 + 2 * i, cv::Scalar(30, 130, 250), cv::FILLED);
    cv::circle(mask, centre, 12 + 2 * i, cv::Scalar(255), cv::FILLED);
    const std::string name = "view" + std::to_string(i);
    ASSERT_TRUE(cv::imwrite(dir.Path(name + ".png"), image));
    ASSERT_TRUE(cv::imwrite(dir.Path(name + "_mask.png"), mask));
    examples += "  - {image: " + name + ".png, class: orange ball, mask: " + name +
                "_mask.png, outline: 1}\n";
  }
  WriteTextFileAtomically(dir.Path("examples.yaml"), examples);
  const std::string train =
      "train-colors " + dir.Path("classes.yaml") + " --examples " + dir.Path("examples.yaml");
  const Result without = RunOslam(train);
  EXPECT_EQ(without.exit_code, 1);
  EXPECT_NE(without.err.find("give --camera"), std::string::npos) << without.err;
  const Result with = RunOslam(train + " --camera " + dir.Path("rig/camera.yaml") + " --quiet");
  ASSERT_EQ(with.exit_code, 0) << with.err;
  const std::vector<ObjectClass> trained = ReadClasses(dir.Path("classes.yaml"));
  ASSERT_TRUE(trained[0].colour.has_value());
  EXPECT_TRUE(trained[0].image_shape.has_value());
  // The outlines' blobs teach the blob colour too; one flat paint: the spread
  // is the floor, a share of the colour box's (at least 1 unit).
  ASSERT_TRUE(trained[0].colour->blob_chroma.has_value());
  const double pixel_std_v = std::max(1.0, trained[0].colour->yuv_std[2]);
  EXPECT_DOUBLE_EQ(trained[0].colour->blob_chroma->std[1], 0.25 * pixel_std_v);
  ASSERT_EQ(RunOslam(train + " --camera " + dir.Path("rig/camera.yaml") +
                     " --blob-colour-floor 0.5 --quiet")
                .exit_code,
            0);
  EXPECT_DOUBLE_EQ(ReadClasses(dir.Path("classes.yaml"))[0].colour->blob_chroma->std[1],
                   0.5 * pixel_std_v);
  const Result no_floor = RunOslam(train + " --blob-colour-floor 0");
  EXPECT_EQ(no_floor.exit_code, 2);
  EXPECT_NE(no_floor.err.find("--blob-colour-floor must be positive"), std::string::npos)
      << no_floor.err;
  const std::string text = ReadTextFile(dir.Path("classes.yaml"));
  EXPECT_NE(text.find("diameter_mean_m: 0.2\n"), std::string::npos) << text;
  EXPECT_EQ(text.find("e-01"), std::string::npos) << text;
  // --camera belongs to the examples mode; the help points at the examples' format.
  EXPECT_EQ(RunOslam("train-colors " + dir.Path("classes.yaml") + " --from-ground-truth " +
                     dir.Path("") + " --camera x.yaml")
                .exit_code,
            2);
  EXPECT_NE(RunOslam("train-colors --help").out.find("docs/detection.md"), std::string::npos);
}

}  // namespace
}  // namespace oslam

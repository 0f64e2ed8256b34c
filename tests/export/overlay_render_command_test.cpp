// oslam overlay and oslam render end to end, run as the user runs them (the
// oslam binary): the files promised are written and read back, usage errors
// exit 2, unreadable input exits 1 with a one-line error naming the file.
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "core/run_folder.h"
#include "test_util.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

const std::string kOMap = OSLAM_SOURCE_DIR "/tests/data/export_omap.json";

using CliResult = testing::CommandResult;

CliResult Oslam(const std::string& arguments) {
  return testing::RunShellCommand(std::string(OSLAM_BINARY) + " " + arguments);
}

std::vector<std::string> FilesIn(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

// A run folder for the fixture map's 4 estimated poses: uniform grey LPA
// frames, the camera, class colours and a ground-truth trajectory.
void WriteRun(const std::string& run) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  fs::create_directories(run + "/frames");
  for (int i = 0; i < 4; ++i) {
    const cv::Mat frame(camera.image_height(), camera.image_width(), CV_8UC3, cv::Scalar::all(90));
    ASSERT_TRUE(cv::imwrite(run + "/frames/00000" + std::to_string(i) + ".png", frame));
  }
  SaveCamera(camera, run + "/camera.yaml");
  ObjectClass box;
  box.name = "green box";
  box.display_rgb = {40, 150, 60};
  box.diameter_mean_m = 0.65;
  box.diameter_std_m = 0.05;
  box.height_mean_m = 0.57;
  box.height_std_m = 0.05;
  WriteClasses({box}, run + "/classes.yaml");
  GroundTruth truth;
  truth.trajectory = {{-1.0, -1.0, 0.0}, {-0.5, -1.0, 0.0}, {0.0, -1.0, 0.3}, {0.4, -0.8, 0.8}};
  WriteGroundTruth(truth, run);
}

TEST(OverlayCommand, DrawsTheChosenFramesWithTheMapOnThem) {
  testing::TempDir dir;
  WriteRun(dir.Path("run"));
  const std::string out = dir.Path("overlays");
  const CliResult result =
      Oslam("overlay " + dir.Path("run") + " " + kOMap + " -o " + out + " --frames 1,3 --quiet");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, "");
  ASSERT_EQ(FilesIn(out), (std::vector<std::string>{"000001.jpg", "000003.jpg"}));
  const cv::Mat frame = cv::imread(dir.Path("run/frames/000001.png"));
  for (const std::string name : {"000001.jpg", "000003.jpg"}) {
    const cv::Mat overlay = cv::imread(out + "/" + name);
    ASSERT_EQ(overlay.size(), frame.size()) << name;
    // The green box (pi 0.95) is in view: many pixels differ from the grey
    // frame (by more than JPEG's rounding) and some are green-dominant.
    cv::Mat difference, changed;
    cv::absdiff(overlay, frame, difference);
    changed = difference > 30;
    EXPECT_GT(cv::countNonZero(changed.reshape(1)), 500) << name;
    std::vector<cv::Mat> bgr;
    cv::split(overlay, bgr);
    const cv::Mat greenish = (bgr[1] > bgr[0] + 20) & (bgr[1] > bgr[2] + 20);
    EXPECT_GT(cv::countNonZero(greenish), 20) << name;
  }
}

TEST(OverlayCommand, AllFramesByDefaultAndAProgressLine) {
  testing::TempDir dir;
  WriteRun(dir.Path("run"));
  const CliResult result =
      Oslam("overlay " + dir.Path("run") + " " + kOMap + " -o " + dir.Path("out"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(FilesIn(dir.Path("out")),
            (std::vector<std::string>{"000000.jpg", "000001.jpg", "000002.jpg", "000003.jpg"}));
  EXPECT_NE(result.out.find("wrote 4 overlays"), std::string::npos) << result.out;
}

// Overlays are drawn on several threads; the files must not depend on it.
TEST(OverlayCommand, SameFilesWithOneOrSeveralThreads) {
  testing::TempDir dir;
  WriteRun(dir.Path("run"));
  for (const char* threads : {"1", "3"}) {
    const CliResult result =
        Oslam("overlay " + dir.Path("run") + " " + kOMap + " -o " +
              dir.Path(std::string("out") + threads) + " --threads " + threads + " --quiet");
    ASSERT_EQ(result.exit_code, 0) << result.err;
  }
  const std::vector<std::string> names = FilesIn(dir.Path("out1"));
  ASSERT_EQ(names.size(), 4u);
  ASSERT_EQ(FilesIn(dir.Path("out3")), names);
  for (const std::string& name : names) {
    const cv::Mat one = cv::imread(dir.Path("out1/" + name));
    const cv::Mat three = cv::imread(dir.Path("out3/" + name));
    ASSERT_EQ(one.size(), three.size()) << name;
    cv::Mat differ;
    cv::compare(one, three, differ, cv::CMP_NE);
    EXPECT_EQ(cv::countNonZero(differ.reshape(1)), 0) << name;
  }
  EXPECT_EQ(
      Oslam("overlay " + dir.Path("run") + " " + kOMap + " -o " + dir.Path("bad") + " --threads -1")
          .exit_code,
      2);
}

// oslam run keeps detections in its output folder and hands them to the
// export stage with --detections: they are drawn (white outlines).
TEST(ExportCommand, OverlaysDrawTheDetectionsGiven) {
  testing::TempDir dir;
  WriteRun(dir.Path("run"));
  std::ofstream(dir.Path("detections.csv"))
      << "frame,class,u_r_px,u_phi_rad,s_r_px,s_phi_rad\n1,green box,100,2.5,40,0.4\n";
  const std::string plain = dir.Path("plain"), with = dir.Path("with");
  ASSERT_EQ(Oslam("export " + kOMap + " --run " + dir.Path("run") + " -o " + plain +
                  " --overlays --quiet")
                .exit_code,
            0);
  const CliResult result =
      Oslam("export " + kOMap + " --run " + dir.Path("run") + " -o " + with +
            " --overlays --detections " + dir.Path("detections.csv") + " --quiet");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  auto white = [](const std::string& path) {
    std::vector<cv::Mat> bgr;
    cv::split(cv::imread(path), bgr);
    return cv::countNonZero((bgr[0] > 240) & (bgr[1] > 240) & (bgr[2] > 240));
  };
  EXPECT_GT(white(with + "/overlays/000001.jpg"), white(plain + "/overlays/000001.jpg") + 50);
  EXPECT_EQ(white(with + "/overlays/000002.jpg"), white(plain + "/overlays/000002.jpg"));
  const CliResult missing =
      Oslam("export " + kOMap + " --run " + dir.Path("run") + " -o " + dir.Path("x") +
            " --overlays --detections " + dir.Path("nothere.csv"));
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("nothere.csv"), std::string::npos) << missing.err;
}

TEST(RenderCommand, WritesTheFiguresThatReadBack) {
  testing::TempDir dir;
  const CliResult result =
      Oslam("render " + kOMap + " -o " + dir.Path("out") + " --figure-size 160 --quiet");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, "");
  // No run folder, so no ground truth and no comparison plot.
  ASSERT_EQ(FilesIn(dir.Path("out")),
            (std::vector<std::string>{"birdseye.csv", "birdseye.png", "birdseye.svg",
                                      "perspective.png"}));
  for (const char* name : {"birdseye.png", "perspective.png"}) {
    const cv::Mat image = cv::imread(dir.Path("out/") + name);
    EXPECT_EQ(image.size(), cv::Size(160, 160)) << name;
  }
}

TEST(RenderCommand, RunWithGroundTruthAddsTheTrajectoryPlot) {
  testing::TempDir dir;
  WriteRun(dir.Path("run"));
  const CliResult result = Oslam("render " + kOMap + " -o " + dir.Path("out") + " --run " +
                                 dir.Path("run") + " --figure-size 300 --quiet");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  ASSERT_EQ(
      FilesIn(dir.Path("out")),
      (std::vector<std::string>{"birdseye.csv", "birdseye.png", "birdseye.svg", "perspective.png",
                                "trajectories.csv", "trajectories.png", "trajectories.svg"}));
  const cv::Mat plot = cv::imread(dir.Path("out/trajectories.png"));
  EXPECT_EQ(plot.cols, 300);
  EXPECT_GT(plot.rows, 0);
}

// Exit 2 with one line on stderr naming the command.
void ExpectUsageError(const std::string& arguments, const std::string& mentions) {
  const CliResult result = Oslam(arguments);
  EXPECT_EQ(result.exit_code, 2) << arguments << "\n" << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_NE(result.err.find("usage error"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find(mentions), std::string::npos) << arguments << "\n" << result.err;
}

TEST(OverlayRenderCommands, UsageErrorsExit2AndWriteNothing) {
  testing::TempDir dir;
  WriteRun(dir.Path("run"));
  const std::string run = dir.Path("run"), out = dir.Path("out");
  ExpectUsageError("overlay " + run + " " + kOMap, "-o");
  ExpectUsageError("overlay " + kOMap + " -o " + out, "OMAP");  // RUN_DIR missing
  ExpectUsageError("overlay " + run + " " + kOMap + " -o " + out + " --frames 2-9", "--frames");
  ExpectUsageError("overlay " + run + " " + kOMap + " -o " + out + " --frames x", "--frames");
  ExpectUsageError("overlay " + run + " " + kOMap + " -o " + out + " --min-existence 2",
                   "min-existence");
  ExpectUsageError("render " + kOMap, "-o");
  ExpectUsageError("render " + kOMap + " -o " + out + " --figure-size 10", "64 to 8192 pixels");
  ExpectUsageError("render " + kOMap + " -o " + out + " --overlays", "--overlays");
  EXPECT_FALSE(fs::exists(out));
}

// Exit 1 with one line naming the file that is missing.
void ExpectMissingInput(const std::string& arguments, const std::string& path) {
  const CliResult result = Oslam(arguments);
  EXPECT_EQ(result.exit_code, 1) << arguments << "\n" << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_NE(result.err.find(path), std::string::npos) << arguments << "\n" << result.err;
}

TEST(OverlayRenderCommands, MissingInputExits1NamingTheFile) {
  testing::TempDir dir;
  WriteRun(dir.Path("run"));
  const std::string run = dir.Path("run"), out = dir.Path("out");
  const std::string no_map = dir.Path("no_map.json"), no_run = dir.Path("no_run");
  ExpectMissingInput("overlay " + run + " " + no_map + " -o " + out, no_map);
  ExpectMissingInput("overlay " + no_run + " " + kOMap + " -o " + out, no_run);
  fs::remove(run + "/camera.yaml");
  ExpectMissingInput("overlay " + run + " " + kOMap + " -o " + out, run + "/camera.yaml");
  ExpectMissingInput("render " + no_map + " -o " + out, no_map);
  ExpectMissingInput("render " + kOMap + " -o " + out + " --run " + no_run, no_run);
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace oslam

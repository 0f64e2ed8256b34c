// docs/your-robot.md's rehearsal block, run as written (each `oslam` line in
// a fresh folder, `samples/` from the source tree), and its map compared with
// the same scene from an ideal run folder (PNG frames, one odometry row per
// frame).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "test_util.h"

namespace oslam {
namespace {

std::string ReadWhole(const std::string& path) {
  std::stringstream text;
  text << std::ifstream(path).rdbuf();
  return text.str();
}

// The `oslam ...` lines between <!-- rehearsal --> and <!-- /rehearsal -->.
std::vector<std::string> RehearsalCommands(const std::string& guide) {
  const size_t begin = guide.find("<!-- rehearsal -->"), end = guide.find("<!-- /rehearsal -->");
  EXPECT_NE(begin, std::string::npos);
  EXPECT_NE(end, std::string::npos);
  std::vector<std::string> commands;
  std::istringstream lines(guide.substr(begin, end - begin));
  std::string line;
  while (std::getline(lines, line))
    if (line.rfind("oslam ", 0) == 0) commands.push_back(line.substr(6));
  return commands;
}

testing::CommandResult RunIn(const std::string& dir, std::string arguments) {
  for (size_t at = arguments.find(" samples/"); at != std::string::npos;
       at = arguments.find(" samples/", at + 1))
    arguments.replace(at + 1, 8, std::string(OSLAM_SOURCE_DIR) + "/samples/");
  return testing::RunShellCommand("cd " + dir + " && " + OSLAM_BINARY + " " + arguments);
}

nlohmann::json Eval(const std::string& path) {
  return nlohmann::json::parse(ReadWhole(path));
}

TEST(YourRobotGuide, RehearsalRunsAsWritten) {
  const std::vector<std::string> commands =
      RehearsalCommands(ReadWhole(std::string(OSLAM_SOURCE_DIR) + "/docs/your-robot.md"));
  ASSERT_EQ(commands.size(), 4u);
  testing::TempDir dir;
  for (const std::string& command : commands) {
    const testing::CommandResult result = RunIn(dir.Path(), command);
    ASSERT_EQ(result.exit_code, 0) << command << "\n" << result.err;
  }
  // The mask found against the rig the simulator drew: most of the rig
  // masked, little of the world.
  const cv::Mat found = cv::imread(dir.Path("robot_run/mask.png"), cv::IMREAD_GRAYSCALE);
  const cv::Mat rig = cv::imread(dir.Path("robot_run/ground_truth/mask.png"), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(found.empty());
  ASSERT_EQ(found.size(), rig.size());
  const double rig_px = cv::countNonZero(rig == 0);
  const double world_px = cv::countNonZero(rig != 0);
  const double rig_masked = cv::countNonZero((rig == 0) & (found == 0)) / rig_px;
  const double world_masked = cv::countNonZero((rig != 0) & (found == 0)) / world_px;
  std::printf(
      "mask: %.1f %% of the rig and %.1f %% of the rest of the image (outside the mirror too) "
      "masked\n",
      100 * rig_masked, 100 * world_masked);
  EXPECT_GT(rig_masked, 0.75);
  const std::string report = ReadWhole(dir.Path("robot_out/report.md"));
  EXPECT_NE(report.find("| odometry by time | kept"), std::string::npos) << report;
  for (const char* file : {"map.glb", "map.ply", "trajectory.ply", "eval.json", "run/frames.csv"})
    EXPECT_TRUE(std::filesystem::is_regular_file(dir.Path("robot_out/") + file)) << file;

  // The same scene and frames from an ideal run folder.
  ASSERT_EQ(
      RunIn(dir.Path(), "simulate samples/scenes/lab.yaml -o ideal --frames 60 --quiet").exit_code,
      0);
  ASSERT_EQ(RunIn(dir.Path(), "train-colors ideal/classes.yaml --from-ground-truth ideal --quiet")
                .exit_code,
            0);
  ASSERT_EQ(RunIn(dir.Path(), "run ideal -o ideal_out --quiet").exit_code, 0);
  const nlohmann::json video = Eval(dir.Path("robot_out/eval.json"));
  const nlohmann::json ideal = Eval(dir.Path("ideal_out/eval.json"));
  for (const char* key :
       {"true_objects_found", "spurious_objects", "ate_rmse_m", "object_position_error_median_m"})
    std::printf("%-32s rehearsal %8.3f  ideal %8.3f\n", key, video[key].get<double>(),
                ideal[key].get<double>());
  // The rig in the image, blur, exposure, vignetting, compression and its
  // own odometry clock cost little:
  // found and spurious objects within one of the ideal run's, ATE and
  // position median within 1.2x.
  EXPECT_GE(video["true_objects_found"].get<int>(), ideal["true_objects_found"].get<int>() - 1);
  EXPECT_LE(video["spurious_objects"].get<int>(), ideal["spurious_objects"].get<int>() + 1);
  EXPECT_LE(video["ate_rmse_m"].get<double>(), 1.2 * ideal["ate_rmse_m"].get<double>());
  EXPECT_LE(video["object_position_error_median_m"].get<double>(),
            1.2 * ideal["object_position_error_median_m"].get<double>());
}

}  // namespace
}  // namespace oslam

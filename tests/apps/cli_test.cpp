// The oslam command as a user meets it: exit codes 0 / 1 (runtime error) /
// 2 (usage error), one-line errors on stderr, --help and --version.
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "test_util.h"

namespace oslam {
namespace {

using Result = testing::CommandResult;

Result RunOslam(const std::string& arguments) {
  return testing::RunShellCommand(std::string(OSLAM_BINARY) + " " + arguments);
}

int Lines(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

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

}  // namespace
}  // namespace oslam

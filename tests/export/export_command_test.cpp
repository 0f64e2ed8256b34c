// oslam export end to end on a small O-Map fixture (tests/data/export_omap.json):
// every promised file is written and re-reads, and bad usage is refused.
#include <filesystem>

#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <opencv2/imgcodecs.hpp>

#include "apps/commands.h"
#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

const std::string kFixture = std::string(OSLAM_SOURCE_DIR) + "/tests/data/export_omap.json";

TEST(ExportCommand, WritesModelsAndFiguresThatReadBack) {
  testing::TempDir dir;
  const std::string out = dir.Path("out");
  ASSERT_EQ(RunExportCommand({kFixture, "-o", out, "--figure-size", "200", "--quiet"}), 0);
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string error, warning;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &error, &warning, out + "/map.glb")) << error;
  // Pink ball (pi = 0.05) is below the default --min-existence 0.1; no run
  // folder, so only the estimated trajectory; plus the floor and its grid.
  std::vector<std::string> names;
  for (const auto& node : model.nodes) names.push_back(node.name);
  EXPECT_EQ(names, (std::vector<std::string>{"green box 0", "yellow box 1", "trajectory estimated",
                                             "floor", "floor grid"}));
  ASSERT_TRUE(loader.LoadASCIIFromFile(&model, &error, &warning, out + "/map.gltf")) << error;
  for (const char* name : {"map.ply", "trajectory.ply", "trajectory_estimated.txt"})
    EXPECT_GT(std::filesystem::file_size(out + "/" + name), 100u) << name;
  // No run folder: no odometry or ground truth to write.
  EXPECT_FALSE(std::filesystem::exists(out + "/trajectory_truth.txt"));
  for (const char* name : {"birdseye.png", "perspective.png"}) {
    const cv::Mat image = cv::imread(out + "/" + name);
    EXPECT_EQ(image.cols, 200) << name;
    EXPECT_EQ(image.rows, 200) << name;
  }
  // No ground truth without a run folder: no comparison plot.
  EXPECT_FALSE(std::filesystem::exists(out + "/trajectories.png"));
}

TEST(ExportCommand, MinExistenceZeroKeepsEveryObject) {
  testing::TempDir dir;
  ASSERT_EQ(RunExportCommand({kFixture, "-o", dir.Path(), "--min-existence", "0", "--no-grid",
                              "--figure-size", "100", "--quiet"}),
            0);
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string error, warning;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &error, &warning, dir.Path("map.glb")));
  EXPECT_EQ(model.nodes.size(), 5u);  // three objects, the trajectory and the floor
}

TEST(ExportCommand, UsageErrors) {
  testing::TempDir dir;
  EXPECT_THROW(RunExportCommand({kFixture}), UsageError);  // no -o
  EXPECT_THROW(RunExportCommand({kFixture, "-o", dir.Path(), "--overlays"}), UsageError);
  EXPECT_THROW(RunExportCommand({kFixture, "-o", dir.Path(), "--min-existence", "1.5"}),
               UsageError);
  EXPECT_THROW(RunExportCommand({kFixture, "-o", dir.Path(), "--frames", "1-3"}), UsageError);
}

TEST(ExportCommand, BadInputNamesTheFile) {
  testing::TempDir dir;
  try {
    RunExportCommand({dir.Path("missing.json"), "-o", dir.Path("out"), "--quiet"});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.json"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace oslam

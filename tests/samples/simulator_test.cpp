#include "samples/simulator.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "core/atomic_file.h"
#include "core/csv.h"
#include "core/run_folder.h"
#include "test_util.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

// Relative path -> contents of every file under `dir`.
std::map<std::string, std::string> FilesUnder(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    if (entry.is_regular_file())
      files[fs::relative(entry.path(), dir).string()] = ReadTextFile(entry.path().string());
  return files;
}

Scene Lab() {
  return LoadScene(std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/lab.yaml");
}

TEST(Simulator, SameSeedSameBytesOtherSeedOtherOdometry) {
  const Scene scene = Lab();
  testing::TempDir dir;
  SimulationOptions options;
  options.seed = 5;
  options.max_frames = 3;
  Simulate(scene, dir.Path("a"), options);
  Simulate(scene, dir.Path("b"), options);
  options.seed = 6;
  Simulate(scene, dir.Path("c"), options);

  const auto a = FilesUnder(dir.Path("a")), b = FilesUnder(dir.Path("b")),
             c = FilesUnder(dir.Path("c"));
  ASSERT_EQ(a.size(), 10u);  // 3 frames, odometry, camera, classes, 4 ground-truth files
  EXPECT_TRUE(a == b);
  EXPECT_NE(a.at("odometry.csv"), c.at("odometry.csv"));
  EXPECT_NE(a.at("frames/000002.png"), c.at("frames/000002.png"));
}

TEST(Simulator, WritesARunFolderTheReadersAccept) {
  const Scene scene = Lab();
  testing::TempDir dir;
  SimulationOptions options;
  options.max_frames = 4;
  const SimulationSummary summary = Simulate(scene, dir.Path("run"), options);
  EXPECT_EQ(summary.frames, 4);
  const FrameSource frames(dir.Path("run"));
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_EQ(frames.Read(3).cols, 640);
  const Odometry odometry = ReadOdometry(RunFolderPaths::Of(dir.Path("run")).odometry, 4);
  EXPECT_EQ(ReadClasses(RunFolderPaths::Of(dir.Path("run")).classes).size(), scene.classes.size());
  const std::optional<GroundTruth> truth = ReadGroundTruth(dir.Path("run"));
  ASSERT_TRUE(truth.has_value());
  EXPECT_EQ(truth->trajectory.size(), 4u);
  EXPECT_EQ(truth->objects.size(), scene.objects.size());
  EXPECT_GT(truth->sightings.size(), 4u);
  // The run starts where the scene says; odometry starts at the true pose.
  EXPECT_DOUBLE_EQ(odometry.poses[0].x, truth->trajectory[0].x);
  // Pixel-measured slices: one row per sighting, in the same order.
  const CsvTable visible = CsvTable::Read(dir.Path("run") + "/ground_truth/visible_slices.csv");
  ASSERT_EQ(visible.num_rows(), truth->sightings.size());
  for (size_t row = 0; row < visible.num_rows(); ++row) {
    EXPECT_EQ(visible.Integer(row, visible.ColumnIndex("object_id")),
              truth->sightings[row].object_id);
    const double visible_px = visible.Double(row, visible.ColumnIndex("visible_px"));
    const double footprint_px = visible.Double(row, visible.ColumnIndex("footprint_px"));
    EXPECT_NEAR(visible_px / footprint_px, truth->sightings[row].visible_fraction, 1e-12);
    EXPECT_GE(visible.Double(row, visible.ColumnIndex("u_r_px")),
              scene.camera->annulus().blind_radius_px);
  }
  // No temporary files left behind.
  for (const auto& entry : fs::recursive_directory_iterator(dir.Path("run")))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
}

}  // namespace
}  // namespace oslam

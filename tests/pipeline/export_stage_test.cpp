// The export stage: the models, figures and the overlays of the frames
// asked for; overlays need the run folder, checked before anything is
// written.
#include "pipeline/export_stage.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "simulated_run.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

TEST(ExportStage, WritesTheModelsFiguresAndChosenOverlays) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  const OMap map = testing::MapOfSimulatedRun(dir);

  ExportStageOptions options;
  options.overlays = true;
  options.overlay_frames = "0,3";
  EXPECT_THROW(RunExportStage(map, {}, dir.Path("no_run"), options, {}), Error);
  EXPECT_FALSE(fs::exists(dir.Path("no_run")));
  RunExportStage(map, {run, dir.Path("d.csv")}, dir.Path("export"), options, {});
  for (const char* file :
       {"map.glb", "map.ply", "trajectory_estimated.txt", "birdseye.png", "birdseye.svg",
        "trajectories.png", "trajectories.csv", "overlays/000000.jpg", "overlays/000003.jpg"})
    EXPECT_TRUE(fs::is_regular_file(dir.Path("export/") + file)) << file;
  EXPECT_FALSE(fs::exists(dir.Path("export/overlays/000001.jpg")));

  options.overlay_format = "png";
  options.overlay_frames = "3";
  RunExportStage(map, {run, dir.Path("d.csv")}, dir.Path("lossless"), options, {});
  EXPECT_TRUE(fs::is_regular_file(dir.Path("lossless/overlays/000003.png")));
  EXPECT_FALSE(fs::exists(dir.Path("lossless/overlays/000003.jpg")));
  options.overlay_format = "gif";
  std::string format_why;
  EXPECT_FALSE(options.Validate(&format_why));
  EXPECT_NE(format_why.find("gif"), std::string::npos) << format_why;
  options.overlay_format = "jpg";
  options.figure_size_px = 1;
  std::string why;
  EXPECT_FALSE(options.Validate(&why));
}

}  // namespace
}  // namespace oslam

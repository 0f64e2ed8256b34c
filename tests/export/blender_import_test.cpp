// Opens the exported .glb in Blender (headless, Debian's blender 3.4) and
// checks there what users will see (tests/export/blender_import_check.py):
// objects in their class shapes at their base points with alpha = pi and
// back faces culled, trajectories as tubes with faces in their own materials,
// a floor; then a Workbench render (the solid viewport's engine) compared
// with tests/golden/blender_workbench.png. The comparison is shown to fail
// when an object or a trajectory is missing.
// Labelled "slow" (Blender takes seconds to start and render); skipped, saying
// so, when blender is not installed.
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "export/display_scene.h"
#include "export/export_fixture.h"
#include "export/gltf_writer.h"
#include "export/golden.h"
#include "test_util.h"

namespace oslam {
namespace {

bool BlenderMissing() {
  return std::system("command -v blender > /dev/null 2>&1") != 0;
}

constexpr const char* kNoBlender =
    "blender is not installed (apt-get install blender python3-numpy; left out of "
    "scripts/common.sh's packages as a test-only tool of several hundred MB)";

std::string ReadLog(const std::string& path) {
  std::string log;
  if (FILE* f = std::fopen(path.c_str(), "r")) {
    char buffer[4096];
    size_t n;
    while ((n = std::fread(buffer, 1, sizeof(buffer), f)) > 0) log.append(buffer, n);
    std::fclose(f);
  }
  return log;
}

// Writes `scene` as a .glb, runs the check script on it and renders it;
// returns the render (empty when Blender failed, with the log in `log`).
cv::Mat ImportAndRender(const ExportScene& scene, const testing::TempDir& dir,
                        const std::string& stem, std::string* log) {
  ExportOptions options;
  options.min_existence = 0.1;
  const std::string glb = dir.Path(stem + ".glb"), png = dir.Path(stem + ".png");
  WriteGltf(scene, options, glb);
  std::ostringstream command;
  command << "blender -b --factory-startup --python-exit-code 1 --python " << OSLAM_SOURCE_DIR
          << "/tests/export/blender_import_check.py -- " << glb << " --render " << png;
  for (const OMapObject* object : ShownObjects(scene.map, options.min_existence)) {
    const Eigen::Vector3d& b = object->base_world;
    command << " '" << ObjectLabel(*object) << "|" << b.x() << "," << b.y() << "," << b.z() << "|"
            << object->diameter_m << "," << object->height_m << "|" << object->existence_probability
            << "|" << ObjectShapeName(ClassShape(scene.classes, object->class_name)) << "'";
  }
  command << " > " << dir.Path(stem + ".log") << " 2>&1";
  const int status = std::system(command.str().c_str());
  *log = ReadLog(dir.Path(stem + ".log"));
  EXPECT_EQ(status, 0) << *log;
  EXPECT_NE(log->find("blender import check: OK"), std::string::npos) << *log;
  return cv::imread(png, cv::IMREAD_COLOR);
}

TEST(BlenderImport, SceneImportsAsShapesTubesAndFloorAndRendersAsTheGolden) {
  if (BlenderMissing()) GTEST_SKIP() << kNoBlender;
  testing::TempDir dir;
  std::string log;
  const cv::Mat render = ImportAndRender(testing::FixtureScene(), dir, "map", &log);
  ASSERT_FALSE(render.empty()) << log;
  testing::ExpectMatchesGolden(render, "blender_workbench.png");
}

TEST(BlenderImport, RenderComparisonFailsWithoutAnObjectOrATrajectory) {
  if (BlenderMissing()) GTEST_SKIP() << kNoBlender;
  if (testing::Regenerating()) GTEST_SKIP() << "regenerating the goldens";
  const cv::Mat golden = cv::imread(testing::GoldenPath("blender_workbench.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(golden.empty());
  testing::TempDir dir;
  std::string log;
  ExportScene no_ball = testing::FixtureScene();
  no_ball.map.objects.erase(no_ball.map.objects.begin() + 1);  // the pink ball
  const cv::Mat without_object = ImportAndRender(no_ball, dir, "no_ball", &log);
  ASSERT_FALSE(without_object.empty()) << log;
  EXPECT_FALSE(testing::MatchesGolden(without_object, golden));
  EXPECT_GT(testing::DifferingBlobPixels(without_object, golden), 0);

  ExportScene no_odometry = testing::FixtureScene();
  no_odometry.odometry.clear();
  const cv::Mat without_trajectory = ImportAndRender(no_odometry, dir, "no_odometry", &log);
  ASSERT_FALSE(without_trajectory.empty()) << log;
  EXPECT_FALSE(testing::MatchesGolden(without_trajectory, golden));
  EXPECT_GT(testing::DifferingBlobPixels(without_trajectory, golden), 0);
}

}  // namespace
}  // namespace oslam

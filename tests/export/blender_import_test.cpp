// Opens the exported .glb in Blender (headless, Debian's blender 3.4) and
// checks there what users will see: object count, upright cylinders at their
// base points, material alpha = pi (tests/export/blender_import_check.py).
// Labelled "slow" (not in the default run: it needs Blender, which starts in a
// second or two); skipped when blender is not installed.
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <gtest/gtest.h>

#include "export/export_fixture.h"
#include "export/gltf_writer.h"
#include "test_util.h"

namespace oslam {
namespace {

TEST(BlenderImport, ObjectsAreUprightWithAlphaPi) {
  if (std::system("command -v blender > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "blender not installed (apt-get install blender python3-numpy)";
  testing::TempDir dir;
  const ExportScene scene = testing::FixtureScene();
  ExportOptions options;
  options.min_existence = 0.1;
  WriteGltf(scene, options, dir.Path("map.glb"));

  std::ostringstream command;
  command << "blender -b --factory-startup --python-exit-code 1 --python " << OSLAM_SOURCE_DIR
          << "/tests/export/blender_import_check.py -- " << dir.Path("map.glb");
  for (const OMapObject* object : ShownObjects(scene.map, options.min_existence)) {
    const Eigen::Vector3d& b = object->base_world;
    command << " '" << ObjectLabel(*object) << "|" << b.x() << "," << b.y() << "," << b.z() << "|"
            << object->diameter_m << "," << object->height_m << "|" << object->existence_probability
            << "'";
  }
  command << " > " << dir.Path("blender.log") << " 2>&1";
  const int status = std::system(command.str().c_str());
  std::string log;
  if (FILE* f = std::fopen(dir.Path("blender.log").c_str(), "r")) {
    char buffer[4096];
    size_t n;
    while ((n = std::fread(buffer, 1, sizeof(buffer), f)) > 0) log.append(buffer, n);
    std::fclose(f);
  }
  EXPECT_EQ(status, 0) << log;
  EXPECT_NE(log.find("blender import check: OK"), std::string::npos) << log;
}

}  // namespace
}  // namespace oslam

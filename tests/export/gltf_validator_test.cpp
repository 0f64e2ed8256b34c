// Every glTF the exporter writes passes the Khronos glTF validator (npm
// package gltf-validator, installed at configure time by
// install_gltf_validator.sh into the build tree) with zero errors and zero
// warnings. Skipped,
// saying why, when node or the validator is not available.
#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>

#include "export/export_fixture.h"
#include "export/gltf_writer.h"
#include "omap/omap_json.h"
#include "test_util.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

// Why the validator cannot run here, or "" when it can.
std::string ValidatorUnavailable() {
  if (std::system("command -v node >/dev/null 2>&1") != 0) return "node is not installed";
  if (!fs::exists(fs::path(GLTF_VALIDATOR_DIR) / "node_modules/gltf-validator/package.json"))
    return std::string("gltf-validator is not installed in ") + GLTF_VALIDATOR_DIR +
           " (needs npm and the npm registry at configure time; or run "
           "tests/export/install_gltf_validator.sh " GLTF_VALIDATOR_DIR ")";
  return "";
}

struct Report {
  int errors = -1, warnings = -1, infos = -1, hints = -1;
  std::string text;  // the validator's output: counts, then each error and warning
};

Report Validate(const std::string& path) {
  const std::string command = "node " OSLAM_SOURCE_DIR "/tests/export/validate_gltf.js " +
                              std::string(GLTF_VALIDATOR_DIR) + " '" + path + "' 2>&1";
  Report report;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return report;
  char buffer[4096];
  while (std::fgets(buffer, sizeof(buffer), pipe) != nullptr) report.text += buffer;
  pclose(pipe);
  std::sscanf(report.text.c_str(), "errors=%d warnings=%d infos=%d hints=%d", &report.errors,
              &report.warnings, &report.infos, &report.hints);
  return report;
}

void ExpectValid(const std::string& path) {
  const Report report = Validate(path);
  ASSERT_GE(report.errors, 0) << "validator did not report on " << path << ":\n" << report.text;
  EXPECT_EQ(report.errors, 0) << path << ":\n" << report.text;
  EXPECT_EQ(report.warnings, 0) << path << ":\n" << report.text;
  std::printf("gltf-validator %s: %d errors, %d warnings, %d infos, %d hints\n",
              fs::path(path).filename().c_str(), report.errors, report.warnings, report.infos,
              report.hints);
}

// Both encodings of a scene, every object shown, with and without the grid
// (and with the camera pyramids along with the grid).
void ExpectValidExports(const ExportScene& scene, const std::string& stem) {
  testing::TempDir dir;
  for (const bool grid : {true, false}) {
    ExportOptions options;
    options.min_existence = 0.0;
    options.floor_grid = grid;
    options.camera_every = grid ? 5 : 0;
    for (const char* extension : {".glb", ".gltf"}) {
      const std::string path = dir.Path(stem + (grid ? "_grid" : "") + extension);
      WriteGltf(scene, options, path);
      ExpectValid(path);
    }
  }
}

TEST(GltfValidator, FixtureOMapFilePasses) {
  if (const std::string why = ValidatorUnavailable(); !why.empty()) GTEST_SKIP() << why;
  ExportScene scene;
  scene.map = ReadOMap(OSLAM_SOURCE_DIR "/tests/data/export_omap.json");
  ExpectValidExports(scene, "export_omap");
}

TEST(GltfValidator, SceneWithAllTrajectoriesPasses) {
  if (const std::string why = ValidatorUnavailable(); !why.empty()) GTEST_SKIP() << why;
  ExpectValidExports(testing::FixtureScene(), "fixture_scene");
}

TEST(GltfValidator, EmptyMapPasses) {
  if (const std::string why = ValidatorUnavailable(); !why.empty()) GTEST_SKIP() << why;
  ExpectValidExports(ExportScene{}, "empty");
}

// The check itself: a damaged file must be reported, or a broken validator
// set-up would pass everything.
TEST(GltfValidator, ReportsErrorsInADamagedFile) {
  if (const std::string why = ValidatorUnavailable(); !why.empty()) GTEST_SKIP() << why;
  testing::TempDir dir;
  const std::string path = dir.Path("map.glb");
  WriteGltf(testing::FixtureScene(), ExportOptions{}, path);
  fs::resize_file(path, fs::file_size(path) / 2);
  EXPECT_GT(Validate(path).errors, 0);
}

}  // namespace
}  // namespace oslam

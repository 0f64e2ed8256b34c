// Randomised corruption of every input format (a stand-in for fuzzing: no
// clang/libFuzzer in the default toolchain): readers must either accept the
// bytes or throw oslam::Error with a one-line message, never crash or throw
// anything else. Seeded, so a failure is reproducible.
#include <cstring>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "omap/omap_json.h"
#include "test_util.h"

namespace oslam {
namespace {

std::string ReadAll(const std::string& path) {
  std::stringstream text;
  text << std::ifstream(path, std::ios::binary).rdbuf();
  return text.str();
}

// Flips, inserts, deletes and duplicates bytes, biased towards the characters
// that matter to the formats.
std::string Corrupt(const std::string& text, std::mt19937_64* rng) {
  std::string out = text;
  const char* interesting = ",:-[]{}\n\"#.e0123456789 \tnaNinf%";
  std::uniform_int_distribution<int> edits(1, 6);
  for (int n = edits(*rng); n > 0 && !out.empty(); --n) {
    std::uniform_int_distribution<size_t> at(0, out.size() - 1);
    const size_t i = at(*rng);
    const char c = interesting[(*rng)() % std::strlen(interesting)];
    switch ((*rng)() % 5) {
      case 0: out[i] = c; break;
      case 1: out.insert(out.begin() + i, c); break;
      case 2: out.erase(i, 1 + (*rng)() % 8); break;
      case 3: out.insert(i, out.substr(i, (*rng)() % 40)); break;
      default: out.resize(i); break;
    }
  }
  return out;
}

void FuzzReader(const std::string& valid, const std::string& file_name,
                const std::function<void(const std::string&)>& read, int rounds) {
  testing::TempDir dir;
  const std::string path = dir.Path(file_name);
  std::mt19937_64 rng(20261122);
  int accepted = 0, rejected = 0;
  for (int round = 0; round < rounds; ++round) {
    const std::string corrupted = Corrupt(valid, &rng);
    std::ofstream(path, std::ios::binary | std::ios::trunc) << corrupted;
    try {
      read(path);
      ++accepted;
    } catch (const Error& e) {
      const std::string message = e.what();
      ASSERT_FALSE(message.empty());
      ASSERT_EQ(message.find('\n'), std::string::npos) << message;
      ++rejected;
    } catch (const std::exception& e) {
      FAIL() << file_name << " round " << round << ": " << e.what() << " on input:\n" << corrupted;
    }
  }
  EXPECT_GT(rejected, 0) << file_name << ": no corruption was ever detected";
  ::testing::Test::RecordProperty(file_name + "_accepted", accepted);
}

TEST(Corruption, CameraYaml) {
  testing::TempDir dir;
  SaveCamera(HyperbolicCamera::Preset("lpa"), dir.Path("camera.yaml"));
  FuzzReader(ReadAll(dir.Path("camera.yaml")), "camera.yaml", [](const std::string& p) { LoadCamera(p); }, 400);
}

TEST(Corruption, ClassesYaml) {
  testing::TempDir dir;
  ObjectClass c;
  c.name = "green box";
  c.diameter_mean_m = c.height_mean_m = 0.6;
  c.diameter_std_m = c.height_std_m = 0.2;
  c.colour = ColourBox{{50, 110, 100}, {4, 2, 3}, 3, std::nullopt};
  ObjectClass d = c;
  d.name = "door";
  WriteClasses({c, d}, dir.Path("classes.yaml"), ConfusionMatrix{{0.9, 0.1}, {0.2, 0.8}});
  FuzzReader(ReadAll(dir.Path("classes.yaml")), "classes.yaml", [](const std::string& p) {
    ReadClasses(p);
    ReadConfusion(p);
  }, 400);
}

TEST(Corruption, OdometryCsv) {
  testing::TempDir dir;
  WriteOdometryPoses({{0, 0, 0}, {0.2, 0, 0.1}, {0.4, 0.02, 0.2}, {0.6, 0.05, 0.2}},
                     dir.Path("odometry.csv"));
  FuzzReader(ReadAll(dir.Path("odometry.csv")), "odometry.csv",
             [](const std::string& p) { ReadOdometry(p, 4); }, 400);
}

TEST(Corruption, OMapJson) {
  FuzzReader(ReadAll(std::string(OSLAM_SOURCE_DIR) + "/tests/data/export_omap.json"), "omap.json",
             [](const std::string& p) { ReadOMap(p); }, 400);
}

}  // namespace
}  // namespace oslam

// A small simulated run with trained colours (tests/data/sift_clutter.yaml:
// 16 frames, one class, one object and a look-alike), made once per test
// program with the oslam program, and fast O-SLAM settings for it.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "omap/omap_json.h"
#include "pipeline/detect_stage.h"
#include "pipeline/slam_stage.h"
#include "test_util.h"

namespace oslam::testing {

inline CommandResult Oslam(const std::string& arguments) {
  return RunShellCommand(std::string(OSLAM_BINARY) + " " + arguments);
}

// The run folder; "" (and a test failure) when it could not be made.
inline std::string SimulatedRun() {
  static TempDir* dir = new TempDir;  // lives as long as the test program
  static const std::string run = [] {
    const std::string path = dir->Path("run");
    const CommandResult simulate = Oslam("simulate " + std::string(OSLAM_SOURCE_DIR) +
                                         "/tests/data/sift_clutter.yaml -o " + path + " --quiet");
    if (simulate.exit_code != 0) return std::string();
    const CommandResult train =
        Oslam("train-colors " + path + "/classes.yaml --from-ground-truth " + path + " --quiet");
    return train.exit_code == 0 ? path : std::string();
  }();
  EXPECT_FALSE(run.empty()) << "could not simulate the test run";
  return run;
}

// Few iterations: the stages' plumbing is under test, not the sampler.
inline void MakeFast(SlamStageOptions* options) {
  options->sampler.num_iterations = 60;
  options->sampler.burn_in = 10;
  options->sampler.hill_climb_steps = 20;
}
inline constexpr char kFastFlags[] = " --samples 60 --burn-in 10 --hill-climb 20 ";

// A copy of `run` at `copy` (replaced), to break.
inline std::string CopyOfRun(const std::string& run, const std::string& copy) {
  std::filesystem::remove_all(copy);
  std::filesystem::copy(run, copy, std::filesystem::copy_options::recursive);
  return copy;
}

// The simulated run's O-Map from the detect and (fast) O-SLAM stages; the
// detections in `dir`/d.csv, the map in `dir`/omap.json.
inline OMap MapOfSimulatedRun(const TempDir& dir) {
  StageOutput quiet;
  quiet.quiet = true;
  RunDetectStage(SimulatedRun(), dir.Path("d.csv"), {}, quiet);
  SlamStageOptions slam;
  MakeFast(&slam);
  RunSlamStage({SimulatedRun(), dir.Path("d.csv"), nullptr}, dir.Path("omap.json"), slam, quiet);
  return ReadOMap(dir.Path("omap.json"));
}

inline std::string ReadFile(const std::string& path) {
  std::stringstream text;
  text << std::ifstream(path, std::ios::binary).rdbuf();
  return text.str();
}

}  // namespace oslam::testing

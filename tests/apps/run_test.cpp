// `oslam run` end to end on a small simulated run: outputs, determinism, and
// bad input (each a one-line error naming the file, exit code 1 or 2, and no
// output written before the inputs are checked).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "omap/omap_json.h"
#include "test_util.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

using Result = testing::CommandResult;

Result Oslam(const std::string& arguments) {
  return testing::RunShellCommand(std::string(OSLAM_BINARY) + " " + arguments);
}

std::string ReadFile(const std::string& path) {
  std::stringstream text;
  text << std::ifstream(path, std::ios::binary).rdbuf();
  return text.str();
}

// One simulated run with trained colours, shared by every test (made once).
class RunCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    const std::string run = dir_->Path("run");
    const Result simulate = Oslam("simulate " + std::string(OSLAM_SOURCE_DIR) +
                                  "/tests/data/sift_clutter.yaml -o " + run + " --quiet");
    ASSERT_EQ(simulate.exit_code, 0) << simulate.err;
    const Result train =
        Oslam("train-colors " + run + "/classes.yaml --from-ground-truth " + run + " --quiet");
    ASSERT_EQ(train.exit_code, 0) << train.err;
  }
  static void TearDownTestSuite() { delete dir_; }

  // A copy of the run to break.
  std::string CopyOfRun(const std::string& name) {
    const std::string copy = dir_->Path(name);
    fs::remove_all(copy);
    fs::copy(dir_->Path("run"), copy, fs::copy_options::recursive);
    return copy;
  }
  static std::string Run() { return dir_->Path("run"); }
  static std::string Fast() {
    return " --set slam.samples=60 --set slam.burn_in=10 --set slam.hill_climb=20 --set "
           "export.overlays=0 ";
  }

  static testing::TempDir* dir_;
};
testing::TempDir* RunCommand::dir_ = nullptr;

TEST_F(RunCommand, WritesTheMapFiguresReportAndEvaluationAndIsDeterministic) {
  const std::string out = dir_->Path("out1");
  const Result run = Oslam("run " + Run() + " -o " + out + Fast() + "--seed 3 --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, "");
  for (const char* file : {"detections.csv", "omap.json", "map.glb", "map.ply", "birdseye.png",
                           "report.md", "eval.json", "config.yaml"})
    EXPECT_TRUE(fs::is_regular_file(fs::path(out) / file)) << file;
  const OMap map = ReadOMap(out + "/omap.json");
  EXPECT_EQ(map.trajectory.size(), 16u);
  const std::string eval = ReadFile(out + "/eval.json");
  EXPECT_NE(eval.find("\"true_objects_total\": 1"), std::string::npos) << eval;
  EXPECT_NE(ReadFile(out + "/report.md").find("## Timings"), std::string::npos);
  // No temporary files left behind.
  for (const auto& entry : fs::directory_iterator(out))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();

  // Same seed, same map: objects, trajectory and the sampler's path are
  // identical (the file also records timings and its input paths, which differ).
  const std::string again = dir_->Path("out2");
  ASSERT_EQ(Oslam("run " + Run() + " -o " + again + Fast() + "--seed 3 --quiet").exit_code, 0);
  const auto first = nlohmann::json::parse(ReadFile(out + "/omap.json"));
  const auto second = nlohmann::json::parse(ReadFile(again + "/omap.json"));
  EXPECT_EQ(first["objects"].dump(), second["objects"].dump());
  EXPECT_EQ(first["trajectory"].dump(), second["trajectory"].dump());
  EXPECT_EQ(first["sampler"]["cold_chain_log_target"].dump(),
            second["sampler"]["cold_chain_log_target"].dump());
  EXPECT_EQ(ReadFile(out + "/detections.csv"), ReadFile(again + "/detections.csv"));
}

// Exit code 1, one line on stderr naming `file_part` and `problem`, and no
// output folder.
void ExpectInputError(const Result& result, const std::string& file_part,
                      const std::string& problem, const std::string& out) {
  EXPECT_EQ(result.exit_code, 1) << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_NE(result.err.find(file_part), std::string::npos) << result.err;
  EXPECT_NE(result.err.find(problem), std::string::npos) << result.err;
  EXPECT_FALSE(fs::exists(out)) << "output written despite bad input";
}

TEST_F(RunCommand, BadInputIsReportedBeforeAnythingIsWritten) {
  const std::string out = dir_->Path("never");
  {
    const std::string run = CopyOfRun("short_odometry");
    std::string text = ReadFile(run + "/odometry.csv");
    text.erase(text.rfind('\n', text.size() - 2) + 1);  // drop the last row
    std::ofstream(run + "/odometry.csv") << text;
    ExpectInputError(Oslam("run " + run + " -o " + out), "odometry.csv",
                     "has 15 rows but the run has 16 frames", out);
  }
  {
    const std::string run = CopyOfRun("nan_odometry");
    std::string text = ReadFile(run + "/odometry.csv");
    const size_t x = text.find("\n3,") + 3;
    text.replace(x, text.find(',', x) - x, "nan");
    std::ofstream(run + "/odometry.csv") << text;
    ExpectInputError(Oslam("run " + run + " -o " + out), "odometry.csv:5", "NaN", out);
  }
  {
    const std::string run = dir_->Path("empty");
    fs::create_directories(run);
    ExpectInputError(Oslam("run " + run + " -o " + out), run, "no frames/ folder", out);
  }
  {
    const std::string run = CopyOfRun("bad_camera");
    std::ofstream(run + "/camera.yaml") << "model: [broken\n";
    ExpectInputError(Oslam("run " + run + " -o " + out), "camera.yaml", "YAML syntax error", out);
  }
  {
    const std::string run = CopyOfRun("untrained");
    std::string text = ReadFile(run + "/classes.yaml");
    text.erase(text.find("    colour:"), text.find("confusion:") - text.find("    colour:"));
    text.erase(text.find("confusion:"));
    std::ofstream(run + "/classes.yaml") << text;
    ExpectInputError(Oslam("run " + run + " -o " + out), "classes.yaml",
                     "no class has a colour model", out);
  }
  {
    testing::TempDir config_dir;
    std::ofstream(config_dir.Path("oslam.yaml")) << "slam:\n  sampels: 10\n";
    ExpectInputError(
        Oslam("run " + Run() + " -o " + out + " --config " + config_dir.Path("oslam.yaml")),
        "oslam.yaml", "slam.sampels: unknown key", out);
  }
}

TEST_F(RunCommand, CorruptFrameIsNamedUnlessSkipped) {
  const std::string run = CopyOfRun("corrupt_frame");
  std::ofstream(run + "/frames/000004.png") << "not a png";
  const Result result = Oslam("run " + run + " -o " + dir_->Path("corrupt_out") + Fast());
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("000004.png: not an image"), std::string::npos) << result.err;
  const Result skipped = Oslam("run " + run + " -o " + dir_->Path("skipped_out") + Fast() +
                               "--set detect.skip_bad_frames=1 --quiet");
  EXPECT_EQ(skipped.exit_code, 0) << skipped.err;
  EXPECT_NE(skipped.err.find("skipping frame 4"), std::string::npos) << skipped.err;
}

// Frames are decoded and searched on several threads; the detections, in
// frame order, must not depend on it.
TEST_F(RunCommand, DetectionsDoNotDependOnTheThreads) {
  const std::string one = dir_->Path("threads1.csv"), three = dir_->Path("threads3.csv");
  ASSERT_EQ(Oslam("detect " + Run() + " -o " + one + " --threads 1 --quiet").exit_code, 0);
  ASSERT_EQ(Oslam("detect " + Run() + " -o " + three + " --threads 3 --quiet").exit_code, 0);
  const std::string csv = ReadFile(one);
  EXPECT_GT(std::count(csv.begin(), csv.end(), '\n'), 10);
  EXPECT_EQ(csv, ReadFile(three));
}

TEST_F(RunCommand, UsageErrorsExitWithTwo) {
  // In the suite's temporary folder: a run that wrongly goes ahead leaves
  // nothing in the working directory.
  const std::string out = dir_->Path("usage_out");
  const std::string run_to = "run " + Run() + " -o " + out;
  for (const std::string& arguments :
       {"run " + Run(), run_to + " --set nosuch.key=1", run_to + " --set slam.samples",
        run_to + " --set slam.method=magic", run_to + " --set slam.merge_sigma_m=-1",
        run_to + " --set slam.burn_in=2000", run_to + " --set slam.pixel_noise_px=thirty",
        std::string("config")}) {
    const Result result = Oslam(arguments);
    EXPECT_EQ(result.exit_code, 2) << arguments << ": " << result.err;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  }
  const Result defaults = Oslam("config --print-defaults");
  EXPECT_EQ(defaults.exit_code, 0);
  for (const char* line :
       {"samples: 1500", "pixel_noise_px: 30", "spurious_t0_m2: 0.16", "spurious_tau_m2: 0.04",
        "track_gate_radius_px: 30", "motion_mult_fwd: 0.1", "merge_distance_m: 0.5"})
    EXPECT_NE(defaults.out.find(line), std::string::npos) << line << " in " << defaults.out;
  EXPECT_FALSE(fs::exists(out)) << "output written despite a bad configuration";

  // The printed defaults are a valid configuration file; a bad value in a
  // file is a one-line error naming the file and the key (exit code 1).
  testing::TempDir dir;
  std::ofstream(dir.Path("defaults.yaml")) << defaults.out;
  const Result check = Oslam("config --check " + dir.Path("defaults.yaml"));
  EXPECT_EQ(check.exit_code, 0) << check.err;
  EXPECT_EQ(check.out, defaults.out);
  std::ofstream(dir.Path("bad.yaml")) << "slam:\n  spurious_tau_m2: wide\n";
  const Result bad = Oslam("config --check " + dir.Path("bad.yaml"));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
  EXPECT_NE(bad.err.find("bad.yaml: slam.spurious_tau_m2"), std::string::npos) << bad.err;
}

// Ctrl-C in the middle of writing frames leaves complete files only: no temp
// files, every frame written so far decodes.
TEST(Interrupt, SigintLeavesNoHalfWrittenFiles) {
  testing::TempDir dir;
  const std::string run = dir.Path("run");
  const std::string scene = std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/lab.yaml";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    execl(OSLAM_BINARY, "oslam", "simulate", scene.c_str(), "-o", run.c_str(), "--quiet", nullptr);
    _exit(127);
  }
  // Interrupt once some frames are out, however loaded the machine is.
  auto frames_written = [&] {
    std::error_code ec;
    if (!fs::is_directory(run + "/frames", ec)) return 0;
    int n = 0;
    for (const auto& entry : fs::directory_iterator(run + "/frames", ec))
      n += entry.path().extension() == ".png";
    return n;
  };
  for (int i = 0; i < 1200 && frames_written() < 3; ++i) usleep(50000);
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGINT)
      << "the simulation was not interrupted (finished first?)";
  int frames = 0;
  for (const auto& entry : fs::recursive_directory_iterator(run)) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
    if (entry.path().extension() == ".png") {
      EXPECT_FALSE(cv::imread(entry.path().string()).empty()) << entry.path();
      ++frames;
    }
  }
  EXPECT_GT(frames, 0);
  EXPECT_FALSE(fs::exists(run + "/odometry.csv"));  // written last: the run is visibly unfinished
}

// `oslam map --known-association` on the same run: with --keyframe-start
// below its 16 frames the solve starts from the keyframe solve, says so and
// records it in the O-Map; with 0 it starts from raw odometry and reaches
// the same map.
TEST_F(RunCommand, MapReportsTheKeyframeStartOfALongRun) {
  testing::TempDir dir;
  const std::string common = "map " + Run() + " --known-association --seed 2 ";
  const Result keyframed = Oslam(common + "--keyframe-start 5 -o " + dir.Path("keyframed.json"));
  ASSERT_EQ(keyframed.exit_code, 0) << keyframed.err;
  EXPECT_NE(keyframed.out.find("start: 3 keyframes, "), std::string::npos)
      << keyframed.out;  // frames 0, 10 and 15
  const nlohmann::json with = nlohmann::json::parse(ReadFile(dir.Path("keyframed.json")));
  ASSERT_TRUE(with["solver"].contains("keyframe_start")) << with["solver"].dump();
  EXPECT_EQ(with["solver"]["keyframe_start"]["keyframes"], 3);

  const Result raw = Oslam(common + "--keyframe-start 0 -o " + dir.Path("raw.json"));
  ASSERT_EQ(raw.exit_code, 0) << raw.err;
  EXPECT_EQ(raw.out.find("start:"), std::string::npos) << raw.out;
  const nlohmann::json without = nlohmann::json::parse(ReadFile(dir.Path("raw.json")));
  EXPECT_FALSE(without["solver"].contains("keyframe_start"));
  EXPECT_NEAR(with["solver"]["final_cost"].get<double>(),
              without["solver"]["final_cost"].get<double>(), 1e-2);

  const Result bad = Oslam(common + "--keyframe-start -1 -o " + dir.Path("bad.json"));
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  EXPECT_NE(bad.err.find("--keyframe-start must be >= 0"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir.Path("bad.json")));
}

}  // namespace
}  // namespace oslam

// `oslam run` marks its output folder (run.json): a run that failed or was
// killed half way never looks finished, a re-run leaves no older result
// beside its own, and --resume reuses what a killed run completed.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <iostream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "reliability_fixture.h"

extern char** environ;

namespace oslam {
namespace {

using testing::CopyOfRun;
using testing::FixtureRun;
using testing::Oslam;
using testing::OslamResult;
using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;
namespace fs = std::filesystem;

// The fixture's fast run, seeded and quiet.
std::vector<std::string> Fast() {
  std::vector<std::string> arguments = testing::FastRunArguments();
  arguments.insert(arguments.end(), {"--seed", "3", "--quiet"});
  return arguments;
}

std::string FastArguments() {
  return testing::Joined(Fast());
}

nlohmann::json Status(const std::string& out) {
  return nlohmann::json::parse(ReadFile(out + "/run.json"));
}

TEST(RunStatus, ACompleteRunSaysSo) {
  TempDir dir;
  const std::string out = dir.Path("out");
  const OslamResult r = Oslam("run " + FixtureRun() + " -o " + out + FastArguments());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json status = Status(out);
  EXPECT_EQ(status["format"], "oslam-run");
  EXPECT_EQ(status["status"], "complete");
  for (const char* stage : {"configuration", "detect", "o-slam", "export", "eval", "report"})
    EXPECT_EQ(status["stages"][stage], "complete") << stage;
  EXPECT_FALSE(status.contains("error"));
  // Run times are in the report, not in the map.
  EXPECT_EQ(ReadFile(out + "/omap.json").find("time"), std::string::npos);
  EXPECT_NE(ReadFile(out + "/report.md").find("## Run times of the sampler"), std::string::npos);
}

TEST(RunStatus, AFailedReRunLeavesNoOlderResultAndSaysWhy) {
  TempDir dir;
  const std::string out = dir.Path("out");
  ASSERT_EQ(Oslam("run " + FixtureRun() + " -o " + out + FastArguments()).exit_code, 0);
  WriteFile(out + "/notes.txt", "the user's own file");
  const std::string run = CopyOfRun(dir.Path("run"));
  const std::string frame = run + "/frames/000009.png";
  WriteFile(frame, "not a png");
  const OslamResult r = Oslam("run " + run + " -o " + out + FastArguments());
  std::cout << "| run, failed re-run into an earlier run's folder | " << r.exit_code << " | "
            << testing::OneLine(r.err) << " | " << testing::FilesLeft(out) << " |" << std::endl;
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(frame + ": not an image"), std::string::npos) << r.err;
  for (const char* old : {"omap.json", "map.glb", "map.gltf", "map.ply", "report.md", "eval.json",
                          "detections.csv", "birdseye.png"})
    EXPECT_FALSE(fs::exists(out + "/" + old)) << old << " of the earlier run is left";
  EXPECT_EQ(ReadFile(out + "/notes.txt"), "the user's own file");
  EXPECT_TRUE(fs::exists(out + "/config.yaml"));
  const nlohmann::json status = Status(out);
  EXPECT_EQ(status["status"], "failed");
  EXPECT_EQ(status["stages"]["detect"], "failed");
  EXPECT_EQ(status["stages"]["o-slam"], "pending");
  EXPECT_NE(status["error"].get<std::string>().find("000009.png"), std::string::npos);
}

// A re-run replaces the overlays it draws: none of the earlier run's
// frames is left beside them (a frame drawn then and not now would show an
// older map), also when it draws none, and files of the user's own in
// overlays/ are kept.
TEST(RunStatus, AReRunClearsTheOverlaysOfTheEarlierRun) {
  TempDir dir;
  const std::string out = dir.Path("out"), overlays = out + "/overlays";
  const auto run = [&](const std::string& frames) {
    return Oslam("run " + FixtureRun() + " -o " + out + FastArguments() +
                 " --set export.overlays=1 --set export.overlay_frames=" + frames +
                 " --set export.figure_size_px=200");
  };
  const OslamResult first = run("0-5");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_EQ(testing::FilesUnder(overlays),
            (std::vector<std::string>{"000000.jpg", "000001.jpg", "000002.jpg", "000003.jpg",
                                      "000004.jpg", "000005.jpg"}));
  WriteFile(overlays + "/notes.txt", "the user's own file");
  WriteFile(overlays + "/000001.jpg", "an old overlay");  // must be drawn again
  const OslamResult second = run("1,2");
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_EQ(testing::FilesUnder(overlays),
            (std::vector<std::string>{"000001.jpg", "000002.jpg", "notes.txt"}));
  EXPECT_NE(ReadFile(overlays + "/000001.jpg"), "an old overlay");
  EXPECT_EQ(ReadFile(overlays + "/notes.txt"), "the user's own file");
  std::cout << "| run, re-run drawing frames 1,2 after 0-5 | " << second.exit_code
            << " | - | overlays: " << testing::FilesLeft(overlays) << " |" << std::endl;
  // With overlays off, the earlier overlays would show a map this run did
  // not make: they go too.
  const OslamResult third =
      Oslam("run " + FixtureRun() + " -o " + out + FastArguments() + " --set export.overlays=0");
  ASSERT_EQ(third.exit_code, 0) << third.err;
  EXPECT_EQ(testing::FilesUnder(overlays), (std::vector<std::string>{"notes.txt"}));
  std::cout << "| run, re-run with overlays off | " << third.exit_code
            << " | - | overlays: " << testing::FilesLeft(overlays) << " |" << std::endl;
}

// Starts oslam with `arguments`; returns its pid.
pid_t Start(const std::vector<std::string>& arguments) {
  std::vector<std::string> all = {OSLAM_BINARY};
  all.insert(all.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int failed = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return failed ? -1 : pid;
}

TEST(RunStatus, AKilledRunLooksUnfinishedAndResumeReusesItsStages) {
  TempDir dir;
  const std::string out = dir.Path("out");
  std::vector<std::string> arguments = {"run", FixtureRun(), "-o", out};
  const std::vector<std::string> fast = Fast();
  arguments.insert(arguments.end(), fast.begin(), fast.end());
  const pid_t pid = Start(arguments);
  ASSERT_GT(pid, 0);
  // Killed (no chance to clean up) once the detections are done.
  bool detected = false;
  const auto start = std::chrono::steady_clock::now();
  while (!detected && std::chrono::steady_clock::now() - start < std::chrono::seconds(120)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    const std::string text = ReadFile(out + "/run.json");
    detected = text.find("\"detect\": \"complete\"") != std::string::npos;
  }
  ::kill(pid, SIGKILL);
  int wait_status = 0;
  ::waitpid(pid, &wait_status, 0);
  ASSERT_TRUE(detected) << "the run never finished its detect stage";
  const nlohmann::json killed = Status(out);
  std::cout << "| run, killed after the detect stage | (SIGKILL) | - | run.json: "
            << killed["status"] << " |" << std::endl;
  EXPECT_EQ(killed["status"], "running");  // never "complete"
  EXPECT_FALSE(fs::exists(out + "/report.md"));

  const OslamResult resumed =
      Oslam("run " + FixtureRun() + " -o " + out + " --resume" + FastArguments());
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  const nlohmann::json status = Status(out);
  EXPECT_EQ(status["status"], "complete");
  EXPECT_EQ(status["stages"]["detect"], "reused");
  // The kill races the next stage: a fast O-SLAM stage (or a test process
  // polling late under load) may have completed it too, and then it is
  // reused as well; a stage unfinished at the kill is run again.
  const bool slam_done_when_killed = killed["stages"].value("o-slam", "") == "complete";
  EXPECT_EQ(status["stages"]["o-slam"], slam_done_when_killed ? "reused" : "complete");
  // The same map as a run from scratch (into another folder: the paths in
  // the map differ by that folder only).
  const std::string fresh = dir.Path("fresh");
  ASSERT_EQ(Oslam("run " + FixtureRun() + " -o " + fresh + FastArguments()).exit_code, 0);
  std::string map = ReadFile(out + "/omap.json");
  for (size_t at; (at = map.find(out + "/")) != std::string::npos;)
    map.replace(at, out.size(), fresh);
  EXPECT_EQ(map, ReadFile(fresh + "/omap.json"));
  // Other settings: nothing is reused.
  const OslamResult other = Oslam("run " + FixtureRun() + " -o " + out +
                                  " --resume --set detect.min_area_px=41" + FastArguments());
  ASSERT_EQ(other.exit_code, 0) << other.err;
  EXPECT_EQ(Status(out)["stages"]["detect"], "complete");
}

}  // namespace
}  // namespace oslam

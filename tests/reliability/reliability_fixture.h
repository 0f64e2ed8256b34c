// Shared by the reliability tests (bad input, full disk, fuzzing): the oslam
// program run with a time limit, and one small simulated run with trained
// colours, detections and an O-Map, made once per build and copied by each
// test that changes it.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "test_util.h"

namespace oslam::testing {

namespace fs = std::filesystem;

struct OslamResult {
  int exit_code = -1;  // -1: killed by a signal
  bool timed_out = false;
  double seconds = 0;
  std::string out, err;
};

// Runs `oslam ARGUMENTS` under `timeout` (a hang is a result, not a stuck
// test), optionally after a shell prefix such as "ulimit -f 8;". The prefix
// applies to oslam alone: its output reaches the files through pipes, so that
// a file size limit does not swallow the error message.
inline OslamResult Oslam(const std::string& arguments, double timeout_s = 60,
                         const std::string& shell_prefix = "") {
  TempDir dir;
  std::ostringstream command;
  command << "bash -c 'set -o pipefail; { (" << shell_prefix << " exec timeout -s KILL "
          << timeout_s << " " << OSLAM_BINARY << " " << arguments << ") | cat >" << dir.Path("out")
          << "; } 2>&1 | cat >" << dir.Path("err") << "'";
  const auto start = std::chrono::steady_clock::now();
  const int status = std::system(command.str().c_str());
  OslamResult result;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  // timeout -s KILL: the child dies of SIGKILL, bash reports 128 + 9.
  result.timed_out = code == 137 && result.seconds >= timeout_s;
  result.exit_code = code >= 128 ? -1 : code;
  std::stringstream out, err;
  out << std::ifstream(dir.Path("out")).rdbuf();
  err << std::ifstream(dir.Path("err")).rdbuf();
  result.out = out.str();
  result.err = err.str();
  return result;
}

inline std::string ReadFile(const std::string& path) {
  std::stringstream text;
  text << std::ifstream(path, std::ios::binary).rdbuf();
  return text.str();
}

inline void WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

inline int Lines(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

// A one-line message without its newline, for the printed tables.
inline std::string OneLine(std::string message) {
  if (!message.empty() && message.back() == '\n') message.pop_back();
  return message;
}

// Settings that make `oslam run` on the fixture take seconds: a short
// sampler and no overlays (tests that want overlays set them again).
inline std::vector<std::string> FastRunArguments() {
  return {"--set", "slam.samples=60",    "--set", "slam.burn_in=10",
          "--set", "slam.hill_climb=20", "--set", "export.overlays=0"};
}

// The arguments as one command-line string, each after a space.
inline std::string Joined(const std::vector<std::string>& arguments) {
  std::string text;
  for (const std::string& a : arguments) text += " " + a;
  return text;
}

// Every regular file under `folder` (relative paths, sorted); empty when the
// folder does not exist.
inline std::vector<std::string> FilesUnder(const std::string& folder) {
  std::vector<std::string> files;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return files;
  for (const auto& entry : fs::recursive_directory_iterator(folder))
    if (!entry.is_directory()) files.push_back(fs::relative(entry.path(), folder).string());
  std::sort(files.begin(), files.end());
  return files;
}

// The files under `folder` on one line ("none" when there are none).
inline std::string FilesLeft(const std::string& folder) {
  std::string list;
  for (const std::string& f : FilesUnder(folder)) list += (list.empty() ? "" : " ") + f;
  return list.empty() ? "none" : list;
}

// Temp files of an atomic write (".NAME.tmp-XXXXXX.EXT").
inline bool IsTempFile(const std::string& relative_path) {
  const std::string name = fs::path(relative_path).filename().string();
  return name.size() > 1 && name[0] == '.' && name.find(".tmp") != std::string::npos;
}

// The simulated run every reliability test starts from: 16 frames of the
// SIFT test scene, trained colours, detections.csv and an O-Map (omap.json,
// known association). Made once per build of the program: the first test to
// need it builds it in a temp folder and renames it into place.
inline std::string FixtureRun() {
  const fs::path home = fs::path(OSLAM_TEST_BUILD_DIR) / "reliability_fixture";
  // Made again whenever the program changes.
  const auto stamp = fs::last_write_time(OSLAM_BINARY).time_since_epoch().count();
  const fs::path done = home / ("run-" + std::to_string(stamp));
  if (fs::is_directory(done)) return done.string();
  std::error_code ec;
  if (fs::is_directory(home))
    for (const auto& entry : fs::directory_iterator(home))
      if (entry.path().filename().string().rfind("run-", 0) == 0 && entry.path() != done)
        fs::remove_all(entry, ec);  // of an older program
  fs::create_directories(home);
  const fs::path making = home / ("making-" + std::to_string(::getpid()));
  fs::remove_all(making);
  const std::string run = (making / "run").string();
  const auto must = [](const OslamResult& r, const std::string& what) {
    if (r.exit_code != 0) throw std::runtime_error(what + " failed: " + r.err);
  };
  must(Oslam("simulate " + std::string(OSLAM_SOURCE_DIR) + "/tests/data/sift_clutter.yaml -o " +
             run + " --quiet"),
       "simulate");
  must(Oslam("train-colors " + run + "/classes.yaml --from-ground-truth " + run + " --quiet"),
       "train-colors");
  must(Oslam("detect " + run + " --quiet"), "detect");
  must(Oslam("map " + run + " --known-association -o " + run + "/omap.json --quiet"), "map");
  fs::rename(run, done, ec);  // another test process may have been first: use its run
  fs::remove_all(making, ec);
  if (!fs::is_directory(done)) throw std::runtime_error("cannot make the fixture run");
  return done.string();
}

// A copy of the fixture run at `path` (replaced).
inline std::string CopyOfRun(const std::string& path) {
  fs::remove_all(path);
  fs::copy(FixtureRun(), path, fs::copy_options::recursive);
  return path;
}

}  // namespace oslam::testing

// Mutation fuzzing of every input parser, through the oslam program: each
// shipped or fixture input is mutated OSLAM_FUZZ_ROUNDS times from a fixed
// seed and handed to a command that reads it. Whatever the bytes, oslam must
// exit 0, 1 or 2 within the time limit (no crash, no hang); an error is one
// line naming the file; and a command that fails leaves no output behind.
// Each target prints its counts ("| target | runs | ... |").
#include <cstring>
#include <functional>
#include <iostream>
#include <map>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "reliability_fixture.h"

#ifndef OSLAM_FUZZ_ROUNDS
#define OSLAM_FUZZ_ROUNDS 12
#endif

namespace oslam {
namespace {

using testing::CopyOfRun;
using testing::FilesUnder;
using testing::Oslam;
using testing::OslamResult;
using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;
namespace fs = std::filesystem;

// Per case: a hang is a run longer than this (the slowest target, one
// simulated frame, takes well under a second).
constexpr double kTimeoutS = 30;

// Text mutations, biased towards what matters to the formats: separators,
// signs, exponents, huge numbers, NaN; and byte mutations for images.
std::string Mutate(const std::string& input, bool binary, std::mt19937_64* rng) {
  std::string out = input;
  static const char* const kTokens[] = {
      ",",     ":",      "-",    "[",   "]",  "{",           "}",   "\n",  "\"",
      "#",     ".",      "e",    "0",   "9",  " ",           "\t",  "nan", "inf",
      "1e300", "-1e308", "1e30", "2e9", "-1", "99999999999", "null"};
  std::uniform_int_distribution<int> edits(1, 6);
  for (int n = edits(*rng); n > 0 && !out.empty(); --n) {
    std::uniform_int_distribution<size_t> at(0, out.size() - 1);
    const size_t i = at(*rng);
    const std::string token = binary ? std::string(1, static_cast<char>((*rng)() & 0xFF))
                                     : kTokens[(*rng)() % (sizeof(kTokens) / sizeof(*kTokens))];
    switch ((*rng)() % 6) {
      case 0:
        out.replace(i, 1, token);
        break;
      case 1:
        out.insert(i, token);
        break;
      case 2:
        out.erase(i, 1 + (*rng)() % 8);
        break;
      case 3:
        out.insert(i, out.substr(i, (*rng)() % 40));
        break;
      case 4:
        out.resize(i);
        break;
      default:  // a byte of a binary header, or a digit of a number
        out[binary ? i % std::min<size_t>(out.size(), 64) : i] ^=
            static_cast<char>(1 << ((*rng)() % 8));
        break;
    }
  }
  return out;
}

struct Counts {
  int runs = 0, accepted = 0, rejected = 0, usage = 0, crashes = 0, hangs = 0, outputs_left = 0,
      unnamed = 0;
};

// Mutates the file `target` (relative to `folder`, a fresh copy each round)
// and runs `command` ({DIR} = the copy, {OUT} = a fresh output folder).
void Fuzz(const std::string& name, const std::function<void(const std::string&)>& make,
          const std::string& target, const std::string& command, bool binary = false) {
  TempDir work;
  const std::string original = work.Path("original");
  make(original);
  const std::string bytes = ReadFile(original + "/" + target);
  ASSERT_FALSE(bytes.empty()) << target;
  std::mt19937_64 rng(std::hash<std::string>()(name) ^ 20261125);
  Counts c;
  for (int round = 0; round < OSLAM_FUZZ_ROUNDS; ++round) {
    const std::string dir = work.Path("case" + std::to_string(round));
    const std::string out = work.Path("out" + std::to_string(round));
    fs::copy(original, dir, fs::copy_options::recursive);
    const std::string mutated = Mutate(bytes, binary, &rng);
    WriteFile(dir + "/" + target, mutated);
    std::string arguments = command;
    for (const auto& [key, value] : {std::pair<std::string, std::string>{"{DIR}", dir},
                                     std::pair<std::string, std::string>{"{OUT}", out}})
      for (size_t at; (at = arguments.find(key)) != std::string::npos;)
        arguments.replace(at, key.size(), value);
    const OslamResult r = Oslam(arguments, kTimeoutS);
    ++c.runs;
    const std::string where = name + " round " + std::to_string(round) + ": " + r.err;
    if (r.timed_out) {
      ++c.hangs;
      ADD_FAILURE() << "hang: " << where;
    } else if (r.exit_code < 0 || r.exit_code > 2) {
      ++c.crashes;
      ADD_FAILURE() << "crash (exit " << r.exit_code << "): " << where;
    } else if (r.exit_code == 0) {
      ++c.accepted;
    } else {
      ++(r.exit_code == 1 ? c.rejected : c.usage);
      EXPECT_EQ(testing::Lines(r.err), 1) << where;
      EXPECT_EQ(r.err.find("internal error"), std::string::npos) << where;
      if (r.exit_code == 1 && r.err.find(dir + "/" + target) == std::string::npos) {
        ++c.unnamed;
        ADD_FAILURE() << "the error does not name " << target << ": " << where;
      }
      if (!FilesUnder(out).empty()) {
        ++c.outputs_left;
        ADD_FAILURE() << "output left after an error: " << where;
      }
    }
    fs::remove_all(dir);
    fs::remove_all(out);
  }
  std::cout << "| " << name << " | " << c.runs << " | " << c.accepted << " | " << c.rejected
            << " | " << c.usage << " | " << c.crashes << " | " << c.hangs << " | " << c.outputs_left
            << " | " << c.unnamed << " |" << std::endl;
  EXPECT_GT(c.rejected + c.usage, 0) << name << ": no mutation was ever refused";
}

// The fixture run, or a one-frame copy of it (the detector's targets).
void FullRun(const std::string& path) {
  CopyOfRun(path);
}

void OneFrameRun(const std::string& path, const std::string& extension) {
  CopyOfRun(path);
  std::vector<std::string> frames = FilesUnder(path + "/frames");
  for (size_t i = 1; i < frames.size(); ++i) fs::remove(path + "/frames/" + frames[i]);
  std::string odometry = ReadFile(path + "/odometry.csv");
  odometry.erase(odometry.find('\n', odometry.find('\n') + 1) + 1);  // header and row 0
  WriteFile(path + "/odometry.csv", odometry);
  fs::remove(path + "/detections.csv");
  if (extension == ".png") return;
  const std::string png = path + "/frames/" + frames[0];
  ASSERT_TRUE(cv::imwrite(path + "/frames/000000" + extension, cv::imread(png)));
  fs::remove(png);
}

std::string Data(const std::string& name) {
  return std::string(OSLAM_SOURCE_DIR) + "/tests/data/" + name;
}

void Standalone(const std::string& path, const std::string& name, const std::string& source) {
  fs::create_directories(path);
  fs::copy(source, path + "/" + name);
}

TEST(Fuzz, CameraYaml) {
  Fuzz("camera.yaml", FullRun, "camera.yaml",
       "camera --from {DIR}/camera.yaml -o {OUT}/camera.yaml "
       "--quiet");
}

TEST(Fuzz, ClassesYaml) {
  Fuzz("classes.yaml", FullRun, "classes.yaml",
       "render {DIR}/omap.json --run {DIR} -o {OUT} --figure-size 64 --quiet");
}

TEST(Fuzz, OdometryCsv) {
  Fuzz("odometry.csv", FullRun, "odometry.csv",
       "render {DIR}/omap.json --run {DIR} -o {OUT} --figure-size 64 --quiet");
}

TEST(Fuzz, GroundTruthTrajectoryCsv) {
  Fuzz("ground_truth/trajectory.csv", FullRun, "ground_truth/trajectory.csv",
       "eval {DIR}/omap.json {DIR}/ground_truth -o {OUT}/eval.json");
}

TEST(Fuzz, GroundTruthObjectsCsv) {
  Fuzz("ground_truth/objects.csv", FullRun, "ground_truth/objects.csv",
       "eval {DIR}/omap.json {DIR}/ground_truth -o {OUT}/eval.json");
}

TEST(Fuzz, GroundTruthSightingsCsv) {
  Fuzz("ground_truth/sightings.csv", FullRun, "ground_truth/sightings.csv",
       "eval-detect {DIR} --json {OUT}/eval.json --quiet");
}

TEST(Fuzz, DetectionsCsv) {
  Fuzz("detections.csv", FullRun, "detections.csv",
       "overlay {DIR} {DIR}/omap.json -o {OUT} --frames 0 --quiet");
}

TEST(Fuzz, OMapJson) {
  Fuzz("omap.json", FullRun, "omap.json",
       "render {DIR}/omap.json -o {OUT} --figure-size 64 --quiet");
}

TEST(Fuzz, OMapJsonForExport) {
  Fuzz("omap.json (export)", FullRun, "omap.json",
       "export {DIR}/omap.json -o {OUT} --figure-size 64 --quiet");
}

TEST(Fuzz, FramePng) {
  Fuzz(
      "frames/000000.png", [](const std::string& p) { OneFrameRun(p, ".png"); },
      "frames/000000.png", "detect {DIR} -o {OUT}/detections.csv --quiet", true);
}

TEST(Fuzz, FrameJpeg) {
  Fuzz(
      "frames/000000.jpg", [](const std::string& p) { OneFrameRun(p, ".jpg"); },
      "frames/000000.jpg", "detect {DIR} -o {OUT}/detections.csv --quiet", true);
}

TEST(Fuzz, GtsamLandmarks) {
  Fuzz(
      "landmarks (gtsam)",
      [](const std::string& p) { Standalone(p, "data.txt", Data("landmarks/gtsam_small.txt")); },
      "data.txt", "map --landmarks {DIR}/data.txt -o {OUT}/omap.json --quiet");
}

TEST(Fuzz, G2oToroIsamLandmarks) {
  for (const char* name : {"g2o_small.g2o", "toro_small.graph", "isam_small.txt"})
    Fuzz(
        std::string("landmarks (") + name + ")",
        [name](const std::string& p) {
          Standalone(p, name, Data(std::string("landmarks/") + name));
        },
        name, std::string("map --landmarks {DIR}/") + name + " -o {OUT}/omap.json --quiet");
}

TEST(Fuzz, VictoriaRawMeasurements) {
  const auto make = [](const std::string& p) {
    Standalone(p, "measurements.dat", Data("landmarks/raw_measurements.dat"));
    fs::copy(Data("landmarks/raw_inputs.dat"), p + "/inputs.dat");
  };
  const std::string command =
      "map --landmarks {DIR}/measurements.dat --format victoria-raw --unknown-association "
      "-o {OUT}/omap.json --quiet";
  Fuzz("landmarks (victoria-raw measurements)", make, "measurements.dat", command);
  Fuzz("landmarks (victoria-raw inputs)", make, "inputs.dat", command);
}

TEST(Fuzz, SceneYaml) {
  Fuzz(
      "scene.yaml",
      [](const std::string& p) { Standalone(p, "scene.yaml", Data("sift_clutter.yaml")); },
      "scene.yaml", "simulate {DIR}/scene.yaml -o {OUT} --frames 1 --quiet");
}

TEST(Fuzz, RunConfigYaml) {
  const auto make = [](const std::string& p) {
    fs::create_directories(p);
    const OslamResult defaults = Oslam("config --print-defaults");
    ASSERT_EQ(defaults.exit_code, 0);
    WriteFile(p + "/oslam.yaml", defaults.out);
  };
  Fuzz("oslam.yaml (run configuration)", make, "oslam.yaml", "config --check {DIR}/oslam.yaml");
}

}  // namespace
}  // namespace oslam

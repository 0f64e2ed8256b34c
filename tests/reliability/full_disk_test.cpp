// A full disk, for every command that writes: oslam runs under `ulimit -f N`
// (with SIGXFSZ ignored, a write beyond N KiB fails as on a full disk) for
// several N. Whatever N, the command either succeeds or exits 1 with one
// line naming the file it could not write; no temp file is left; and every
// file under its final name is whole: the one a run without a limit writes,
// or the file that was there before. Each cell prints itself
// ("| command | limit | exit | message | files |").
#include <iostream>
#include <map>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "reliability_fixture.h"

namespace oslam {
namespace {

using testing::CopyOfRun;
using testing::FilesUnder;
using testing::FixtureRun;
using testing::Oslam;
using testing::OslamResult;
using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;
namespace fs = std::filesystem;

// Files whose content depends on the run time: only checked to be present.
const std::set<std::string> kTimed = {"report.md", "run.json"};

struct Command {
  std::string name;
  // Writes the inputs and any old output into `dir`; returns the arguments
  // ({OUT} = the output folder, which `prepare` may fill with old files).
  std::function<std::string(const std::string& dir, const std::string& out)> prepare;
};

std::map<std::string, std::string> Snapshot(const std::string& folder) {
  std::map<std::string, std::string> files;
  for (const std::string& f : FilesUnder(folder)) files[f] = ReadFile(folder + "/" + f);
  return files;
}

std::string Fast() {
  return testing::Joined(testing::FastRunArguments()) + " --set export.figure_size_px=200 ";
}

std::vector<Command> Commands() {
  return {
      {"camera -o",
       [](const std::string&, const std::string& out) {
         EXPECT_EQ(Oslam("camera --preset cogniron -o " + out + "/camera.yaml --quiet").exit_code,
                   0);
         return "camera --preset lpa -o " + out + "/camera.yaml --quiet";
       }},
      {"train-colors (in place)",
       [](const std::string&, const std::string& out) {
         CopyOfRun(out);  // classes.yaml is rewritten in place
         return "train-colors " + out + "/classes.yaml --from-ground-truth " + out + " --quiet";
       }},
      {"eval -o",
       [](const std::string&, const std::string& out) {
         fs::create_directories(out);
         WriteFile(out + "/eval.json", "old");
         return "eval " + FixtureRun() + "/omap.json " + FixtureRun() + "/ground_truth -o " + out +
                "/eval.json --json";
       }},
      {"map --known-association",
       [](const std::string&, const std::string& out) {
         return "map " + FixtureRun() + " --known-association -o " + out + "/omap.json --quiet";
       }},
      {"detect",
       [](const std::string&, const std::string& out) {
         return "detect " + FixtureRun() + " -o " + out + "/detections.csv --quiet";
       }},
      {"render",
       [](const std::string&, const std::string& out) {
         return "render " + FixtureRun() + "/omap.json --run " + FixtureRun() + " -o " + out +
                " --figure-size 200 --quiet";
       }},
      {"export",
       [](const std::string&, const std::string& out) {
         return "export " + FixtureRun() + "/omap.json --run " + FixtureRun() + " -o " + out +
                " --figure-size 200 --quiet";
       }},
      {"simulate",
       [](const std::string&, const std::string& out) {
         return "simulate " + std::string(OSLAM_SOURCE_DIR) + "/tests/data/sift_clutter.yaml -o " +
                out + " --frames 2 --quiet";
       }},
      {"run",
       [](const std::string&, const std::string& out) {
         return "run " + FixtureRun() + " -o " + out + Fast() + "--quiet";
       }},
  };
}

class FullDisk : public ::testing::TestWithParam<int> {};

TEST_P(FullDisk, EveryFileIsWholeOrAsBeforeAndTheErrorNamesIt) {
  const Command command = Commands()[GetParam()];
  TempDir dir;
  // Without a limit: what a complete write gives.
  const std::string reference_out = dir.Path("reference");
  const std::string reference_arguments = command.prepare(dir.Path(), reference_out);
  const std::map<std::string, std::string> reference_before = Snapshot(reference_out);
  const OslamResult reference = Oslam(reference_arguments);
  ASSERT_EQ(reference.exit_code, 0) << reference.err;
  const std::map<std::string, std::string> complete = Snapshot(reference_out);
  int failures = 0;
  for (const int limit_kib : {0, 2, 16, 64, 256}) {
    const std::string out = dir.Path("out" + std::to_string(limit_kib));
    const std::string arguments = command.prepare(dir.Path(), out);
    const std::map<std::string, std::string> before = Snapshot(out);
    const OslamResult r =
        Oslam(arguments, 120, "trap \"\" XFSZ; ulimit -f " + std::to_string(limit_kib) + ";");
    // Map the reference's paths onto this cell's output folder.
    std::string whole;
    int wrong = 0;
    for (auto [file, bytes] : Snapshot(out)) {
      // Paths written into the files (omap.json's source) name this cell's folder.
      for (size_t at; (at = bytes.find(out + "/")) != std::string::npos;)
        bytes.replace(at, out.size(), reference_out);
      const std::string at = "[" + std::to_string(limit_kib) + " KiB] " + file;
      EXPECT_FALSE(testing::IsTempFile(file)) << command.name << " " << at;
      const auto done = complete.find(file);
      const auto old = before.find(file);
      const bool is_complete =
          done != complete.end() && (kTimed.count(file) || done->second == bytes);
      const bool is_old = old != before.end() && old->second == bytes;
      if (is_complete || is_old) {
        whole += (whole.empty() ? "" : " ") + file + (is_old && !is_complete ? " (old)" : "");
      } else {
        ++wrong;
        ADD_FAILURE() << command.name << " " << at << ": neither whole nor as before ("
                      << bytes.size() << " bytes)";
      }
    }
    const std::string message = testing::OneLine(r.err);
    std::cout << "| " << command.name << " | " << limit_kib << " KiB | " << r.exit_code << " | "
              << (message.empty() ? "-" : message) << " | " << (whole.empty() ? "none" : whole)
              << " |" << std::endl;
    EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 1) << command.name << ": " << r.err;
    if (r.exit_code == 1) {
      EXPECT_EQ(testing::Lines(r.err), 1) << r.err;
      EXPECT_EQ(r.err.find("libpng"), std::string::npos) << r.err;
      EXPECT_NE(r.err.find(out), std::string::npos) << "the error names no output file: " << r.err;
    } else {
      EXPECT_EQ(r.err, "") << command.name;
      EXPECT_EQ(Snapshot(out).size(), complete.size()) << command.name;
    }
    failures += wrong;
  }
  (void)reference_before;
  EXPECT_EQ(failures, 0);
}

INSTANTIATE_TEST_SUITE_P(Commands, FullDisk, ::testing::Range(0, 9),
                         [](const ::testing::TestParamInfo<int>& info) {
                           std::string name = Commands()[info.param].name;
                           for (char& c : name)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return name;
                         });

}  // namespace
}  // namespace oslam

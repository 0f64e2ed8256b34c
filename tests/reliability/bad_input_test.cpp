// The bad-input table: one row per failure an audit of oslam found (a full
// disk, absurd but finite values, corrupt images, planted symlinks, files
// that name nothing). Each row runs the oslam program and asserts the
// outcome a user must get: the exit code, one line naming the file (and
// line or key), no library message, no output left, and no long run. Each
// row also prints itself ("| case | exit | message | files left |") so the
// table can be read from the test log.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include <gtest/gtest.h>

#include "reliability_fixture.h"

namespace oslam {
namespace {

using testing::CopyOfRun;
using testing::FilesLeft;
using testing::FilesUnder;
using testing::FixtureRun;
using testing::Oslam;
using testing::OslamResult;
using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;
namespace fs = std::filesystem;

// Replaces the first `from` in the file at `path` by `to`.
void Edit(const std::string& path, const std::string& from, const std::string& to) {
  std::string text = ReadFile(path);
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from << " not in " << path;
  text.replace(at, from.size(), to);
  WriteFile(path, text);
}

// Replaces field `column` (0-based) of CSV data row `row` (0-based, after the header).
void EditCsv(const std::string& path, int row, int column, const std::string& value) {
  std::istringstream in(ReadFile(path));
  std::string line, out;
  for (int i = -1; std::getline(in, line); ++i) {
    if (i == row) {
      std::vector<std::string> fields;
      std::stringstream split(line);
      for (std::string f; std::getline(split, f, ',');) fields.push_back(f);
      fields.at(column) = value;
      line.clear();
      for (size_t k = 0; k < fields.size(); ++k) line += (k ? "," : "") + fields[k];
    }
    out += line + "\n";
  }
  WriteFile(path, out);
}

// Prints the row and checks what every row needs: the exit code, exactly one
// line on stderr holding every `parts`, and no hang (Oslam's time limit:
// unbounded work is a run killed there; speed itself is not asserted).
void Row(const std::string& name, const OslamResult& r, int exit_code,
         const std::vector<std::string>& parts, const std::string& files_left) {
  std::cout << "| " << name << " | " << r.exit_code << " | " << testing::OneLine(r.err) << " | "
            << files_left << " |" << std::endl;
  EXPECT_FALSE(r.timed_out) << name;
  EXPECT_EQ(r.exit_code, exit_code) << name << ": " << r.err;
  EXPECT_EQ(testing::Lines(r.err), 1) << name << ": " << r.err;
  EXPECT_EQ(r.err.find("libpng"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("internal error"), std::string::npos) << r.err;
  for (const std::string& part : parts) EXPECT_NE(r.err.find(part), std::string::npos) << r.err;
}

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override { run_ = FixtureRun(); }
  std::string run_;
  TempDir dir_;
};

// ---- 1. silent data loss on a full disk (ulimit -f: files cannot grow) ----

TEST_F(BadInput, TrainColorsOnAFullDiskKeepsTheClassesFile) {
  const std::string run = CopyOfRun(dir_.Path("run"));
  const std::string classes = run + "/classes.yaml";
  const std::string before = ReadFile(classes);
  const OslamResult r =
      Oslam("train-colors " + classes + " --from-ground-truth " + run + " --quiet", 60,
            "trap \"\" XFSZ; ulimit -f 0;");
  Row("train-colors, full disk", r, 1, {classes + ": write failed"}, "classes.yaml as it was");
  EXPECT_EQ(ReadFile(classes), before);
  for (const std::string& f : FilesUnder(run)) EXPECT_FALSE(testing::IsTempFile(f)) << f;
}

TEST_F(BadInput, CameraOnAFullDiskWritesNoEmptyFile) {
  const std::string out = dir_.Path("out/camera.yaml");
  const OslamResult r =
      Oslam("camera --preset lpa -o " + out + " --quiet", 60, "trap \"\" XFSZ; ulimit -f 0;");
  Row("camera -o, full disk", r, 1, {out + ": write failed"}, FilesLeft(dir_.Path("out")));
  EXPECT_TRUE(FilesUnder(dir_.Path("out")).empty());
}

// ---- 3. finite but absurd values ----

TEST_F(BadInput, RenderRefusesACoordinateOf1e300) {
  const std::string omap = dir_.Path("omap.json");
  fs::copy(run_ + "/omap.json", omap);
  std::string text = ReadFile(omap);
  const size_t at = text.find("\"base_point_m\": [") + 17;
  const size_t end = text.find(',', at);
  text.replace(at, end - at, "\n    1e300");
  WriteFile(omap, text);
  const std::string out = dir_.Path("out");
  const OslamResult r = Oslam("render " + omap + " -o " + out + " --quiet");
  Row("render, O-Map coordinate 1e300", r, 1,
      {omap + ": objects[0].base_point_m[0]: 1e+300 is outside"}, FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

TEST_F(BadInput, RenderRefusesATrajectoryXOfMinus1e308) {
  const std::string omap = dir_.Path("omap.json");
  fs::copy(run_ + "/omap.json", omap);
  std::string text = ReadFile(omap);
  const size_t at = text.find("\"x_m\": ") + 7;
  text.replace(at, text.find(',', at) - at, "-1e308");
  WriteFile(omap, text);
  const std::string out = dir_.Path("out");
  const OslamResult r = Oslam("render " + omap + " -o " + out + " --quiet");
  Row("render, trajectory x -1e308", r, 1, {omap + ": trajectory[0].x_m: -1e+308 is outside"},
      FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

TEST_F(BadInput, RenderRefusesOdometryYOf1e30) {
  const std::string run = CopyOfRun(dir_.Path("run"));
  EditCsv(run + "/odometry.csv", 1, 2, "1e30");
  const std::string out = dir_.Path("out");
  const OslamResult r =
      Oslam("render " + run + "/omap.json --run " + run + " -o " + out + " --quiet");
  Row("render, odometry y 1e30", r, 1, {run + "/odometry.csv:3: column 'y_m': 1e+30 is outside"},
      FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

void EditFirstObject(const std::string& omap, const std::string& key, const std::string& value) {
  std::string text = ReadFile(omap);
  const size_t at = text.find("\"" + key + "\": ") + key.size() + 4;
  text.replace(at, text.find_first_of(",\n", at) - at, value);
  WriteFile(omap, text);
}

TEST_F(BadInput, ExportRefusesADiameterOf1e300) {
  const std::string omap = dir_.Path("omap.json");
  fs::copy(run_ + "/omap.json", omap);
  EditFirstObject(omap, "diameter_m", "1e300");
  const std::string out = dir_.Path("out");
  const OslamResult r = Oslam("export " + omap + " -o " + out + " --quiet");
  Row("export, diameter 1e300", r, 1, {omap + ": objects[0].diameter_m: 1e+300 is outside"},
      FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

TEST_F(BadInput, ExportRefusesABaseOf1e300) {
  const std::string omap = dir_.Path("omap.json");
  fs::copy(run_ + "/omap.json", omap);
  std::string text = ReadFile(omap);
  const size_t list = text.find("\"base_point_m\": [");
  const size_t last = text.rfind(',', text.find(']', list)) + 1;  // z
  text.replace(last, text.find(']', list) - last, "\n    1e300\n   ");
  WriteFile(omap, text);
  const std::string out = dir_.Path("out");
  const OslamResult r = Oslam("export " + omap + " -o " + out + " --quiet");
  Row("export, base z 1e300", r, 1, {omap + ": objects[0].base_point_m[2]: 1e+300 is outside"},
      FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

TEST_F(BadInput, CameraOf60000By60000IsRefused) {
  const std::string camera = dir_.Path("camera.yaml");
  fs::copy(run_ + "/camera.yaml", camera);
  Edit(camera, "image_width: 640", "image_width: 60000");
  Edit(camera, "image_height: 480", "image_height: 60000");
  const OslamResult r = Oslam("camera --from " + camera + " --quiet");
  Row("camera.yaml 60000x60000", r, 1,
      {camera + ": invalid camera: image size 60000x60000 is beyond the image bounds"}, "none");
  // And a run using it stops before decoding a frame.
  const std::string run = CopyOfRun(dir_.Path("run"));
  fs::copy(camera, run + "/camera.yaml", fs::copy_options::overwrite_existing);
  const OslamResult detect = Oslam("detect " + run + " -o " + dir_.Path("d.csv") + " --quiet");
  Row("detect, camera.yaml 60000x60000", detect, 1, {run + "/camera.yaml: invalid camera"},
      fs::exists(dir_.Path("d.csv")) ? "d.csv" : "none");
  EXPECT_FALSE(fs::exists(dir_.Path("d.csv")));
}

// A real PNG whose IHDR declares another size (the CRC is left stale: the
// size must be refused before a decoder looks at the chunk).
std::string PngDeclaring(const std::string& png, unsigned width, unsigned height) {
  std::string bytes = png;
  for (int k = 0; k < 4; ++k) {
    bytes[16 + k] = static_cast<char>((width >> (24 - 8 * k)) & 0xFF);
    bytes[20 + k] = static_cast<char>((height >> (24 - 8 * k)) & 0xFF);
  }
  return bytes;
}

TEST_F(BadInput, APngDeclaring30000By30000IsRefusedBeforeDecoding) {
  const std::string run = CopyOfRun(dir_.Path("run"));
  const std::string frame = run + "/frames/000003.png";
  WriteFile(frame, PngDeclaring(ReadFile(frame), 30000, 30000));
  const std::string out = dir_.Path("d.csv");
  const OslamResult r = Oslam("detect " + run + " -o " + out + " --quiet");
  Row("detect, PNG declaring 30000x30000", r, 1,
      {frame + ": the png header declares 30000x30000 pixels, beyond the image bounds"},
      fs::exists(out) ? "d.csv" : "none");
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(BadInput, AFigureSizeOf100000IsAUsageErrorBeforeAnyFile) {
  for (const char* command : {"render", "export"}) {
    const std::string out = dir_.Path(std::string("out_") + command);
    const OslamResult r = Oslam(std::string(command) + " " + run_ + "/omap.json -o " + out +
                                " --figure-size 100000 --quiet");
    Row(std::string(command) + " --figure-size 100000", r, 2, {"64 to 8192 pixels"},
        FilesLeft(out));
    EXPECT_TRUE(FilesUnder(out).empty());
  }
}

TEST_F(BadInput, ADetectionWiderThanACircleIsRefused) {
  for (const char* width : {"2e7", "1e6"}) {
    const std::string run = CopyOfRun(dir_.Path(std::string("run") + width));
    EditCsv(run + "/detections.csv", 0, 5, width);
    const std::string out = dir_.Path(std::string("out") + width);
    const OslamResult r =
        Oslam("overlay " + run + " " + run + "/omap.json -o " + out + " --frames 0 --quiet");
    Row(std::string("overlay, s_phi_rad ") + width, r, 1,
        {run + "/detections.csv:2: column 's_phi_rad': ", "is outside [0, 6.28319]"},
        FilesLeft(out));
    EXPECT_TRUE(FilesUnder(out).empty());
  }
}

// ---- 4. temp files that could be hijacked ----

TEST_F(BadInput, ASymlinkPlantedInTheOutputFolderIsNeverFollowed) {
  const std::string out = dir_.Path("out");
  fs::create_directories(out);
  const std::string victim = dir_.Path("victim.txt");
  WriteFile(victim, "keep me");
  // Every name the old temp scheme (".STEM.tmpPID-N.EXT") could pick for the
  // next few processes, and the target itself.
  for (int pid = ::getpid(); pid < ::getpid() + 200; ++pid)
    fs::create_symlink(victim, out + "/.eval.tmp" + std::to_string(pid) + "-0.json");
  fs::create_symlink(victim, out + "/eval.json");
  const OslamResult r = Oslam("eval " + run_ + "/omap.json " + run_ + "/ground_truth -o " + out +
                              "/eval.json --json");
  std::cout << "| eval -o, symlinks planted at temp names and the target | " << r.exit_code
            << " | (none: exit 0) | eval.json; victim untouched |" << std::endl;
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadFile(victim), "keep me");
  EXPECT_FALSE(fs::is_symlink(out + "/eval.json"));
  EXPECT_NE(ReadFile(out + "/eval.json").find("ate"), std::string::npos);
}

// ---- 5. errors that name nothing, or say nothing ----

TEST_F(BadInput, LandmarksWithXOf1e300AreRefusedBeforeAnythingIsWritten) {
  const std::string data = dir_.Path("landmarks.txt");
  WriteFile(data,
            "ODOMETRY 0 1 1.0 0.0 0.0 0.0001 0 0 4e-06 0 4e-06\n"
            "LANDMARK 1 2 1e300 5.0 0.4 0 0.4\n"
            "ODOMETRY 1 3 1.0 0.1 0.5 0.0001 0 0 4e-06 0 4e-06\n"
            "LANDMARK 3 2 3.0 0.0 0.4 0.1 0.9\n");
  const std::string out = dir_.Path("out");
  const OslamResult r = Oslam("map --landmarks " + data + " -o " + out + "/omap.json --quiet");
  Row("map --landmarks, x 1e300", r, 1, {data + ":2: x: 1e+300 is outside"}, FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

TEST_F(BadInput, AG2oVertexAt1e300IsRefusedBeforeAnythingIsWritten) {
  const std::string data = dir_.Path("landmarks.g2o");
  WriteFile(data,
            "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_XY 2 1e300 5\n"
            "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 1000\nEDGE_SE2_XY 0 2 3 5 10 0 10\n");
  const std::string out = dir_.Path("out");
  const OslamResult r = Oslam("map --landmarks " + data + " -o " + out + "/omap.json --quiet");
  Row("map --landmarks (g2o), vertex x 1e300", r, 1, {data + ":3: x: 1e+300 is outside"},
      FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

TEST_F(BadInput, AnOMapFieldOfTheWrongTypeIsNamed) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"diameter_m", "\"big\""}, {"class", "7"}, {"num_detections", "[1]"}, {"id", "{}"}};
  const std::vector<std::string> expected = {
      "objects[0].diameter_m: must be a number", "objects[0].class: must be a string",
      "objects[0].num_detections: must be a number", "objects[0].id: must be a number"};
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string omap = dir_.Path("omap" + std::to_string(i) + ".json");
    fs::copy(run_ + "/omap.json", omap);
    EditFirstObject(omap, cases[i].first, cases[i].second);
    const std::string out = dir_.Path("out" + std::to_string(i));
    const OslamResult r = Oslam("export " + omap + " -o " + out + " --quiet");
    Row("export, O-Map " + cases[i].first + " = " + cases[i].second, r, 1,
        {omap + ": " + expected[i]}, FilesLeft(out));
    EXPECT_TRUE(FilesUnder(out).empty());
  }
}

TEST_F(BadInput, ATruncatedPngIsOneLineNamingTheFrame) {
  const std::string run = CopyOfRun(dir_.Path("run"));
  const std::string frame = run + "/frames/000005.png";
  const std::string bytes = ReadFile(frame);
  WriteFile(frame, bytes.substr(0, bytes.size() / 2));
  const std::string out = dir_.Path("d.csv");
  const OslamResult r = Oslam("detect " + run + " -o " + out + " --quiet");
  Row("detect, truncated PNG", r, 1, {frame + ": corrupt PNG: the file ends early"},
      fs::exists(out) ? "d.csv" : "none");
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(BadInput, ADamagedVideoIsOneLineNamingIt) {
  const std::string run = CopyOfRun(dir_.Path("run"));
  fs::remove_all(run + "/frames");
  // An MP4 header and then nothing a decoder can use: FFmpeg has its own
  // message for it ("moov atom not found"), which must not reach the terminal.
  std::string video(
      "\0\0\0\x18"
      "ftypmp42\0\0\0\0mp42isom",
      24);
  for (int i = 0; i < 4096; ++i) video += static_cast<char>((i * 7919) % 251);
  WriteFile(run + "/video.mp4", video);
  const std::string out = dir_.Path("d.csv");
  const OslamResult r = Oslam("detect " + run + " -o " + out + " --quiet");
  Row("detect, damaged video.mp4", r, 1, {run + "/video.mp4: "},
      fs::exists(out) ? "d.csv" : "none");
  EXPECT_EQ(r.err.find("moov"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(BadInput, AMeiXiOf50IsRefused) {
  const std::string camera = dir_.Path("camera.yaml");
  WriteFile(camera,
            "model: mei\nimage_width: 640\nimage_height: 480\nblind_radius_px: 40\n"
            "rim_radius_px: 236\nintrinsics:\n  xi: 50\n  fx_px: 300\n  fy_px: 300\n"
            "  skew_px: 0\n  cx_px: 320\n  cy_px: 240\n  k1: 0\n  k2: 0\n  p1: 0\n  p2: 0\n"
            "  focus_height_m: 0.8\n  mount_roll_rad: 0\n  mount_pitch_rad: 0\n"
            "  mount_yaw_rad: 0\n");
  const OslamResult r = Oslam("camera --from " + camera + " --quiet");
  Row("camera.yaml, mei xi 50", r, 1, {camera + ": invalid camera: xi: 50 is outside [0, 3]"},
      "none");
}

TEST_F(BadInput, AMirrorOfB1000TimesAIsRefused) {
  const std::string camera = dir_.Path("camera.yaml");
  fs::copy(run_ + "/camera.yaml", camera);
  std::string text = ReadFile(camera);
  const size_t at = text.find("mirror_b_m: ") + 12;
  text.replace(at, text.find('\n', at) - at, "39.29");
  WriteFile(camera, text);
  const OslamResult r = Oslam("camera --from " + camera + " --quiet");
  Row("camera.yaml, mirror b = 1000 a", r, 1,
      {camera + ": invalid camera: mirror_b_m", "is outside"}, "none");
}

TEST_F(BadInput, AnIdOf1e300IsRefusedNotWrapped) {
  const std::string omap = dir_.Path("omap.json");
  fs::copy(run_ + "/omap.json", omap);
  EditFirstObject(omap, "id", "1e300");
  const std::string out = dir_.Path("out");
  const OslamResult r = Oslam("export " + omap + " -o " + out + " --quiet");
  Row("export, O-Map id 1e300", r, 1, {omap + ": objects[0].id: 1e+300 is outside"},
      FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

TEST_F(BadInput, ANegativeDiameterIsRefused) {
  const std::string omap = dir_.Path("omap.json");
  fs::copy(run_ + "/omap.json", omap);
  EditFirstObject(omap, "diameter_m", "-0.5");
  const std::string out = dir_.Path("out");
  const OslamResult r = Oslam("export " + omap + " -o " + out + " --quiet");
  Row("export, negative diameter", r, 1,
      {omap + ": objects[0].diameter_m: -0.5 is outside [0, 100] m"}, FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

TEST_F(BadInput, NoDetectionSurvivingPreAssociationNamesTheDetections) {
  const std::string run = CopyOfRun(dir_.Path("run"));
  // Two sightings five frames apart: no track of the 3 frames a track needs.
  std::string csv = ReadFile(run + "/detections.csv");
  const size_t first = csv.find('\n') + 1, second = csv.find('\n', first) + 1;
  WriteFile(run + "/detections.csv", csv.substr(0, second));
  EditCsv(run + "/detections.csv", 0, 0, "5");
  const std::string out = dir_.Path("out");
  const OslamResult r = Oslam("slam " + run + " -o " + out + "/omap.json --quiet");
  Row("slam, no detection survives pre-association", r, 1,
      {run + "/detections.csv: no detection survived pre-association (1 detections, 1 of them in "
             "tracks shorter than 3 frames)"},
      FilesLeft(out));
  EXPECT_TRUE(FilesUnder(out).empty());
}

TEST_F(BadInput, AnOverlaysSymlinkOutOfTheOutputFolderIsRefused) {
  const std::string out = dir_.Path("out"), outside = dir_.Path("outside");
  fs::create_directories(out);
  fs::create_directories(outside);
  fs::create_symlink(outside, out + "/overlays");
  const OslamResult r = Oslam("export " + run_ + "/omap.json --run " + run_ + " --overlays -o " +
                              out + " --figure-size 64 --quiet");
  Row("export --overlays, overlays/ a symlink out of -o", r, 1,
      {out + "/overlays: a symlink to " + outside + ", out of the output folder"},
      FilesLeft(out) + "; outside: " + FilesLeft(outside));
  EXPECT_TRUE(FilesUnder(outside).empty());
  EXPECT_EQ(FilesUnder(out).size(), 0u);  // the symlink is no regular file
  const OslamResult run = Oslam("run " + run_ + " -o " + out + " --quiet");
  Row("run, overlays/ a symlink out of -o", run, 1,
      {out + "/overlays: a symlink to " + outside + ", out of the output folder"},
      FilesLeft(out) + "; outside: " + FilesLeft(outside));
  EXPECT_TRUE(FilesUnder(outside).empty());
}

}  // namespace
}  // namespace oslam

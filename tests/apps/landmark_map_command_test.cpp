// oslam map --landmarks end to end on the fixtures: O-Map and trajectory CSV
// written and readable, association files, one-line errors and exit codes.
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "core/csv.h"
#include "omap/omap_json.h"
#include "test_util.h"

namespace oslam {
namespace {

const std::string kData = std::string(OSLAM_SOURCE_DIR) + "/tests/data/landmarks/";

testing::CommandResult RunOslam(const std::string& arguments) {
  return testing::RunShellCommand(std::string(OSLAM_BINARY) + " " + arguments);
}

TEST(LandmarkMapCommand, GtsamFileGivesTreesAndTrajectory) {
  testing::TempDir dir;
  const testing::CommandResult run =
      RunOslam("map --landmarks " + kData + "gtsam_small.txt -o " + dir.Path("omap.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("2 landmarks from 3 sightings, 4 poses"), std::string::npos) << run.out;
  const OMap map = ReadOMap(dir.Path("omap.json"));
  ASSERT_EQ(map.objects.size(), 2u);
  EXPECT_EQ(map.objects[0].id, 2);
  EXPECT_EQ(map.objects[1].id, 7);
  EXPECT_EQ(map.objects[0].class_name, "tree");
  EXPECT_EQ(map.objects[0].num_detections, 2);
  EXPECT_EQ(map.objects[0].diameter_m, 0.0);  // not measured in this format
  EXPECT_GT(map.objects[0].covariance(0, 0), 0.0);
  ASSERT_EQ(map.trajectory.size(), 4u);
  EXPECT_EQ(map.trajectory[0].x, 0.0);  // the gauge
  const CsvTable trajectory = CsvTable::Read(dir.Path("trajectory.csv"));
  EXPECT_EQ(trajectory.header(),
            (std::vector<std::string>{"pose", "pose_id", "x_m", "y_m", "theta_rad"}));
  ASSERT_EQ(trajectory.num_rows(), 4u);
  EXPECT_EQ(trajectory.Integer(2, trajectory.ColumnIndex("pose_id")), 3);
  EXPECT_DOUBLE_EQ(trajectory.Double(3, trajectory.ColumnIndex("x_m")), map.trajectory[3].x);
}

TEST(LandmarkMapCommand, RawFormatWithAnAssociationFile) {
  testing::TempDir dir;
  const std::string common = "map --landmarks " + kData + "raw_measurements.dat --format " +
                             "victoria-raw --inputs " + kData + "raw_inputs.dat -o " +
                             dir.Path("omap.json") + " --trajectory " + dir.Path("t.csv");
  // No ids in the raw files: an error naming the file, exit code 1.
  const testing::CommandResult no_ids = RunOslam(common);
  EXPECT_EQ(no_ids.exit_code, 1);
  EXPECT_EQ(no_ids.err.rfind("oslam map: error: " + kData +
                                 "raw_measurements.dat: the sightings have no landmark ids",
                             0),
            0u)
      << no_ids.err;
  const testing::CommandResult run =
      RunOslam(common + " --association " + kData + "raw_association.txt --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, "");
  const OMap map = ReadOMap(dir.Path("omap.json"));
  ASSERT_EQ(map.objects.size(), 2u);
  // Landmark 0: seen twice, trunk 0.30 m and 0.40 m -> fused 0.35 m.
  EXPECT_NEAR(map.objects[0].diameter_m, 0.35, 1e-6);
  EXPECT_GT(map.objects[0].covariance(3, 3), 0.0);
  const CsvTable trajectory = CsvTable::Read(dir.Path("t.csv"));
  EXPECT_EQ(trajectory.header()[2], "time_s");
  EXPECT_EQ(trajectory.num_rows(), 3u);
}

// --preset victoria-raw: the raw format, unknown association and its flags;
// flags given override them.
TEST(LandmarkMapCommand, PresetSetsFlagsTheCommandLineOverrides) {
  testing::TempDir dir;
  const std::string common = "map --preset victoria-raw --landmarks " + kData +
                             "raw_measurements.dat --inputs " + kData + "raw_inputs.dat -o " +
                             dir.Path("omap.json");
  // The preset's --min-track 3: the fixture's tracks are shorter, all clutter.
  const testing::CommandResult strict = RunOslam(common);
  EXPECT_EQ(strict.exit_code, 1);
  EXPECT_NE(strict.err.find("no track of at least 3 sightings"), std::string::npos) << strict.err;
  const testing::CommandResult run = RunOslam(common + " --min-track 1");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("tracks: "), std::string::npos) << run.out;  // unknown association
  EXPECT_EQ(ReadOMap(dir.Path("omap.json")).trajectory.size(), 3u);
  const testing::CommandResult unknown = RunOslam(common + " --preset mars");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("unknown preset 'mars' (known: victoria-raw)"), std::string::npos)
      << unknown.err;
}

// oslam simulate-landmarks writes a data set and its truth that oslam map
// reads back: the true association solves close to the true trajectory.
TEST(LandmarkMapCommand, SimulatedWorldWithItsTruth) {
  testing::TempDir dir;
  const testing::CommandResult sim =
      RunOslam("simulate-landmarks -o " + dir.Path("w") +
               " --poses 300 --landmarks 40 --blocks 2 --seed 2 --format g2o");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  EXPECT_NE(sim.out.find("300 poses, 40 landmarks"), std::string::npos) << sim.out;
  const std::string world = dir.Path("w/world.g2o");
  const testing::CommandResult known = RunOslam(
      "map --landmarks " + world + " --association " + dir.Path("w/true_association.txt") +
      " --truth-trajectory " + dir.Path("w/true_trajectory.csv") + " -o " + dir.Path("omap.json"));
  ASSERT_EQ(known.exit_code, 0) << known.err;
  const size_t at = known.out.find("vs the true trajectory: RMSE ");
  ASSERT_NE(at, std::string::npos) << known.out;
  const double rmse = std::stod(known.out.substr(at + 29));
  // 300 m of odometry with 2 cm / 0.3 deg per metre, corrected by the
  // landmarks: well under a metre.
  EXPECT_GT(rmse, 0.0);
  EXPECT_LT(rmse, 1.0);
  const size_t aligned_at = known.out.find("after a rigid alignment (ATE) ", at);
  ASSERT_NE(aligned_at, std::string::npos) << known.out;
  const double ate = std::stod(known.out.substr(aligned_at + 30));
  EXPECT_GT(ate, 0.0);
  EXPECT_LE(ate, rmse + 1e-3);  // printed to the millimetre
  EXPECT_EQ(CsvTable::Read(dir.Path("w/true_landmarks.csv")).num_rows(), 40u);
  // A truth of another length: an error naming the file.
  const testing::CommandResult other = RunOslam("simulate-landmarks -o " + dir.Path("v") +
                                                " --poses 200 --landmarks 30 --blocks 2 --quiet");
  ASSERT_EQ(other.exit_code, 0) << other.err;
  EXPECT_EQ(other.out, "");
  const testing::CommandResult mismatch = RunOslam(
      "map --landmarks " + world + " --association " + dir.Path("w/true_association.txt") +
      " --truth-trajectory " + dir.Path("v/true_trajectory.csv") + " -o " + dir.Path("omap.json"));
  EXPECT_EQ(mismatch.exit_code, 1);
  EXPECT_NE(
      mismatch.err.find(dir.Path("v/true_trajectory.csv") + ": 200 poses for a data set of 300"),
      std::string::npos)
      << mismatch.err;
  EXPECT_EQ(RunOslam("simulate-landmarks -o " + dir.Path("u") + " --poses 0").exit_code, 2);
  EXPECT_EQ(RunOslam("simulate-landmarks --poses 10").exit_code, 2);  // no -o
}

// --unknown-association: the ids are hidden from the solve and used to score it.
TEST(LandmarkMapCommand, UnknownAssociationComparesWithTheIds) {
  testing::TempDir dir;
  const std::string common = "map --landmarks " + kData +
                             "gtsam_small.txt --unknown-association -o " + dir.Path("omap.json") +
                             " --seed 3";
  const testing::CommandResult run = RunOslam(common);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("tracks: 3 sightings -> "), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("window 1/1: 4 poses"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("pairwise agreement"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("landmarks"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("trajectory vs the file's association solved under the same noise: "
                         "RMSE"),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("duplicate landmarks joined"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("without its outlier sightings"), std::string::npos) << run.out;
  const OMap map = ReadOMap(dir.Path("omap.json"));
  EXPECT_GE(map.objects.size(), 2u);  // the two trees are 5 m apart: never one
  EXPECT_EQ(map.trajectory.size(), 4u);
  const testing::CommandResult quiet = RunOslam(common + " --quiet");
  EXPECT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.out, "");
  EXPECT_EQ(RunOslam(common + " --evaluation fast").exit_code, 2);
  EXPECT_EQ(RunOslam(common + " --track-gate 0").exit_code, 2);
  EXPECT_EQ(RunOslam(common + " --landmark-prior-std 0").exit_code, 2);
  EXPECT_EQ(RunOslam(common + " --landmark-density 0").exit_code, 2);  // no location prior
  EXPECT_EQ(RunOslam(common + " --landmark-density dense").exit_code, 2);
  const testing::CommandResult estimated = RunOslam(common + " --landmark-density auto");
  ASSERT_EQ(estimated.exit_code, 0) << estimated.err;
  EXPECT_NE(estimated.out.find("landmark density from the sightings: "), std::string::npos)
      << estimated.out;
  const testing::CommandResult known_estimated =
      RunOslam("map --landmarks " + kData + "gtsam_small.txt --landmark-density auto -o " +
               dir.Path("known.json"));
  ASSERT_EQ(known_estimated.exit_code, 0) << known_estimated.err;
  EXPECT_NE(known_estimated.out.find("landmark density from the sightings: "), std::string::npos)
      << known_estimated.out;
  EXPECT_EQ(RunOslam(common + " --landmark-density 1e-4 --landmark-prior-std 50").exit_code, 2);
  EXPECT_EQ(RunOslam(common + " --landmark-prior-std 50").exit_code, 0);  // the Gaussian instead
  EXPECT_EQ(RunOslam(common + " --min-track 0").exit_code, 2);
  EXPECT_EQ(RunOslam(common + " --joint-screen -1").exit_code, 2);
  EXPECT_EQ(RunOslam(common + " --joint-screen 0").exit_code, 0);
  EXPECT_EQ(RunOslam(common + " --threads -1").exit_code, 2);
  EXPECT_EQ(RunOslam(common + " --probation-windows -1").exit_code, 2);
  EXPECT_EQ(RunOslam(common + " --probation-gain nan").exit_code, 2);
  EXPECT_EQ(RunOslam(common + " --probation-windows 2 --probation-shift 0").exit_code, 0);
  const testing::CommandResult one_thread = RunOslam(common + " --threads 1");
  ASSERT_EQ(one_thread.exit_code, 0) << one_thread.err;
  EXPECT_EQ(ReadOMap(dir.Path("omap.json")).objects.size(), map.objects.size());
  EXPECT_EQ(RunOslam(common + " --poses -1").exit_code, 2);
  // --poses: a prefix; --association-out: one id per sighting of it.
  const testing::CommandResult prefix =
      RunOslam(common + " --poses 3 --association-out " + dir.Path("a.txt"));
  ASSERT_EQ(prefix.exit_code, 0) << prefix.err;
  EXPECT_EQ(ReadOMap(dir.Path("omap.json")).trajectory.size(), 3u);
  std::ifstream ids(dir.Path("a.txt"));
  int lines = 0;
  for (std::string line; std::getline(ids, line);) ++lines;
  EXPECT_GT(lines, 0);
  EXPECT_LE(lines, 3);  // the sightings of the first 3 poses
}

TEST(LandmarkMapCommand, BadInputAndUsage) {
  testing::TempDir dir;
  const testing::CommandResult bad =
      RunOslam("map --landmarks " + kData + "gtsam_bad_field.txt -o " + dir.Path("o.json"));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_EQ(bad.err,
            "oslam map: error: " + kData + "gtsam_bad_field.txt:3: y: 'five' is not a number\n");
  EXPECT_EQ(RunOslam("map --landmarks " + kData + "gtsam_small.txt").exit_code, 2);  // no -o
  EXPECT_EQ(RunOslam("map --landmarks " + kData + "gtsam_small.txt --format csv -o x").exit_code,
            2);
  EXPECT_EQ(RunOslam("map --landmarks " + kData + "gtsam_small.txt --landmark-prior-std -1 -o " +
                     dir.Path("o.json"))
                .exit_code,
            2);
  EXPECT_EQ(RunOslam("map --landmarks " + kData + "gtsam_small.txt --landmark-density -1 -o " +
                     dir.Path("o.json"))
                .exit_code,
            2);
  const testing::CommandResult help = RunOslam("map --landmarks x --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("--association"), std::string::npos);
}

}  // namespace
}  // namespace oslam

// The g2o, TORO and iSAM readers on small hand-made files (each format's
// own noise convention: information, TORO's order, square-root
// information), GTSAM's BR lines and load2D's noise orders, detection of the
// format, malformed lines named by file and line, and writing then reading
// back.
#include "slam/landmark_formats.h"

#include <cmath>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/LU>

#include "core/error.h"
#include "slam/landmark_factors.h"
#include "slam/landmark_slam.h"
#include "tests/test_util.h"

namespace oslam {
namespace {

const std::string kData = std::string(OSLAM_SOURCE_DIR) + "/tests/data/landmarks/";

template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string WriteFile(const testing::TempDir& dir, const std::string& name,
                      const std::string& text) {
  std::ofstream(dir.Path(name)) << text;
  return dir.Path(name);
}

TEST(G2oLandmarksTest, ReadsVerticesEdgesInformationAndPointSightings) {
  const LandmarkDataset data = ReadG2oLandmarks(kData + "g2o_small.g2o");
  EXPECT_EQ(data.format, "g2o");
  EXPECT_TRUE(data.has_landmark_ids);
  ASSERT_EQ(data.num_poses, 3);
  EXPECT_EQ(data.pose_ids, (std::vector<long>{0, 1, 2}));
  ASSERT_EQ(data.odometry.size(), 3u);
  // EDGE_SE2 carries the information matrix (upper triangle, row-major).
  Eigen::Matrix3d information;
  information << 100, 10, 0, 10, 400, 0, 0, 0, 2500;
  EXPECT_TRUE(data.odometry[1].covariance.isApprox(information.inverse(), 1e-12));
  EXPECT_DOUBLE_EQ(data.odometry[1].delta.theta, 0.5);
  EXPECT_EQ(data.odometry[2].from, 2);  // the loop closure
  EXPECT_EQ(data.odometry[2].to, 0);
  EXPECT_NEAR(data.dead_reckoning[2].x, 2.0, 1e-12);
  EXPECT_NEAR(data.dead_reckoning[2].y, 0.1, 1e-12);
  ASSERT_EQ(data.sightings.size(), 3u);
  const LandmarkSighting& s = data.sightings[0];
  EXPECT_TRUE(s.cartesian);
  EXPECT_EQ(s.landmark, 10);
  EXPECT_NEAR(s.range_m, std::hypot(3.0, 1.0), 1e-12);
  EXPECT_NEAR(s.bearing_rad, std::atan2(1.0, 3.0), 1e-12);
  Eigen::Matrix2d point_information;
  point_information << 25, 5, 5, 16;
  EXPECT_TRUE(s.xy_covariance.isApprox(point_information.inverse(), 1e-12));
  EXPECT_EQ(data.sightings[2].landmark, 11);
  EXPECT_EQ(data.sightings[2].line, 13);

  // Solved with the file's association: converged, every whitened residual
  // accounted for (cost = sum of the factors' squared errors / 2).
  LandmarkSlam slam;
  const LandmarkSlamResult result = slam.Solve(data, GivenAssociation(data));
  ASSERT_EQ(result.summary.termination, TerminationType::kConverged);
  ASSERT_EQ(result.landmarks.size(), 2u);
  double sum = 0;
  for (const LandmarkSighting& z : data.sightings)
    sum += SightingSquaredError(z, result.trajectory[z.pose],
                                result.landmarks[z.landmark == 10 ? 0 : 1].position_m,
                                data.sensor_offset_m);
  for (const RelativePoseMeasurement& e : data.odometry) {
    const Pose2 d = BetweenPoses(result.trajectory[e.from], result.trajectory[e.to]);
    const Eigen::Vector3d r(d.x - e.delta.x, d.y - e.delta.y, d.theta - e.delta.theta);
    sum += r.dot(e.covariance.inverse() * r);
  }
  EXPECT_NEAR(result.summary.final_cost, 0.5 * sum, 1e-6 * sum);
}

TEST(ToroGraphTest, ReadsTheInformationInToroOrder) {
  const LandmarkDataset data = ReadToroGraph(kData + "toro_small.graph");
  EXPECT_EQ(data.format, "toro");
  ASSERT_EQ(data.num_poses, 3);
  EXPECT_TRUE(data.sightings.empty());
  ASSERT_EQ(data.odometry.size(), 2u);
  // ff fs ss rr fr sr = 100 10 400 2500 5 7.
  Eigen::Matrix3d information;
  information << 100, 10, 5, 10, 400, 7, 5, 7, 2500;
  EXPECT_TRUE(data.odometry[0].covariance.isApprox(information.inverse(), 1e-12));
  // A pose graph solves (no landmarks).
  LandmarkSlam slam;
  EXPECT_TRUE(slam.Solve(data, GivenAssociation(data)).summary.IsUsable());
}

TEST(IsamLandmarksTest, ReadsSquareRootInformation) {
  const LandmarkDataset data = ReadIsamLandmarks(kData + "isam_small.txt");
  EXPECT_EQ(data.format, "isam");
  ASSERT_EQ(data.num_poses, 3);
  ASSERT_EQ(data.odometry.size(), 2u);
  Eigen::Matrix3d r;
  r << 10, 1, 0, 0, 20, 0, 0, 0, 50;
  EXPECT_TRUE(data.odometry[0].covariance.isApprox((r.transpose() * r).inverse(), 1e-12));
  ASSERT_EQ(data.sightings.size(), 2u);
  Eigen::Matrix2d r2;
  r2 << 5, 1, 0, 4;
  EXPECT_TRUE(data.sightings[0].cartesian);
  EXPECT_TRUE(data.sightings[0].xy_covariance.isApprox((r2.transpose() * r2).inverse(), 1e-12));
  EXPECT_EQ(data.sightings[1].pose, 1);
  EXPECT_EQ(data.sightings[1].landmark, 5);
}

TEST(GtsamLandmarksTest, BearingRangeLinesAndLoad2DNoiseOrders) {
  testing::TempDir dir;
  // The first ODOMETRY covariance is diagonal at entries 1, 3, 4: load2D's
  // TORO-ordered covariance (ff fs ss rr fr sr); the second, row-major.
  const std::string path = WriteFile(dir, "g.txt",
                                     "ODOMETRY 0 1 1 0 0 0.01 0 0.04 0.0025 0 0\n"
                                     "ODOMETRY 1 2 1 0 0 0.01 0 0 0.04 0 0.0025\n"
                                     "BR 1 7 0.25 12.5 0.01 0.2\n"
                                     "LANDMARK 2 7 3 1 0.5 0.1 0.2\n");
  const LandmarkDataset data = ReadGtsamLandmarks(path);
  ASSERT_EQ(data.odometry.size(), 2u);
  const Eigen::Vector3d diagonal(0.01, 0.04, 0.0025);
  EXPECT_TRUE(data.odometry[0].covariance.isApprox(Eigen::Matrix3d(diagonal.asDiagonal())));
  EXPECT_TRUE(data.odometry[1].covariance.isApprox(Eigen::Matrix3d(diagonal.asDiagonal())));
  ASSERT_EQ(data.sightings.size(), 2u);
  const LandmarkSighting& br = data.sightings[0];
  EXPECT_FALSE(br.cartesian);
  EXPECT_DOUBLE_EQ(br.bearing_rad, 0.25);
  EXPECT_DOUBLE_EQ(br.range_m, 12.5);
  EXPECT_DOUBLE_EQ(br.bearing_std_rad, 0.01);
  EXPECT_DOUBLE_EQ(br.range_std_m, 0.2);
  // An anisotropic LANDMARK covariance is kept as the point's covariance.
  EXPECT_TRUE(data.sightings[1].cartesian);
  EXPECT_DOUBLE_EQ(data.sightings[1].xy_covariance(0, 1), 0.1);
}

TEST(GtsamLandmarksTest, Load2DReadsVertex2AndEdge2AsOdometry) {
  // GTSAM's own .graph files (examples/Data/example.graph): VERTEX2 initial
  // estimates, EDGE2 with a TORO-ordered covariance, BR sightings.
  testing::TempDir dir;
  const std::string path = WriteFile(dir, "g.graph",
                                     "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nVERTEX2 2 2 0 0\n"
                                     "EDGE2 0 1 1 0 0 0.01 0 0.04 0.0025 0 0\n"
                                     "EDGE2 1 2 1 0 0 0.01 0 0.04 0.0025 0 0\n"
                                     "BR 0 144 0.2 9.1 0.03 0.1\nBR 2 144 0.5 7.5 0.03 0.1\n");
  EXPECT_EQ(DetectLandmarkFormat(path).format, LandmarkFormat::kGtsam);
  const LandmarkDataset data = ReadLandmarkDataset(path, LandmarkFormat::kGtsam);
  ASSERT_EQ(data.num_poses, 3);
  ASSERT_EQ(data.odometry.size(), 2u);
  const Eigen::Vector3d diagonal(0.01, 0.04, 0.0025);  // a covariance, as load2D reads it
  EXPECT_TRUE(data.odometry[1].covariance.isApprox(Eigen::Matrix3d(diagonal.asDiagonal())));
  ASSERT_EQ(data.sightings.size(), 2u);
  EXPECT_EQ(data.sightings[1].pose, 2);
  EXPECT_EQ(data.sightings[1].landmark, 144);
  LandmarkSlam slam;
  EXPECT_TRUE(slam.Solve(data, GivenAssociation(data)).summary.IsUsable());
  const std::string bad = WriteFile(dir, "b.graph", "EDGE2 0 1 1 0 0 1 0 1 1 0 0\nVERTEX2 1 0 0\n");
  EXPECT_NE(ErrorOf([&] { ReadGtsamLandmarks(bad); }).find(bad + ":2: expected 5 fields (VERTEX2"),
            std::string::npos);
}

TEST(ToroGraphTest, EquivalentNodesKeepTheirEdge) {
  // TORO's EQUIV (w100.graph in GTSAM's examples): poses 2 and 0 are one
  // place; the edge between them stays, with its own noise (GTSAM's reading).
  testing::TempDir dir;
  const std::string path = WriteFile(dir, "w.graph",
                                     "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nVERTEX2 2 0 0 0\n"
                                     "EDGE2 1 0 -1 0 0 1 0 1 1 0 0\n"
                                     "EDGE2 2 1 1 0 3.14159 1 0 1 1 0 0\n"
                                     "EDGE2 2 0 0.05 0 0 1 0 1 1 0 0\n"
                                     "EQUIV 2 0\n");
  EXPECT_EQ(DetectLandmarkFormat(path).format, LandmarkFormat::kToro);
  const LandmarkDataset data = ReadToroGraph(path);
  EXPECT_EQ(data.num_poses, 3);
  EXPECT_EQ(data.odometry.size(), 3u);
  const std::string bad = WriteFile(dir, "b.graph", "VERTEX2 0 0 0 0\nEQUIV 2\n");
  EXPECT_NE(ErrorOf([&] { ReadToroGraph(bad); }).find(bad + ":2:"), std::string::npos);
}

TEST(LandmarkFormatTest, DetectsTheFormatFromItsRecords) {
  EXPECT_EQ(DetectLandmarkFormat(kData + "g2o_small.g2o").format, LandmarkFormat::kG2o);
  EXPECT_EQ(DetectLandmarkFormat(kData + "toro_small.graph").format, LandmarkFormat::kToro);
  EXPECT_EQ(DetectLandmarkFormat(kData + "isam_small.txt").format, LandmarkFormat::kIsam);
  EXPECT_EQ(DetectLandmarkFormat(kData + "gtsam_small.txt").format, LandmarkFormat::kGtsam);
  testing::TempDir dir;
  // EDGE2 alone: the diagonal's place tells TORO from iSAM.
  EXPECT_EQ(
      DetectLandmarkFormat(WriteFile(dir, "t", "EDGE2 0 1 1 0 0 100 0 100 1000 0 0\n")).format,
      LandmarkFormat::kToro);
  EXPECT_EQ(DetectLandmarkFormat(WriteFile(dir, "i", "EDGE2 0 1 1 0 0 10 0 0 10 0 30\n")).format,
            LandmarkFormat::kIsam);
  EXPECT_NE(ErrorOf([&] {
              DetectLandmarkFormat(WriteFile(dir, "a", "EDGE2 0 1 1 0 0 10 1 2 10 1 30\n"));
            }).find("give the format"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              DetectLandmarkFormat(WriteFile(dir, "u", "# x\nPOSE 1 2 3\n"));
            }).find(":2: unknown record 'POSE'"),
            std::string::npos);
  std::filesystem::create_directories(dir.Path("raw"));
  std::ofstream(dir.Path("raw/measurements.dat")) << "0 1 1.5 0.2\n";
  EXPECT_EQ(DetectLandmarkFormat(dir.Path("raw")).format, LandmarkFormat::kVictoriaRaw);
  for (const char* name : {"gtsam", "g2o", "toro", "isam", "victoria-raw"})
    EXPECT_STREQ(LandmarkFormatName(*LandmarkFormatFromName(name)), name);
  EXPECT_FALSE(LandmarkFormatFromName("g2o3d"));
}

TEST(LandmarkFormatTest, MalformedLinesNameFileAndLine) {
  testing::TempDir dir;
  struct Case {
    LandmarkFormat format;
    std::string text, expected;
  };
  const std::vector<Case> cases = {
      {LandmarkFormat::kG2o, "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0\n",
       ":2: EDGE_SE2: expected 11 fields"},
      {LandmarkFormat::kG2o,
       "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 -1 0 1\n",
       ":3: the information matrix is not positive definite"},
      {LandmarkFormat::kG2o, "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 4 1 0 0 1 0 0 1 0 1\n",
       ":2: pose 4 has no vertex"},
      {LandmarkFormat::kG2o, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 x\n",
       ":2: theta: 'x' is not a number"},
      {LandmarkFormat::kG2o, "VERTEX_SE2 0 0 0 0\nEDGE_SE3:QUAT 0 1\n",
       ":2: unknown record 'EDGE_SE3:QUAT'"},
      {LandmarkFormat::kG2o, "VERTEX_SE2 0 0 0 0\nVERTEX_XY 5 1 1\nEDGE_SE2_XY 0 5 0 0 1 0 1\n",
       ":3: landmark at range 0"},
      {LandmarkFormat::kG2o,
       "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nVERTEX_SE2 2 0 0 0\n"
       "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n",
       "pose 2 has no odometry edge to an earlier pose"},
      {LandmarkFormat::kToro, "VERTEX2 0 0 0 0\nEDGE2 0 1 1 0 0 1 0 1 1 0\n",
       ":2: EDGE2: expected 11 fields"},
      {LandmarkFormat::kIsam, "EDGE2 0 1 1 0 0 1 0 0 0 0 1\n",
       ":1: the square-root information matrix has a zero on its diagonal"},
      {LandmarkFormat::kIsam, "EDGE2 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 0 -3 1 1 1 0 1\n",
       ":2: landmark l -3 is outside"},
      {LandmarkFormat::kGtsam, "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nBR 1 2 0.1 0 0.1 0.1\n",
       ":2: range must be > 0"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string path = WriteFile(dir, "case" + std::to_string(i), cases[i].text);
    const std::string message = ErrorOf([&] { ReadLandmarkDataset(path, cases[i].format); });
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(cases[i].expected), std::string::npos)
        << "case " << i << ": " << message;
  }
}

// docs/formats.md, Bounds: positions within +-1e5 m (vertices, increments,
// point sightings, and the odometry composed), angles within +-100 rad, ids
// up to 1e9; each error names the file and line (or the pose reached).
TEST(LandmarkFormatTest, ValuesBeyondThePhysicalBoundsNameFileAndLine) {
  testing::TempDir dir;
  struct Case {
    LandmarkFormat format;
    std::string text, expected;
  };
  const std::string pose01 = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";
  const std::string edge01 = "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";
  const std::vector<Case> cases = {
      {LandmarkFormat::kG2o, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1e300 0 0\n" + edge01,
       ":2: x: 1e+300 is outside [-100000, 100000] m"},
      {LandmarkFormat::kG2o, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 -2e5 0\n" + edge01,
       ":2: y: -200000 is outside [-100000, 100000] m"},
      {LandmarkFormat::kG2o, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 1e9\n" + edge01,
       ":2: theta: 1e+09 is outside [-100, 100] rad"},
      {LandmarkFormat::kG2o, pose01 + "VERTEX_XY 5 3e5 1\n" + edge01,
       ":3: x: 300000 is outside [-100000, 100000] m"},
      {LandmarkFormat::kG2o, pose01 + "EDGE_SE2 0 1 1e30 0 0 1 0 0 1 0 1\n",
       ":3: dx: 1e+30 is outside [-100000, 100000] m"},
      {LandmarkFormat::kG2o, pose01 + "EDGE_SE2 0 1 1 0 -1e7 1 0 0 1 0 1\n",
       ":3: dtheta: -1e+07 is outside [-100, 100] rad"},
      {LandmarkFormat::kG2o,
       pose01 + "VERTEX_XY 5 1 1\n" + edge01 + "EDGE_SE2_XY 0 5 0 1e300 1 0 1\n",
       ":5: y: 1e+300 is outside [-100000, 100000] m"},
      {LandmarkFormat::kG2o, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 2000000000 0 0 0\n",
       ":2: pose id 2e+09 is outside [0, 1e+09]"},
      {LandmarkFormat::kToro, "VERTEX2 0 0 0 0\nVERTEX2 1 -1e300 0 0\n",
       ":2: x: -1e+300 is outside [-100000, 100000] m"},
      {LandmarkFormat::kToro, "EDGE2 0 1 0 1e6 0 1 0 1 1 0 0\n",
       ":1: sideward: 1e+06 is outside [-100000, 100000] m"},
      {LandmarkFormat::kIsam, "EDGE2 0 1 1 0 300 1 0 0 1 0 1\n",
       ":1: dtheta: 300 is outside [-100, 100] rad"},
      {LandmarkFormat::kIsam, "EDGE2 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 1 3 1e300 1 1 0 1\n",
       ":2: x: 1e+300 is outside [-100000, 100000] m"},
      // Every increment within the bound, their sum beyond it.
      {LandmarkFormat::kIsam, "EDGE2 0 1 60000 0 0 1 0 0 1 0 1\nEDGE2 1 2 60000 0 0 1 0 0 1 0 1\n",
       ": the odometry reaches (120000, 0) m at pose 2, beyond the position bound"},
      {LandmarkFormat::kToro, "EDGE2 0 1 0 90000 0 1 0 1 1 0 0\nEDGE2 1 2 0 90000 0 1 0 1 1 0 0\n",
       ": the odometry reaches (0, 180000) m at pose 2, beyond the position bound"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string path = WriteFile(dir, "case" + std::to_string(i), cases[i].text);
    const std::string message = ErrorOf([&] { ReadLandmarkDataset(path, cases[i].format); });
    EXPECT_EQ(message.find(path + cases[i].expected), 0u) << "case " << i << ": " << message;
    EXPECT_NE(message.find("(docs/formats.md, Bounds)"), std::string::npos) << message;
  }
  // At the bounds themselves: read.
  const std::string edge = WriteFile(
      dir, "edge", "EDGE2 0 1 100000 -100000 100 1 0 0 1 0 1\nLANDMARK 1 3 1e5 -1e5 1 0 1\n");
  const LandmarkDataset data = ReadLandmarkDataset(edge, LandmarkFormat::kIsam);
  ASSERT_EQ(data.num_poses, 2);
  EXPECT_DOUBLE_EQ(data.odometry[0].delta.x, 1e5);
  EXPECT_DOUBLE_EQ(data.sightings[0].range_m, std::sqrt(2.0) * 1e5);
}

}  // namespace
}  // namespace oslam

// Readers of landmark data sets: GTSAM text format, raw Victoria Park
// (measurements + Ackermann inputs), GPS; malformed lines name file and line.
#include "slam/landmark_data.h"

#include <cmath>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/LU>

#include "core/angles.h"
#include "core/error.h"
#include "tests/test_util.h"

namespace oslam {
namespace {

const std::string kData = std::string(OSLAM_SOURCE_DIR) + "/tests/data/landmarks/";

// The message of the oslam::Error `f` throws ("" if none).
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

TEST(GtsamLandmarksTest, ReadsPosesOdometrySightingsAndLoopClosure) {
  const LandmarkDataset data = ReadGtsamLandmarks(kData + "gtsam_small.txt");
  EXPECT_EQ(data.format, "gtsam");
  EXPECT_TRUE(data.has_landmark_ids);
  ASSERT_EQ(data.num_poses, 4);
  EXPECT_EQ(data.pose_ids, (std::vector<long>{0, 1, 3, 4}));
  ASSERT_EQ(data.odometry.size(), 4u);
  EXPECT_EQ(data.odometry[1].from, 1);
  EXPECT_EQ(data.odometry[1].to, 2);  // file pose 3
  EXPECT_DOUBLE_EQ(data.odometry[1].delta.y, 0.1);
  EXPECT_DOUBLE_EQ(data.odometry[1].covariance(1, 1), 4e-6);
  EXPECT_EQ(data.odometry[3].from, 3);  // 4 -> 0: a loop closure, no new pose
  EXPECT_EQ(data.odometry[3].to, 0);
  // Dead reckoning composes the chain: pose 2 = (2, 0.1, 0.5).
  ASSERT_EQ(data.dead_reckoning.size(), 4u);
  EXPECT_NEAR(data.dead_reckoning[2].x, 2.0, 1e-12);
  EXPECT_NEAR(data.dead_reckoning[2].y, 0.1, 1e-12);
  EXPECT_NEAR(data.dead_reckoning[3].x, 2.0 + std::cos(0.5), 1e-12);

  ASSERT_EQ(data.sightings.size(), 3u);
  const LandmarkSighting& first = data.sightings[0];
  EXPECT_EQ(first.pose, 1);
  EXPECT_EQ(first.landmark, 2);
  EXPECT_NEAR(first.range_m, std::sqrt(50.0), 1e-12);
  EXPECT_NEAR(first.bearing_rad, kPi / 4, 1e-12);
  // GTSAM's load2D: bearing std sqrt(c11 / 10), range std sqrt(c11).
  EXPECT_NEAR(first.bearing_std_rad, std::sqrt(0.04), 1e-12);
  EXPECT_NEAR(first.range_std_m, std::sqrt(0.4), 1e-12);
  EXPECT_TRUE(std::isnan(first.diameter_m));
  EXPECT_EQ(first.line, 3);
  // Unequal c11, c22: carried to first order. Landmark straight ahead at 3 m:
  // range variance c11, bearing variance c22 / r^2.
  const LandmarkSighting& second = data.sightings[1];
  EXPECT_EQ(second.pose, 2);
  EXPECT_NEAR(second.range_std_m, std::sqrt(0.4), 1e-12);
  EXPECT_NEAR(second.bearing_std_rad, std::sqrt(0.9) / 3.0, 1e-12);
  EXPECT_EQ(GivenAssociation(data), (std::vector<int>{2, 2, 7}));
}

TEST(GtsamLandmarksTest, MalformedLinesNameFileAndLine) {
  const std::string bad = kData + "gtsam_bad_field.txt";
  EXPECT_EQ(ErrorOf([&] { ReadGtsamLandmarks(bad); }), bad + ":3: y: 'five' is not a number");
  EXPECT_EQ(ErrorOf([&] { ReadGtsamLandmarks(kData + "missing.txt"); }),
            kData + "missing.txt: cannot open the file");

  testing::TempDir dir;
  const std::string odometry = "ODOMETRY 0 1 1 0 0 0.0001 0 0 4e-06 0 4e-06\n";
  struct Case {
    std::string text, expected;
  };
  const Case cases[] = {
      {odometry + "ODOMETRY 1 2 1 0 0 0.0001 0 0\n", ":2: expected 12 fields"},
      {odometry + "LANDMARK 1 5 1 2 0.4 0\n", ":2: expected 8 fields"},
      {odometry + "POINT 1 5 1 2\n", ":2: unknown record 'POINT'"},
      {odometry + "ODOMETRY 7 8 1 0 0 0.0001 0 0 4e-06 0 4e-06\n",
       ":2: odometry starts at pose 7, which no earlier odometry line reaches"},
      {odometry + "ODOMETRY 1 2 1 0 0 -1 0 0 4e-06 0 4e-06\n", ":2: the odometry covariance"},
      {odometry + "ODOMETRY 1 2 1 0 nan 0.0001 0 0 4e-06 0 4e-06\n",
       ":2: dtheta: 'nan' is not finite"},
      {odometry + "LANDMARK 1 -5 1 2 0.4 0 0.4\n", ":2: landmark l must be >= 0"},
      {odometry + "LANDMARK 1 5 1 2 0.4 0 0\n", ":2: the landmark covariance"},
      {odometry + "\n# comment\nLANDMARK 9 5 1 2 0.4 0 0.4\n",
       ":4: landmark seen from pose 9, which no odometry line reaches"},
      {"# nothing\n", ": no data (empty file)"},
  };
  for (const Case& c : cases) {
    const std::string path = WriteFile(dir, "bad.txt", c.text);
    const std::string message = ErrorOf([&] { ReadGtsamLandmarks(path); });
    EXPECT_EQ(message.rfind(path + c.expected, 0), 0u) << message << "\nexpected " << c.expected;
  }
}

TEST(AckermannTest, StraightAndTurningMatchTheModel) {
  VictoriaRawOptions options;
  const RelativePoseMeasurement straight = IntegrateAckermann(2.0, 0.0, 1.5, options, 10);
  EXPECT_NEAR(straight.delta.x, 3.0, 1e-12);
  EXPECT_NEAR(straight.delta.y, 0.0, 1e-12);
  EXPECT_NEAR(straight.delta.theta, 0.0, 1e-12);
  // Constant steering: the rear-axle centre drives a circle of radius
  // L / tan(alpha) at speed v / (1 - tan(alpha) H / L).
  const double alpha = 0.2, v = 3.0, time = 4.0;
  const double t = std::tan(alpha), L = options.wheelbase_m, H = options.encoder_offset_m;
  const double vc = v / (1 - t * H / L), radius = L / t, heading = vc * time / radius;
  const RelativePoseMeasurement turn = IntegrateAckermann(v, alpha, time, options, 20000);
  EXPECT_NEAR(turn.delta.theta, WrapAngle(heading), 1e-9);
  EXPECT_NEAR(turn.delta.x, radius * std::sin(heading), 2e-3);
  EXPECT_NEAR(turn.delta.y, radius * (1 - std::cos(heading)), 2e-3);
  // The covariance is positive definite and grows with the distance driven.
  const RelativePoseMeasurement shorter = IntegrateAckermann(v, alpha, time / 2, options, 10000);
  EXPECT_GT(turn.covariance.determinant(), 0.0);
  EXPECT_GT(turn.covariance.trace(), shorter.covariance.trace());
}

TEST(AckermannTest, OneStepCovarianceIsTheInputNoiseCarriedByTheJacobian) {
  VictoriaRawOptions options;
  const double v = 2.5, alpha = -0.15, dt = 0.2;
  const RelativePoseMeasurement m = IntegrateAckermann(v, alpha, dt, options, 1);
  const auto f = [&](const Eigen::VectorXd& input) {
    const Pose2 d = IntegrateAckermann(input[0], input[1], dt, options, 1).delta;
    return Eigen::VectorXd(d.Vector());
  };
  const Eigen::MatrixXd g = testing::NumericJacobian(f, Eigen::Vector2d(v, alpha), 1e-6);
  const double speed_std = options.speed_std_fraction * v + options.speed_std_floor_mps;
  const Eigen::Matrix2d q =
      Eigen::Vector2d(speed_std * speed_std, options.steering_std_rad * options.steering_std_rad)
          .asDiagonal();
  Eigen::Matrix3d expected = g * q * g.transpose();
  expected.diagonal() += options.increment_std_floor.cwiseAbs2();
  EXPECT_LT((m.covariance - expected).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(VictoriaRawTest, OnePosePerScanOdometryBetweenScansAndLaserBearings) {
  const LandmarkDataset data =
      ReadVictoriaRaw(kData + "raw_measurements.dat", kData + "raw_inputs.dat");
  EXPECT_EQ(data.format, "victoria-raw");
  EXPECT_FALSE(data.has_landmark_ids);
  ASSERT_EQ(data.num_poses, 3);
  EXPECT_EQ(data.pose_times, (std::vector<double>{0.5, 1.5, 2.5}));
  EXPECT_TRUE(data.sensor_offset_m.isApprox(Eigen::Vector2d(3.78, 0.50)));
  ASSERT_EQ(data.odometry.size(), 2u);
  // 0.5 -> 1.5 s: straight at 2 m/s.
  EXPECT_NEAR(data.odometry[0].delta.x, 2.0, 1e-12);
  EXPECT_NEAR(data.odometry[0].delta.theta, 0.0, 1e-12);
  // 1.5 -> 2.5 s: 0.5 s at 2 m/s steering 0.1 rad, then standing still.
  const VictoriaRawOptions options;
  const double t = std::tan(0.1);
  const double distance = 0.5 * 2.0 / (1 - t * options.encoder_offset_m / options.wheelbase_m);
  EXPECT_NEAR(data.odometry[1].delta.x, distance, 1e-12);
  EXPECT_NEAR(data.odometry[1].delta.theta, distance * t / options.wheelbase_m, 1e-12);
  EXPECT_NEAR(data.dead_reckoning[2].x, 2.0 + distance, 1e-12);

  ASSERT_EQ(data.sightings.size(), 4u);
  EXPECT_EQ(data.sightings[1].pose, 0);
  EXPECT_EQ(data.sightings[2].pose, 1);
  EXPECT_EQ(data.sightings[3].pose, 2);
  EXPECT_NEAR(data.sightings[0].bearing_rad, 0.0, 1e-5);  // pi/2 in the laser = ahead
  EXPECT_NEAR(data.sightings[1].bearing_rad, 0.78540 - kPi / 2, 1e-12);
  EXPECT_DOUBLE_EQ(data.sightings[2].diameter_m, 0.4);
  EXPECT_EQ(data.sightings[2].landmark, -1);
  EXPECT_DOUBLE_EQ(data.sightings[2].range_std_m, options.range_std_m);

  VictoriaRawOptions gated;
  gated.min_range_m = 9.0;
  gated.max_range_m = 15.0;
  EXPECT_EQ(ReadVictoriaRaw(kData + "raw_measurements.dat", kData + "raw_inputs.dat", gated)
                .sightings.size(),
            2u);
}

TEST(VictoriaRawTest, MalformedLinesNameFileAndLine) {
  const std::string measurements = kData + "raw_measurements.dat";
  const std::string bad_inputs = kData + "raw_inputs_bad.dat";
  EXPECT_EQ(ErrorOf([&] { ReadVictoriaRaw(measurements, bad_inputs); }),
            bad_inputs + ":2: expected 3 fields (time speed steering), got 2");
  testing::TempDir dir;
  const std::string backwards = WriteFile(dir, "m.dat", "1.0 10 1.5 0.3\n0.5 10 1.5 0.3\n");
  EXPECT_EQ(ErrorOf([&] { ReadVictoriaRaw(backwards, kData + "raw_inputs.dat"); }),
            backwards + ":2: time goes backwards (0.5 s)");
  const std::string negative = WriteFile(dir, "n.dat", "1.0 -10 1.5 0.3\n");
  EXPECT_EQ(ErrorOf([&] { ReadVictoriaRaw(negative, kData + "raw_inputs.dat"); }),
            negative + ":1: negative range");
  const std::string sharp = WriteFile(dir, "i.dat", "0 1 0\n0.1 1 1.58\n");
  EXPECT_EQ(ErrorOf([&] { ReadVictoriaRaw(measurements, sharp); }),
            sharp + ":2: steering angle beyond +-pi/2");
}

TEST(GpsTest, ReadsFixesAndRejectsBadLines) {
  const std::vector<GpsFix> fixes = ReadGps(kData + "gps_small.dat");
  ASSERT_EQ(fixes.size(), 3u);
  EXPECT_DOUBLE_EQ(fixes[1].time_s, 1.001);
  EXPECT_DOUBLE_EQ(fixes[1].x_m, -2.066);
  EXPECT_DOUBLE_EQ(fixes[2].y_m, -2.028);
  testing::TempDir dir;
  const std::string bad = WriteFile(dir, "gps.dat", "0 1 2\n1 x 2\n");
  EXPECT_EQ(ErrorOf([&] { ReadGps(bad); }), bad + ":2: x: 'x' is not a number");
}

TEST(GpsTest, CompareAlignsRigidlyAndInterpolatesInTime) {
  // A trajectory along x at 1 m/s, poses every second; GPS in a frame turned
  // by 30 deg and shifted, fixes between poses, one 5 m outlier.
  std::vector<Pose2> trajectory;
  std::vector<double> times;
  for (int i = 0; i <= 20; ++i) {
    trajectory.push_back({static_cast<double>(i), 0.1 * i * i / 20.0, 0.0});
    times.push_back(10.0 + i);
  }
  const double angle = DegToRad(30), c = std::cos(angle), s = std::sin(angle);
  std::vector<GpsFix> gps;
  for (double t = 9.0; t <= 31.0; t += 0.5) {  // some before and after the poses
    const double u = t - 10.0;
    const double x = u, y = 0.1 *
                            (std::floor(u) * std::floor(u) +
                             (u - std::floor(u)) * (2 * std::floor(u) + 1)) /
                            20.0;
    gps.push_back({t, 100 + c * x - s * y, -50 + s * x + c * y});
  }
  GpsError exact = CompareWithGps(trajectory, times, gps);
  EXPECT_EQ(exact.num_fixes, 41);  // t = 10 .. 30
  EXPECT_LT(exact.rmse_m, 1e-9);
  EXPECT_NEAR(exact.rotation_rad, angle, 1e-9);
  EXPECT_NEAR(exact.translation_m.x(), 100, 1e-9);
  gps[20].x_m += 5.0;  // one outlier moves the max, hardly the median
  const GpsError outlier = CompareWithGps(trajectory, times, gps);
  EXPECT_GT(outlier.max_m, 4.5);
  EXPECT_LT(outlier.median_m, 0.2);
  // A gap longer than max_gap_s between two poses drops the fixes inside it.
  times.back() += 5.0;
  GpsComparisonOptions one_second;
  one_second.max_gap_s = 1.0;
  EXPECT_LT(CompareWithGps(trajectory, times, gps, one_second).num_fixes, 41);
  EXPECT_THROW(CompareWithGps(trajectory, {1.0}, gps), Error);
  GpsComparisonOptions bad;
  bad.max_gap_s = 0;
  EXPECT_THROW(CompareWithGps(trajectory, times, gps, bad), Error);
}

TEST(GpsTest, AntennaOffsetGivenOrEstimated) {
  // A winding drive (on a circle the offset would not be observable: a rigid
  // turn absorbs it) with the antenna 3.8 m ahead of and 0.5 m left of the
  // robot origin; GPS in a turned, shifted frame.
  std::vector<Pose2> trajectory;
  std::vector<double> times;
  std::vector<GpsFix> gps;
  const Eigen::Vector2d antenna(3.8, 0.5);
  const double angle = DegToRad(-40), c = std::cos(angle), s = std::sin(angle);
  for (int i = 0; i <= 100; ++i) {
    const double u = 0.5 * i;
    const double phi = std::atan(0.8 * std::cos(u / 5));  // heading of y = 4 sin(x / 5)
    const Pose2 pose{u, 4 * std::sin(u / 5), phi};
    trajectory.push_back(pose);
    times.push_back(i);
    const double x = pose.x + std::cos(phi) * antenna.x() - std::sin(phi) * antenna.y();
    const double y = pose.y + std::sin(phi) * antenna.x() + std::cos(phi) * antenna.y();
    gps.push_back({i + 0.0, 7 + c * x - s * y, 3 + s * x + c * y});
  }
  // The origin compared with the antenna: metres off, as no rigid alignment
  // can turn a lever arm that turns with the robot.
  EXPECT_GT(CompareWithGps(trajectory, times, gps).rmse_m, 0.5);
  GpsComparisonOptions given;
  given.antenna_offset_m = antenna;
  const GpsError at_mount = CompareWithGps(trajectory, times, gps, given);
  EXPECT_LT(at_mount.rmse_m, 1e-9);
  EXPECT_NEAR(at_mount.rotation_rad, angle, 1e-9);
  GpsComparisonOptions estimated;
  estimated.estimate_antenna_offset = true;
  estimated.antenna_offset_m = Eigen::Vector2d(-100, 100);  // ignored
  const GpsError fitted = CompareWithGps(trajectory, times, gps, estimated);
  EXPECT_LT(fitted.rmse_m, 1e-6);
  EXPECT_LT((fitted.antenna_offset_m - antenna).norm(), 1e-6);
  EXPECT_NEAR(fitted.rotation_rad, angle, 1e-6);
  EXPECT_NEAR(fitted.translation_m.x(), 7, 1e-6);
}

TEST(AssociationFileTest, OneIdPerSightingOrAnError) {
  EXPECT_EQ(ReadAssociation(kData + "raw_association.txt", 4), (std::vector<int>{0, 1, 0, -1}));
  EXPECT_EQ(ErrorOf([&] { ReadAssociation(kData + "raw_association.txt", 5); }),
            kData + "raw_association.txt: 4 ids for 5 sightings");
  testing::TempDir dir;
  const std::string bad = WriteFile(dir, "a.txt", "3\n-2\n");
  EXPECT_EQ(ErrorOf([&] { ReadAssociation(bad, 2); }),
            bad + ":2: '-2' is not a landmark id (integer >= -1)");
}

}  // namespace
}  // namespace oslam

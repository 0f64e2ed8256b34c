// Planar landmark SLAM data sets (docs/method.md §16): poses linked by relative-pose
// odometry, and range-bearing sightings of point landmarks (trees), with or
// without landmark ids. Two readers:
//
//  * GTSAM's text format (`victoria_park.txt`, docs/formats.md): lines
//      ODOMETRY i j dx dy dtheta c11 c12 c13 c22 c23 c33   (covariance, upper triangle)
//      LANDMARK i l x y c11 c12 c22                        (robot frame, covariance)
//      BR i l bearing range bearing_std range_std           (range-bearing)
//    read as GTSAM's load2D does: (x, y) -> bearing atan2(y, x), range |(x, y)|,
//    bearing std sqrt(c11 / 10) rad and range std sqrt(c11) m when c11 = c22;
//    otherwise a Cartesian sighting with that covariance (load2D uses 1 and 1
//    there); the odometry covariance in TORO's order when it is diagonal
//    there (load2D's automatic noise format). Landmark ids are kept.
//    g2o, TORO and iSAM files: slam/landmark_formats.h.
//  * The raw Victoria Park files (RFS-SLAM's `measurements.dat` + `inputs.dat`):
//    one pose per laser scan; the speed/steering inputs between two scans are
//    integrated with the Ackermann model below into a relative pose whose
//    covariance comes from the input noise; sightings have no ids but carry
//    the trunk diameter. `gps.dat` is read separately.
//
// Every malformed line throws oslam::Error "FILE:LINE: problem".
#pragma once

#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/pose2.h"

namespace oslam {

// Pose `to` seen from pose `from` (indices into the data set's poses).
struct RelativePoseMeasurement {
  int from = 0, to = 0;
  Pose2 delta;  // in from's frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
};

// One range-bearing detection, in the sensor frame (bearing 0 = the robot's
// heading, counter-clockwise positive).
struct LandmarkSighting {
  int pose = 0;       // index into the data set's poses
  int landmark = -1;  // id given by the file, -1 when unknown
  double range_m = 0, bearing_rad = 0;
  double range_std_m = 1, bearing_std_rad = 1;
  double diameter_m = std::numeric_limits<double>::quiet_NaN();  // NaN: not measured
  int line = 0;  // line of the source file, for messages
  // Cartesian sightings (g2o's EDGE_SE2_XY, iSAM's LANDMARK, GTSAM's LANDMARK
  // with an anisotropic covariance): the landmark measured at (x, y) in the
  // sensor frame with this covariance; range_m and bearing_rad hold the same
  // point in polar form (for placing and gating), the two stds are unused.
  bool cartesian = false;
  Eigen::Matrix2d xy_covariance = Eigen::Matrix2d::Identity();
};

struct LandmarkDataset {
  std::string path;    // the file read (raw: measurements.dat)
  std::string format;  // "gtsam" or "victoria-raw"
  int num_poses = 0;
  std::vector<long> pose_ids;      // the file's id of every pose (gtsam), or the scan number
  std::vector<double> pose_times;  // s; empty when the format has no times
  // Poses reached by the odometry chain from pose 0, composed: the initial
  // trajectory (pose 0 at the origin, heading 0).
  std::vector<Pose2> dead_reckoning;
  std::vector<RelativePoseMeasurement> odometry;
  std::vector<LandmarkSighting> sightings;
  Eigen::Vector2d sensor_offset_m = Eigen::Vector2d::Zero();  // (forward, left) in the robot frame
  bool has_landmark_ids = false;
};

// Mean diameter of the sightings `indices` that measured one; nullopt when
// none did.
std::optional<double> MeanMeasuredDiameter(const std::vector<LandmarkSighting>& sightings,
                                           const std::vector<int>& indices);

// GTSAM text format. Pose ids may have gaps; they become indices 0, 1, ... in
// the order the odometry reaches them (the first ODOMETRY line's i is pose 0).
// An ODOMETRY line must start from a pose reached before; one between two
// known poses is a loop closure. Throws oslam::Error "FILE:LINE: ...".
LandmarkDataset ReadGtsamLandmarks(const std::string& path);

// Vehicle and noise of the raw Victoria Park data (README of
// detections_no_ids; ACFR / RFS-SLAM values). The robot frame is the
// rear-axle centre; the encoder sits on the rear left wheel.
struct VictoriaRawOptions {
  double wheelbase_m = 2.83;                   // L
  double encoder_offset_m = 0.76;              // H
  Eigen::Vector2d laser_offset_m{3.78, 0.50};  // a forward, b left
  // Input noise, independent per input sample: speed std = fraction * |v| +
  // floor, steering std. Propagated through the integration (first order).
  double speed_std_fraction = 0.05;
  double speed_std_floor_mps = 0.1;
  double steering_std_rad = 0.035;  // 2 deg
  // Added to every increment's covariance (robot frame, std): keeps a
  // standstill's covariance positive definite and covers slip.
  Eigen::Vector3d increment_std_floor{0.005, 0.005, 0.001};
  // Laser noise (RFS-SLAM: sigma_r^2 = 0.025 m^2, sigma_b^2 = 2.5e-5 rad^2).
  double range_std_m = 0.158;
  double bearing_std_rad = 0.005;
  // Detections outside [min_range, max_range] are dropped (0 / inf: keep all).
  double min_range_m = 0.0;
  double max_range_m = std::numeric_limits<double>::infinity();

  bool Validate(std::string* why) const;
};

// measurements.dat (time range bearing diameter; bearing in the laser frame,
// pi/2 = straight ahead) and inputs.dat (time speed steering). One pose per
// distinct measurement time; pose 0 is the first scan. Throws oslam::Error
// "FILE:LINE: ..." (times must not decrease; inputs must cover the scans).
LandmarkDataset ReadVictoriaRaw(const std::string& measurements_path,
                                const std::string& inputs_path,
                                const VictoriaRawOptions& options = VictoriaRawOptions());

// The relative pose (in the start frame) and its covariance after driving
// with speed v (m/s, measured at the encoder) and steering angle alpha (rad)
// for dt seconds, integrated in `steps` Euler steps. Exposed for tests.
RelativePoseMeasurement IntegrateAckermann(double speed_mps, double steering_rad, double dt_s,
                                           const VictoriaRawOptions& options, int steps = 1);

struct GpsFix {
  double time_s = 0, x_m = 0, y_m = 0;
};
// gps.dat: time x y (local metric frame). Throws oslam::Error "FILE:LINE: ...".
std::vector<GpsFix> ReadGps(const std::string& path);

// A trajectory against GPS, after the least-squares rigid 2D alignment of
// the trajectory onto the fixes (GPS has its own frame): each fix is compared
// with the antenna's position, the pose interpolated linearly at the fix's
// time between the two poses around it plus the antenna's offset in the
// robot frame; fixes before the first or after the last pose time, or inside
// a gap between poses longer than max_gap_s, are skipped.
struct GpsComparisonOptions {
  double max_gap_s = 1.0;
  // Where the antenna sits in the robot frame: (forward, left), metres.
  Eigen::Vector2d antenna_offset_m = Eigen::Vector2d::Zero();
  // Estimate the offset with the alignment (least squares over both,
  // antenna_offset_m ignored): a mount that nobody documented still
  // compares the same point of the vehicle.
  bool estimate_antenna_offset = false;
  bool Validate(std::string* why) const;
};
struct GpsError {
  int num_fixes = 0;  // fixes compared
  double rmse_m = 0, median_m = 0, p95_m = 0, max_m = 0;
  double rotation_rad = 0;                                     // of the alignment
  Eigen::Vector2d translation_m = Eigen::Vector2d::Zero();     // p_gps = R p + t
  Eigen::Vector2d antenna_offset_m = Eigen::Vector2d::Zero();  // used or estimated
};
// Throws oslam::Error when the options are invalid, the sizes differ, the
// times decrease or fewer than 2 fixes (3 when estimating the offset) can be
// compared.
GpsError CompareWithGps(const std::vector<Pose2>& trajectory, const std::vector<double>& times_s,
                        const std::vector<GpsFix>& gps, const GpsComparisonOptions& options = {});

// The landmark ids of the sightings (the association the file gives), -1
// where unknown.
std::vector<int> GivenAssociation(const LandmarkDataset& data);

// An association file: one integer per line, the landmark id of sighting k
// on the k-th data line (ids >= 0, -1 = left out). Throws oslam::Error
// "FILE:LINE: ..." on a bad line, "FILE: ..." unless it has exactly
// `num_sightings` lines.
std::vector<int> ReadAssociation(const std::string& path, size_t num_sightings);

// The number in `token`, finite; throws oslam::Error "FILE:LINE: WHAT: ..."
// otherwise.
double ParseFiniteNumber(const std::string& path, int line, const std::string& token,
                         const char* what);

// Whitespace-separated text data (the GTSAM, Victoria Park, g2o, TORO and iSAM
// files): checks the file (CheckInputFile), then calls `row(line, tokens)`
// for every line that is not blank or a '#' comment. Throws oslam::Error
// naming the file when it cannot be read or holds no data.
void ForEachLandmarkRecord(const std::string& path,
                           const std::function<void(int, const std::vector<std::string>&)>& row);

}  // namespace oslam

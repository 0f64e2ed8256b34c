// The planar SLAM text formats beside GTSAM's (slam/landmark_data.h), read
// into a LandmarkDataset, written from one, and told apart (docs/formats.md,
// Landmark data sets):
//
//  * g2o 2D (types_slam2d): VERTEX_SE2 id x y theta, VERTEX_XY id x y,
//    EDGE_SE2 i j dx dy dtheta + the 3x3 *information* matrix (upper
//    triangle, row-major), EDGE_SE2_XY i j x y + the 2x2 information matrix,
//    FIX id;
//  * TORO: VERTEX2 id x y theta, EDGE2 i j dx dy dtheta + the information
//    matrix in TORO's order (ff fs ss rr fr sr);
//  * iSAM: ODOMETRY (or EDGE2) i j dx dy dtheta + the upper-triangular
//    *square-root information* matrix R (xx xy xt yy yt tt; information
//    R^T R), LANDMARK i l x y + its 2x2 R (xx xy yy).
//
// Relative poses are pose j in pose i's frame; landmark points are in pose
// i's frame (x forward, y left), read as Cartesian sightings. The vertices'
// estimates are not used: the start is the data set's own dead reckoning.
// Every malformed line throws oslam::Error "FILE:LINE: problem".
#pragma once

#include <optional>
#include <string>

#include "slam/landmark_data.h"

namespace oslam {

enum class LandmarkFormat { kGtsam, kG2o, kToro, kIsam, kVictoriaRaw };

// "gtsam", "g2o", "toro", "isam", "victoria-raw".
const char* LandmarkFormatName(LandmarkFormat format);
std::optional<LandmarkFormat> LandmarkFormatFromName(const std::string& name);

struct DetectedLandmarkFormat {
  LandmarkFormat format = LandmarkFormat::kGtsam;
  std::string reason;  // what in the file decided it
};

// The format of `path` from its records: a folder holding measurements.dat
// is victoria-raw; g2o's tags, TORO's VERTEX2, iSAM's EDGE2 with LANDMARK
// lines decide; EDGE2 alone is TORO or iSAM by where its diagonal noise
// entries sit; ODOMETRY lines are read as GTSAM's (the same records carry
// iSAM's square-root information: --format isam). Throws oslam::Error when
// nothing decides (naming the first line that does not fit).
DetectedLandmarkFormat DetectLandmarkFormat(const std::string& path);

LandmarkDataset ReadG2oLandmarks(const std::string& path);
LandmarkDataset ReadToroGraph(const std::string& path);
LandmarkDataset ReadIsamLandmarks(const std::string& path);

struct LandmarkReadOptions {
  std::string inputs_path;  // victoria-raw: inputs.dat (default: beside measurements.dat)
  VictoriaRawOptions raw;
};
// Any format; victoria-raw takes measurements.dat or its folder.
LandmarkDataset ReadLandmarkDataset(const std::string& path, LandmarkFormat format,
                                    const LandmarkReadOptions& options = LandmarkReadOptions());

// Writers (atomically; throw oslam::Error when the data set does not fit the
// format). Pose k is written with id k; landmarks need ids (has_landmark_ids).
// g2o and iSAM store points: a range-bearing sighting is written as its point
// with the range-bearing noise carried to (x, y) to first order. GTSAM keeps
// range-bearing sightings exact as BR lines (bearing range bearing_std
// range_std), Cartesian ones as LANDMARK lines. TORO holds the poses only.
// The sensor must sit at the robot's origin (these formats have no mount).
void WriteG2oLandmarks(const LandmarkDataset& data, const std::string& path);
void WriteToroGraph(const LandmarkDataset& data, const std::string& path);
void WriteIsamLandmarks(const LandmarkDataset& data, const std::string& path);
void WriteGtsamLandmarks(const LandmarkDataset& data, const std::string& path);
void WriteLandmarkDataset(const LandmarkDataset& data, LandmarkFormat format,
                          const std::string& path);

}  // namespace oslam

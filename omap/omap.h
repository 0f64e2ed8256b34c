// The O-Map (spec §2): objects with class, base point, cylinder size,
// covariance and existence probability, plus the estimated trajectory. Pure
// data: mapping produces it, export and evaluation consume it.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/pose2.h"

namespace oslam {

struct OMapObject {
  int id = 0;
  std::string class_name;                                  // most probable class
  Eigen::Vector3d base_world = Eigen::Vector3d::Zero();    // centre of the cylinder base, m
  double diameter_m = 0.0;
  double height_m = 0.0;
  double existence_probability = 1.0;                      // pi in (0, 1]
  // Covariance of (x, y, z, diameter, height); zero when unknown.
  Eigen::Matrix<double, 5, 5> covariance = Eigen::Matrix<double, 5, 5>::Zero();
  int num_detections = 0;
  // P(class | object is real) per class name, most probable first; may be empty.
  std::vector<std::pair<std::string, double>> class_histogram;
};

struct OMap {
  std::vector<OMapObject> objects;
  std::vector<Pose2> trajectory;  // estimated robot pose per frame, world frame
};

// Reads an O-Map JSON file (docs/omap-format.md). Throws oslam::Error naming
// the file and the field on anything malformed.
OMap ReadOMap(const std::string& path);

}  // namespace oslam

// The O-Map (docs/method.md §2): objects with class, base point, cylinder size,
// covariance and existence probability, plus the estimated trajectory, where
// the map came from and the reports of the method that made it. Pure data:
// mapping produces it (slam/, association/), export and evaluation consume
// it, omap_json.h reads and writes it.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/pose2.h"

namespace oslam {

// One identity of O-SLAM's samples: a set of tracks, and how many samples
// hold it.
struct OMapIdentity {
  std::vector<int> tracks;
  int num_samples = 0;
};

struct OMapObject {
  int id = 0;
  std::string class_name;                                // most probable class
  Eigen::Vector3d base_world = Eigen::Vector3d::Zero();  // centre of the cylinder base, m
  double diameter_m = 0.0;
  double height_m = 0.0;
  double existence_probability = 1.0;  // pi in [0, 1]
  // Covariance of (x, y, z, diameter, height); zero when unknown, NaN where
  // the estimate had no finite value.
  Eigen::Matrix<double, 5, 5> covariance = Eigen::Matrix<double, 5, 5>::Zero();
  // A panel's orientation: the world-frame direction of its width (the
  // diameter), modulo pi, rad (docs/method.md §4.2, "Panels"); absent for the
  // other shapes and in maps made without it.
  std::optional<double> yaw_rad;
  int num_detections = 0;
  // P(class | object is real) per class name, most probable first; empty
  // when the map was made with known classes.
  std::vector<std::pair<std::string, double>> class_histogram;
  // O-SLAM only (absent otherwise): the identity the object stands for (with
  // merged identities the union of their tracks, held by a sample holding
  // any of them), and the sample identities combined into it, most frequent
  // first.
  std::optional<OMapIdentity> identity;
  std::vector<OMapIdentity> identities;
};

// Where the map came from.
struct OMapSource {
  std::string run;          // run folder or data-set file
  std::string association;  // how detections became objects, e.g. "known (ground truth)"
  // The detections file given to O-SLAM ("" = the run folder's); absent for
  // maps made from other input.
  std::optional<std::string> detections;
  // Noise added to the simulator's true detections (known association);
  // absent for maps made from real detections, NaN when it does not apply
  // (landmark data sets).
  std::optional<double> pixel_noise_px;
  unsigned long seed = 0;
};

// A report of the method that made the map, written as the top-level JSON
// member `name` ("solver", "evidence", "sampler", ...). `json` is the
// member's value as JSON text: the layer that ran the method makes it, so
// omap/ carries it without knowing the method.
struct OMapReport {
  std::string name;
  std::string json;
};

struct OMap {
  std::vector<OMapObject> objects;
  std::vector<Pose2> trajectory;     // estimated robot pose per frame, world frame
  std::optional<OMapSource> source;  // absent in hand-made maps
  std::vector<OMapReport> reports;   // in the order they are written
  // What depends on the machine and the thread scheduling rather than on the
  // input and the seed (run times, rates, speculative solves undone by the
  // parallel chains): one member per report, under the same names. Left out
  // of omap.json unless asked for (OMapToJson), so that the same input and
  // seed give the same file.
  std::vector<OMapReport> timing;
};

// The report called `name`, or null.
const OMapReport* FindReport(const OMap& map, const std::string& name);

}  // namespace oslam

// Synthetic planar landmark worlds with ground truth (docs/method.md §16.4):
// a robot driving the streets of a city-block grid, or wandering through a
// park, with point landmarks (trees, posts) beside its way; noisy odometry,
// range-bearing sightings with misses and clutter, revisits. For tests and
// the scaling benchmarks of known and unknown association; written in the
// planar formats by slam/landmark_formats.h.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/pose2.h"
#include "slam/landmark_data.h"

namespace oslam {

enum class LandmarkWorldLayout {
  // Streets on a square grid of blocks; at every crossing the robot turns
  // left, right or goes on at random (never back), so it comes by the same
  // streets again. Landmarks on both sides of the streets.
  kCityGrid,
  // A square park: the robot drives smooth random curves, turning back
  // inside the border; landmarks anywhere in the park, clear of nothing.
  kPark,
};

struct LandmarkWorldOptions {
  LandmarkWorldLayout layout = LandmarkWorldLayout::kCityGrid;
  int num_poses = 1000;
  int num_landmarks = 100;
  double step_m = 1.0;  // distance driven between poses
  // City grid: blocks per side and their size (street to street); park: its
  // side is blocks * block_m.
  int blocks = 4;
  double block_m = 40;
  // Landmarks: city grid, this far from a street's centre line (uniform);
  // both layouts keep landmarks at least min_separation_m apart (0: any).
  double street_offset_min_m = 3, street_offset_max_m = 8;
  double min_separation_m = 2;
  // City grid: > 0 puts the landmarks on the points of a square lattice this
  // wide (those within the street offsets, chosen at random), a layout that
  // repeats itself: a re-entry off by one lattice step fits as well as the
  // true one (iSAM's cityTrees10000 has trees on a 5 m lattice). 0: anywhere.
  double lattice_m = 0;
  // Sensor at the robot's origin, facing ahead.
  double max_range_m = 15;
  double field_of_view_rad = 3.14159265358979;  // centred on the heading
  double range_std_m = 0.1;
  double bearing_std_rad = 0.01;
  double detection_probability = 0.9;  // of a landmark in view (misses)
  double clutter_per_scan = 0.05;      // Poisson mean of false detections, uniform in view
  // Odometry noise per step (forward, left, heading); the data set states
  // this covariance, so the model is the one the data come from.
  Eigen::Vector3d odometry_std{0.02, 0.01, 0.005};
  unsigned long seed = 1;

  bool Validate(std::string* why) const;
};

struct LandmarkWorld {
  // Sightings in scan order with their landmark ids: the true ones, and for
  // clutter a fresh id each (from num_landmarks on), so that the formats can
  // hold them; true_association says which are which.
  LandmarkDataset data;
  std::vector<int> true_association;  // per sighting: the landmark, -1 for clutter
  std::vector<Pose2> true_trajectory;
  std::vector<Eigen::Vector2d> true_landmarks;  // by id
};

// Throws oslam::Error on invalid options or when the landmarks cannot be
// placed that far apart.
LandmarkWorld SimulateLandmarkWorld(const LandmarkWorldOptions& options);

// The ground truth beside a written data set: `trajectory_csv` (pose,x_m,
// y_m,theta_rad), `landmarks_csv` (id,x_m,y_m) and `association_txt` (one id
// per sighting in file order, -1 for clutter: the --association format).
void WriteLandmarkWorldTruth(const LandmarkWorld& world, const std::string& trajectory_csv,
                             const std::string& landmarks_csv, const std::string& association_txt);

}  // namespace oslam

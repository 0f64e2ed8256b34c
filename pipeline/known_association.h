// Setup 1 input from a run folder (docs/method.md §3.3): detections are the simulator's
// true bounding slices (ground_truth/sightings.csv) with seeded Gaussian
// noise at the thesis level, associated by their object ids; classes from
// ground_truth/objects.csv; priors from classes.yaml; odometry.csv.
#pragma once

#include <string>
#include <vector>

#include "core/run_folder.h"
#include "slam/geometric_slam.h"

namespace oslam {

struct KnownAssociationOptions {
  double pixel_noise_px = 30.0;  // E: u_r gets E, u_phi E/u_r, s_r and s_phi sqrt(2) times that
  unsigned long seed = 1;
  double min_visible_fraction = 0.5;  // drop sightings of mostly occluded objects
  Eigen::Vector3d location_std_m{10.0, 10.0,
                                 2.0};  // Gamma(c) for every class (docs/method.md §5.1 [G])

  bool Validate(std::string* why) const;
};

struct KnownAssociationInput {
  GeometricSlamProblem problem;
  std::vector<std::string> class_names;
  GroundTruth truth;
  int skipped_sightings = 0;  // no class, occluded, or out of frames
};

// Throws oslam::Error naming the file and problem.
KnownAssociationInput LoadKnownAssociation(const std::string& run_dir,
                                           const KnownAssociationOptions& options);

}  // namespace oslam

// The three modes of `oslam map`, each declaring its own arguments:
//   (none)                O-SLAM on the run's detections, also `oslam slam`;
//   --known-association   geometric SLAM on the simulator's true slices;
//   --landmarks FILE      landmark SLAM on a range-bearing data set.
// -o and --quiet are common to all. Each mode binds its flags to its options
// structs in Declare and runs after Arguments::Parse has chosen it.
#pragma once

#include <string>

#include "apps/arguments.h"
#include "apps/bindings.h"
#include "pipeline/known_association.h"
#include "pipeline/landmark_association.h"
#include "pipeline/slam_stage.h"
#include "slam/geometric_slam.h"
#include "slam/landmark_data.h"
#include "slam/landmark_slam.h"

namespace oslam {

class SlamMode {
 public:
  // RUN_DIR, --detections and the O-SLAM parameters.
  void Declare(Arguments* arguments);
  int Run(const Arguments& arguments);

 private:
  SlamStageOptions options_;
  SlamStageInput input_;
  Bindings bindings_;
};

class KnownAssociationMode {
 public:
  // RUN_DIR, --known-association (the selector) and its parameters.
  void Declare(Arguments* arguments);
  int Run(const Arguments& arguments);

 private:
  KnownAssociationOptions input_;
  GeometricSlamOptions slam_;
  Bindings bindings_;
};

class LandmarkMode {
 public:
  // --landmarks FILE (the selector), the data set's options, the known
  // association's and --unknown-association's parameters.
  void Declare(Arguments* arguments);
  int Run(const Arguments& arguments);

 private:
  // The data set, the files written, and the solve's options.
  struct Options {
    std::string format = "auto";  // auto | gtsam | g2o | toro | isam | victoria-raw
    std::string inputs;           // victoria-raw: "" = inputs.dat beside the measurements
    std::string association;      // one landmark id per sighting; "" = the file's ids
    std::string association_out, trajectory, gps;
    std::string gps_antenna = "estimate";  // "estimate" or "FORWARD,LEFT" in metres
    std::string truth_trajectory;  // CSV pose,x_m,y_m[,theta_rad]: ATE printed
    std::string class_name = "tree";
    long poses = 0;  // the first N poses only (0: all)
    double odometry_noise_scale = 1;
    bool unknown_association = false;
    bool calibrate_noise = false;  // known association: variance components first
    LandmarkSlamOptions slam;      // known association; some shared with `unknown`
    UnknownAssociationOptions unknown;
  };
  int RunUnknownAssociation(const Arguments& arguments, const LandmarkDataset& data);
  // Sets the preset's flags (before the command line's); UsageError for an
  // unknown name.
  void ApplyPreset(const std::string& name);

  Options options_;
  Bindings bindings_;
};

}  // namespace oslam

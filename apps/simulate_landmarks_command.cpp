// oslam simulate-landmarks: a synthetic planar landmark world (method.md
// §16.4) written as a landmark data set with its ground truth beside it.
#include <cstdio>
#include <filesystem>

#include "apps/arguments.h"
#include "apps/bindings.h"
#include "apps/commands.h"
#include "core/error.h"
#include "slam/landmark_formats.h"
#include "slam/landmark_simulation.h"

namespace oslam {

int RunSimulateLandmarksCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam simulate-landmarks -o DIR [--layout city|park] [--poses N] [--landmarks N] "
      "[options]",
      "Simulates a robot driving a city-block grid or a park with point landmarks, range-bearing\n"
      "sightings (misses, clutter) and noisy odometry (docs/method.md §16.4). Writes\n"
      "DIR/world.<format> and the truth: DIR/true_trajectory.csv (pose,x_m,y_m,theta_rad),\n"
      "DIR/true_landmarks.csv (id,x_m,y_m) and DIR/true_association.txt (one id per sighting,\n"
      "-1 for clutter; the --association format of oslam map --landmarks).");
  LandmarkWorldOptions o;
  std::string format = "gtsam";
  Bindings b;
  b.AddChoice(&o.layout,
              {{"city", LandmarkWorldLayout::kCityGrid}, {"park", LandmarkWorldLayout::kPark}},
              "layout", "NAME", "city (a grid of streets) or park (random curves)");
  b.Add(&o.num_poses, "poses", "N", "poses, one per step");
  b.Add(&o.num_landmarks, "landmarks", "N", "point landmarks");
  b.Add(&o.step_m, "step", "M", "distance driven between poses");
  b.Add(&o.blocks, "blocks", "N", "city: blocks per side; park: its side in blocks");
  b.Add(&o.block_m, "block-size", "M", "a block's size (street to street)");
  b.Add(&o.min_separation_m, "separation", "M", "landmarks at least this far apart");
  b.Add(&o.lattice_m, "lattice", "M",
        "city: landmarks on the points of a square lattice this wide (0: anywhere)");
  b.Add(&o.odometry_std(0), "odometry-forward-std", "M", "odometry noise per step, forward (std)");
  b.Add(&o.odometry_std(1), "odometry-left-std", "M", "odometry noise per step, sideways (std)");
  b.Add(&o.odometry_std(2), "odometry-heading-std", "RAD",
        "odometry noise per step, heading (std)");
  b.Add(&o.max_range_m, "max-range", "M", "the sensor's range");
  b.Add(&o.range_std_m, "range-std", "M", "range noise (std)");
  b.Add(&o.bearing_std_rad, "bearing-std", "RAD", "bearing noise (std)");
  b.Add(&o.detection_probability, "detection", "P", "probability of seeing a landmark in view");
  b.Add(&o.clutter_per_scan, "clutter", "MEAN", "false detections per scan (Poisson mean)");
  b.Add(&o.seed, "seed", "N", "random seed");
  b.AddChoice<std::string>(&format, {{"gtsam", "gtsam"}, {"g2o", "g2o"}, {"isam", "isam"}},
                           "format", "NAME",
                           "gtsam (range-bearing BR lines), g2o or isam (points; docs/formats.md)");
  b.Declare(&arguments);
  arguments.AddOption("output", "-o", "DIR", "folder to write (created if needed)");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("missing -o DIR");
  b.Apply(arguments);
  std::string why;
  if (!o.Validate(&why)) throw UsageError(why);

  const std::filesystem::path dir = arguments.Get("output");
  if (std::filesystem::exists(dir) && !std::filesystem::is_directory(dir))
    throw Error::InFile(dir.string(), "exists and is not a folder");
  std::filesystem::create_directories(dir);
  const LandmarkWorld world = SimulateLandmarkWorld(o);
  const std::string data_path =
      (dir / ("world." + std::string(format == "g2o" ? "g2o" : "txt"))).string();
  WriteLandmarkDataset(world.data, *LandmarkFormatFromName(format), data_path);
  WriteLandmarkWorldTruth(world, (dir / "true_trajectory.csv").string(),
                          (dir / "true_landmarks.csv").string(),
                          (dir / "true_association.txt").string());
  if (!arguments.Flag("quiet")) {
    long clutter = 0;
    for (int id : world.true_association) clutter += id < 0;
    std::printf(
        "%d poses, %d landmarks, %zu sightings (%ld clutter); wrote %s and the truth in %s\n",
        world.data.num_poses, static_cast<int>(world.true_landmarks.size()),
        world.data.sightings.size(), clutter, data_path.c_str(), dir.string().c_str());
  }
  return 0;
}

}  // namespace oslam

// oslam map --landmarks FILE: planar landmark SLAM (issue 10) on a range-
// bearing data set, the association taken from the file's landmark ids
// (GTSAM format) or from an association file. Writes the O-Map (trees as
// objects) and the trajectory CSV.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "core/atomic_file.h"
#include "core/csv.h"
#include "core/error.h"
#include "mapping/landmark_data.h"
#include "mapping/landmark_slam.h"
#include "mapping/omap_json.h"

namespace oslam {

namespace {

std::string TrajectoryCsv(const LandmarkDataset& data, const LandmarkSlamResult& result) {
  std::ostringstream out;
  const bool times = static_cast<int>(data.pose_times.size()) == data.num_poses;
  out << "pose,pose_id," << (times ? "time_s," : "") << "x_m,y_m,theta_rad\n";
  for (int i = 0; i < data.num_poses; ++i) {
    const Pose2& p = result.trajectory[i];
    out << i << ',' << data.pose_ids[i] << ',';
    if (times) out << CsvNumber(data.pose_times[i]) << ',';
    out << CsvNumber(p.x) << ',' << CsvNumber(p.y) << ',' << CsvNumber(p.theta) << '\n';
  }
  return out.str();
}

}  // namespace

int RunLandmarkMapCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam map --landmarks FILE [--format gtsam|victoria-raw] -o OMAP.json [options]",
      "Landmark SLAM on a range-bearing data set (docs/formats.md, Landmark data sets) with "
      "the association its landmark ids (or --association) give; writes the O-Map (one 'tree' "
      "object per "
      "landmark) and the trajectory CSV.");
  arguments.AddOption("landmarks", "", "FILE",
                      "gtsam: the text file; victoria-raw: measurements.dat or its folder");
  arguments.AddOption("format", "", "NAME", "gtsam or victoria-raw", "gtsam");
  arguments.AddOption("inputs", "", "FILE",
                      "victoria-raw: speed/steering file (default: inputs.dat beside FILE)");
  arguments.AddOption("association", "", "FILE",
                      "one landmark id per sighting (-1: leave out) instead of the file's ids");
  arguments.AddOption("output", "-o", "OMAP.json", "where to write the O-Map (atomically)");
  arguments.AddOption("trajectory", "", "CSV",
                      "where to write the trajectory (default: trajectory.csv beside the O-Map)");
  arguments.AddOption("class", "", "NAME", "class name of the landmarks in the O-Map", "tree");
  arguments.AddOption("init-window", "", "POSES",
                      "staged initialisation window (0: start from dead reckoning)", "500");
  arguments.AddOption("landmark-prior-std", "", "M",
                      "std of a zero-mean location prior on every landmark (0: none; makes the "
                      "evidence comparable across associations)",
                      "0");
  arguments.AddFlag("pose-covariances", "also compute every pose's covariance (slower)");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("landmarks")) throw UsageError("give the data set with --landmarks FILE");
  if (!arguments.Has("output")) throw UsageError("give the output file with -o OMAP.json");
  const std::string format = arguments.Get("format");
  if (format != "gtsam" && format != "victoria-raw")
    throw UsageError("--format must be gtsam or victoria-raw, not '" + format + "'");
  if (arguments.GetInt("init-window") < 0) throw UsageError("--init-window must be >= 0");

  const std::string file = arguments.Get("landmarks");
  LandmarkDataset data;
  if (format == "gtsam") {
    data = ReadGtsamLandmarks(file);
  } else {
    namespace fs = std::filesystem;
    const fs::path measurements =
        fs::is_directory(file) ? fs::path(file) / "measurements.dat" : fs::path(file);
    const std::string inputs = arguments.Has("inputs")
                                   ? arguments.Get("inputs")
                                   : (measurements.parent_path() / "inputs.dat").string();
    data = ReadVictoriaRaw(measurements.string(), inputs);
  }
  std::vector<int> association;
  std::string association_source = "known (landmark ids in the file)";
  if (arguments.Has("association")) {
    association = ReadAssociation(arguments.Get("association"), data.sightings.size());
    association_source = "given (" + arguments.Get("association") + ")";
  } else if (data.has_landmark_ids) {
    association = GivenAssociation(data);
  } else {
    throw Error::InFile(data.path,
                        "the sightings have no landmark ids; give them with --association FILE "
                        "(the unknown-association solve is issue 10's next step)");
  }

  LandmarkSlamOptions options;
  options.initialisation_window_poses = static_cast<int>(arguments.GetInt("init-window"));
  options.compute_pose_covariances = arguments.Flag("pose-covariances");
  options.landmark_prior_std_m = arguments.GetDouble("landmark-prior-std");
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);
  LandmarkSlam slam(options);
  const LandmarkSlamResult result = slam.Solve(data, association);

  const std::string output = arguments.Get("output");
  const std::string trajectory_path =
      arguments.Has("trajectory")
          ? arguments.Get("trajectory")
          : (std::filesystem::path(output).parent_path() / "trajectory.csv").string();
  OMapSource source{data.path, association_source, std::nan(""), 0};
  WriteOMap(output, LandmarkResultAsOMap(result), {arguments.Get("class")}, source);
  WriteTextFileAtomically(trajectory_path, TrajectoryCsv(data, result));

  if (!arguments.Flag("quiet")) {
    const SolverSummary& s = result.summary;
    std::printf("%zu landmarks from %d sightings, %d poses (%s format)\n", result.landmarks.size(),
                result.num_sightings_used, data.num_poses, format.c_str());
    std::printf(
        "solver: %s (%s), %d iterations, cost %.6g -> %.6g (chi2 per residual %.3f), "
        "%.1f ms\n",
        TerminationName(s.termination), s.message.c_str(), s.iterations, s.initial_cost,
        s.final_cost, s.num_residuals > 0 ? 2.0 * s.final_cost / s.num_residuals : 0.0,
        1e3 * s.total_time_s);
    std::printf("total %.1f ms (staged initialisation %.1f ms)\n", 1e3 * result.total_time_s,
                1e3 * result.initialisation_time_s);
    if (result.evidence.valid) std::printf("log evidence %.3f\n", result.evidence.log_evidence);
    std::printf("trajectory %.1f m (dead reckoning %.1f m)\n", TrajectoryLength(result.trajectory),
                TrajectoryLength(data.dead_reckoning));
    std::printf("wrote %s and %s\n", output.c_str(), trajectory_path.c_str());
  }
  return result.summary.IsUsable() ? 0 : 1;
}

}  // namespace oslam

#include "pipeline/known_association.h"

#include <cmath>
#include <map>
#include <random>

#include "core/angles.h"
#include "core/error.h"

namespace oslam {

bool KnownAssociationOptions::Validate(std::string* why) const {
  if (!(pixel_noise_px >= 0) || !std::isfinite(pixel_noise_px)) {
    if (why) *why = "the pixel noise must be >= 0";
    return false;
  }
  if (!(location_std_m.minCoeff() > 0) || !location_std_m.allFinite()) {
    if (why) *why = "the location prior standard deviations must be positive (a proper prior)";
    return false;
  }
  return true;
}

KnownAssociationInput LoadKnownAssociation(const std::string& run_dir,
                                           const KnownAssociationOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error(why);
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  KnownAssociationInput input;
  const std::vector<ObjectClass> classes = ReadClasses(paths.classes);
  for (const ObjectClass& c : classes) {
    if (!(c.diameter_std_m > 0) || !(c.height_std_m > 0))
      throw Error::InFile(paths.classes, "class '" + c.name +
                                             "': the size prior needs positive standard "
                                             "deviations (a proper prior)");
    ClassPrior prior;
    prior.name = c.name;
    prior.size_mean_m = {c.diameter_mean_m, c.height_mean_m};
    prior.size_std_m = {c.diameter_std_m, c.height_std_m};
    prior.location_std_m = options.location_std_m;
    input.problem.classes.push_back(prior);
    input.class_names.push_back(c.name);
  }
  const Odometry odometry = ReadOdometry(paths.odometry);
  input.problem.increments = odometry.increments;
  input.problem.first_pose = odometry.poses.front();
  auto truth = ReadGroundTruth(run_dir);
  if (!truth)
    throw Error::InFile(paths.ground_truth,
                        "missing: --known-association needs the simulator's ground truth");
  input.truth = *truth;

  std::map<int, int> class_of_object;
  for (const GroundTruthObject& object : input.truth.objects) {
    if (object.class_name.empty()) continue;  // distractor: no detector fires on it
    const int index = FindClass(classes, object.class_name);
    if (index < 0)
      throw Error::InFile(paths.ground_truth + "/objects.csv",
                          "object " + std::to_string(object.id) + " has class '" +
                              object.class_name + "' not in classes.yaml");
    class_of_object[object.id] = index;
  }
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double e = options.pixel_noise_px, e2 = std::sqrt(2.0) * e;
  const long frames = static_cast<long>(input.problem.increments.size());
  for (const GroundTruthSighting& sighting : input.truth.sightings) {
    const auto found = class_of_object.find(sighting.object_id);
    if (found == class_of_object.end() ||
        sighting.visible_fraction < options.min_visible_fraction || sighting.frame < 0 ||
        sighting.frame >= frames || !(sighting.u_r_px > 0)) {
      ++input.skipped_sightings;
      continue;
    }
    BoundingSlice slice{sighting.u_r_px, sighting.u_phi_rad, sighting.s_r_px, sighting.s_phi_rad};
    // Same noise model the factor assumes (docs/method.md §4.2): R on u, W = 2R on s.
    const double ur = slice.u_r_px;
    slice.u_r_px += e * normal(rng);
    slice.u_phi_rad = WrapAngle(slice.u_phi_rad + e / ur * normal(rng));
    slice.s_r_px += e2 * normal(rng);
    slice.s_phi_rad += e2 / ur * normal(rng);
    if (!(slice.u_r_px > 1.0)) {
      ++input.skipped_sightings;
      continue;
    }
    input.problem.observations.push_back({sighting.frame, sighting.object_id, slice});
    input.problem.object_class[sighting.object_id] = found->second;
  }
  return input;
}

}  // namespace oslam

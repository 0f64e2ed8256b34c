// The O-Map's object geometry from the whole pipeline (issue of docs/results.md,
// "Object geometry"): the shipped lab scene rendered, colours and confusion
// learnt from its ground truth as scripts/quickstart.sh does, then `oslam run`.
// The thesis' section model left every object below the camera too tall and
// its base below the floor, and the door, cut by the mirror's rim, 0.85 m short;
// the door's width needs its orientation (docs/method.md §4.2, "Panels").
#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "core/run_folder.h"
#include "omap/evaluation.h"
#include "omap/omap_json.h"
#include "pipeline/simulated_run.h"

namespace oslam {
namespace {

using testing::Oslam;

TEST(ObjectGeometry, LabHeightsAreUnbiasedAndBasesOnTheFloor) {
  testing::TempDir dir;
  const std::string run = dir.Path("lab"), out = dir.Path("out");
  const std::string scene = std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/lab.yaml";
  ASSERT_EQ(Oslam("simulate " + scene + " -o " + run + " --seed 1 --quiet").exit_code, 0);
  ASSERT_EQ(Oslam("train-colors " + run + "/classes.yaml --from-ground-truth " + run + " --quiet")
                .exit_code,
            0);
  ASSERT_EQ(Oslam("detect " + run + " -o " + run + "/training.csv --quiet").exit_code, 0);
  ASSERT_EQ(Oslam("eval-detect " + run + " --detections " + run + "/training.csv " +
                  "--write-confusion " + run + "/classes.yaml --quiet")
                .exit_code,
            0);
  ASSERT_EQ(Oslam("run " + run + " -o " + out + " --seed 1 --quiet").exit_code, 0);

  const OMap map = ReadOMap(out + "/omap.json");
  const std::optional<GroundTruth> truth = ReadGroundTruth(run);
  ASSERT_TRUE(truth);
  const Odometry odometry = ReadOdometry(RunFolderPaths::Of(run).odometry);
  const MapMetrics metrics = EvaluateMap(map, odometry.poses, *truth);
  ASSERT_EQ(metrics.true_objects_found, 7);
  std::map<int, const OMapObject*> by_id;
  for (const OMapObject& object : map.objects) by_id[object.id] = &object;
  std::map<int, const GroundTruthObject*> true_by_id;
  for (const GroundTruthObject& object : truth->objects) true_by_id[object.id] = &object;
  double signed_height = 0;
  for (const ObjectMatch& match : metrics.matches) {
    const GroundTruthObject& object = *true_by_id.at(match.true_id);
    signed_height += match.height_error_m / metrics.matches.size();
    // Every height within 15 % (the door's top is beyond the mirror's rim)
    // and every base on the floor within 5 cm.
    EXPECT_LT(std::abs(match.height_error_m), 0.15 * object.height_m) << object.class_name;
    EXPECT_LT(std::abs(by_id.at(match.map_id)->base_world.z()), 0.05) << object.class_name;
    // The door, a flat panel seen from its front only: with its orientation
    // estimated its width is within 10 % (the mean extent over the half
    // space gave 1.34 m for 1.04).
    if (object.shape == "panel") {
      EXPECT_LT(std::abs(match.diameter_error_m), 0.1 * object.diameter_m) << object.class_name;
    }
  }
  // The bias: today's noise averages to within 3 cm over the seven objects.
  EXPECT_LT(std::abs(signed_height), 0.03);
  EXPECT_LT(metrics.height_error_mean_m, 0.05);
}

}  // namespace
}  // namespace oslam

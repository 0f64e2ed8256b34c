// The classes goal end to end on a look-alike scene (tests/data/look_alikes.yaml:
// an orange ball and a 0.30 x 0.35 m orange bucket of one colour): train,
// detect, measure the confusion, O-SLAM. By colour alone the detector labels
// both objects both ways, and the size priors favour "ball" for the bucket;
// with the learnt image shapes the confusion is informative and O-SLAM maps
// each object with its own class.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "core/run_folder.h"
#include "omap/omap_json.h"
#include "test_util.h"

namespace oslam {
namespace {

testing::CommandResult Oslam(const std::string& arguments) {
  return testing::RunShellCommand(std::string(OSLAM_BINARY) + " " + arguments + " --quiet");
}

void ExpectSuccess(const std::string& arguments) {
  const testing::CommandResult result = Oslam(arguments);
  ASSERT_EQ(result.exit_code, 0) << arguments << ": " << result.err;
}

// P(detected c | true c) for both classes, after measuring the confusion on `detections`.
std::pair<double, double> OwnClassShares(const std::string& run, const std::string& detections) {
  ExpectSuccess("eval-detect " + run + " --detections " + detections + " --write-confusion " + run +
                "/classes.yaml");
  const ConfusionMatrix confusion = *ReadConfusion(run + "/classes.yaml");
  return {confusion[0][0], confusion[1][1]};
}

TEST(LookAlikePipeline, ImageShapesLetOSlamMapTheSameColouredBallAndBucketRight) {
  testing::TempDir dir;
  const std::string run = dir.Path("run");
  ExpectSuccess("simulate " + std::string(OSLAM_SOURCE_DIR) + "/tests/data/look_alikes.yaml -o " +
                run);
  ExpectSuccess("train-colors " + run + "/classes.yaml --from-ground-truth " + run);

  ExpectSuccess("detect " + run + " --keep-look-alikes --max-view-distance inf -o " + run +
                "/colour_only.csv");
  const auto [ball_colour_only, bucket_colour_only] = OwnClassShares(run, run + "/colour_only.csv");
  EXPECT_LT(ball_colour_only, 0.7);
  EXPECT_LT(bucket_colour_only, 0.7);

  ExpectSuccess("detect " + run);
  const auto [ball, bucket] = OwnClassShares(run, run + "/detections.csv");
  EXPECT_GT(ball, 0.9);
  EXPECT_GT(bucket, 0.9);

  ExpectSuccess("slam " + run + " -o " + dir.Path("omap.json") + " --seed 1");
  const OMap omap = ReadOMap(dir.Path("omap.json"));
  const GroundTruth truth = *ReadGroundTruth(run);
  for (const GroundTruthObject& object : truth.objects) {
    SCOPED_TRACE(object.class_name);
    int found = 0;
    for (const OMapObject& mapped : omap.objects) {
      if (mapped.existence_probability <= 0.5) continue;
      if (std::hypot(mapped.base_world.x() - object.base_world.x(),
                     mapped.base_world.y() - object.base_world.y()) > 0.3)
        continue;
      ++found;
      EXPECT_EQ(mapped.class_name, object.class_name);
    }
    EXPECT_EQ(found, 1);
  }
}

}  // namespace
}  // namespace oslam

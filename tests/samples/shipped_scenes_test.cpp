// Renders the shipped scenes end to end (slow: about a minute on 2 cores) and
// checks they deliver what they are for.
#include <map>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "core/run_folder.h"
#include "samples/simulator.h"
#include "test_util.h"

namespace oslam {
namespace {

struct Rendered {
  Scene scene;
  SimulationSummary summary;
  GroundTruth truth;
};

Rendered RenderScene(const std::string& name, const testing::TempDir& dir) {
  Rendered r{
      LoadScene(std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/" + name + ".yaml"), {}, {}};
  SimulationOptions options;
  options.seed = r.scene.seed;
  r.summary = Simulate(r.scene, dir.Path(name), options);
  r.truth = *ReadGroundTruth(dir.Path(name));
  return r;
}

// Sightings per class where at least half the object is visible.
std::map<std::string, int> GoodSightingsPerClass(const GroundTruth& truth) {
  std::map<std::string, int> count;
  for (const GroundTruthSighting& s : truth.sightings)
    if (s.visible_fraction > 0.5) ++count[truth.objects.at(s.object_id).class_name];
  return count;
}

void ExpectEveryClassSeen(const Rendered& r, int at_least) {
  const std::map<std::string, int> count = GoodSightingsPerClass(r.truth);
  for (const ObjectClass& c : r.scene.classes) {
    const auto it = count.find(c.name);
    EXPECT_TRUE(it != count.end() && it->second >= at_least) << c.name;
  }
}

TEST(ShippedScenes, LabShowsEveryTable62ClassAlongAStopAndGoLoop) {
  testing::TempDir dir;
  const Rendered lab = RenderScene("lab", dir);
  EXPECT_EQ(lab.summary.frames, 150);
  EXPECT_EQ(lab.scene.classes.size(), 7u);
  ExpectEveryClassSeen(lab, 50);
}

TEST(ShippedScenes, LongLoopClosesALargeLoopThroughADarkCorridor) {
  testing::TempDir dir;
  const Rendered loop = RenderScene("long_loop", dir);
  EXPECT_EQ(loop.scene.classes.size(), 9u);
  EXPECT_GT(loop.summary.path_length_m, 25.0);
  const Pose2& start = loop.truth.trajectory.front();
  double farthest = 0.0;
  for (const Pose2& p : loop.truth.trajectory)
    farthest = std::max(farthest, std::hypot(p.x - start.x, p.y - start.y));
  EXPECT_GT(farthest, 7.0);
  ExpectEveryClassSeen(loop, 20);
  // Distractors are seen too (they are what makes detections spurious).
  EXPECT_GT(GoodSightingsPerClass(loop.truth)[""], 200);

  // The corridor (outside the lab's x, y in [-3, 3]) is darker than the lab.
  const FrameSource frames(dir.Path("long_loop"));
  double lab_sum = 0, corridor_sum = 0;
  int lab_n = 0, corridor_n = 0;
  for (size_t i = 0; i < frames.size(); i += 5) {
    const Pose2& p = loop.truth.trajectory[i];
    const double mean = cv::mean(frames.Read(i))[1];
    const bool in_lab = std::abs(p.x) < 2.5 && std::abs(p.y) < 2.5;
    const bool in_corridor = p.x > 4.0 || p.y > 4.0;
    if (in_lab) lab_sum += mean, ++lab_n;
    if (in_corridor) corridor_sum += mean, ++corridor_n;
  }
  ASSERT_GT(lab_n, 5);
  ASSERT_GT(corridor_n, 5);
  EXPECT_LT(corridor_sum / corridor_n, 0.8 * lab_sum / lab_n);
}

TEST(ShippedScenes, HouseShowsTheTable61FurnitureWithTheCognironCamera) {
  testing::TempDir dir;
  const Rendered house = RenderScene("house", dir);
  EXPECT_EQ(house.scene.classes.size(), 14u);
  EXPECT_EQ(house.scene.camera->image_width(), 800);
  ExpectEveryClassSeen(house, 20);
}

}  // namespace
}  // namespace oslam

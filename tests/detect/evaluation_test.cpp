// Detection evaluation: the class-confusion counts and the confusion matrix
// measured from them (what O-SLAM's class model reads).
#include "detect/evaluation.h"

#include <gtest/gtest.h>

namespace oslam {
namespace {

Detection DetectionAt(long frame, int class_index, double u_r_px, double u_phi_rad) {
  Detection d;
  d.frame = frame;
  d.class_index = class_index;
  d.slice.u_r_px = u_r_px;
  d.slice.u_phi_rad = u_phi_rad;
  d.slice.s_r_px = 20;
  d.slice.s_phi_rad = 0.1;
  d.area_px = 100;
  return d;
}

// Two objects: a "ball" (class 0) and a "door" (class 1). The ball detector
// also fires on the door in every frame, the door detector only on the door.
TEST(DetectionEvaluation, CountsDetectionsOnObjectsOfAnotherClassAsConfusions) {
  std::vector<ObjectClass> classes(3);
  classes[0].name = "ball";
  classes[1].name = "door";
  classes[2].name = "box";  // never detected
  GroundTruth truth;
  truth.objects.resize(2);
  truth.objects[0] = {0, "ball", "sphere", Eigen::Vector3d(1, 0, 0)};
  truth.objects[1] = {1, "door", "panel", Eigen::Vector3d(0, 1, 0)};
  std::vector<Detection> detections;
  for (long frame = 0; frame < 4; ++frame) {
    truth.trajectory.push_back(Pose2());
    truth.sightings.push_back({frame, 0, 100.0, 0.0, 20.0, 0.1});
    truth.sightings.push_back({frame, 1, 150.0, 1.5, 40.0, 0.3});
    detections.push_back(DetectionAt(frame, 0, 101.0, 0.01));  // ball on the ball
    detections.push_back(DetectionAt(frame, 0, 152.0, 1.52));  // ball on the door
    detections.push_back(DetectionAt(frame, 1, 151.0, 1.49));  // door on the door
  }
  detections.push_back(DetectionAt(0, 1, 60.0, -2.0));  // door on nothing: not a confusion

  const DetectionEvaluation evaluation = EvaluateDetections(detections, truth, classes);
  const std::vector<std::vector<int>> expected{{4, 0, 0}, {4, 4, 0}, {0, 0, 0}};
  EXPECT_EQ(evaluation.confusion_counts, expected);
  EXPECT_EQ(evaluation.per_class[0].confused, 4);
  EXPECT_EQ(evaluation.per_class[1].spurious, 1);

  const double floor = 1e-3;
  const auto confusion = ConfusionFromCounts(evaluation.confusion_counts, floor);
  ASSERT_EQ(confusion.size(), 3u);
  for (const auto& row : confusion) {
    double sum = 0;
    for (double p : row) {
      EXPECT_GE(p, floor * 0.99);
      sum += p;
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
  }
  EXPECT_NEAR(confusion[1][0], 0.5, 2e-3);  // P(ball | door)
  EXPECT_NEAR(confusion[1][1], 0.5, 2e-3);  // P(door | door)
  EXPECT_GT(confusion[0][0], 0.99);         // P(ball | ball)
  EXPECT_GT(confusion[2][2], 0.99);         // never detected: identity row
}

}  // namespace
}  // namespace oslam

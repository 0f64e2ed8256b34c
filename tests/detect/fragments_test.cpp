// Fragments of one blob (BlobDetectorOptions::join_fragments, drop_fragments;
// docs/method.md §10.5) on tests/data/fragments.yaml: a drum whose vertical
// stripes cut its colour blob into pieces, and two balls of one class side
// by side.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <utility>

#include <gtest/gtest.h>

#include "calib/camera_io.h"
#include "detect/blob_detector.h"
#include "detect/colour_training.h"
#include "detect/evaluation.h"
#include "detect/trained_classes.h"
#include "samples/scene.h"
#include "samples/simulator.h"
#include "test_util.h"

namespace oslam {
namespace {

class FragmentsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    run_ = dir_->Path("run");
    Simulate(LoadScene(std::string(OSLAM_SOURCE_DIR) + "/tests/data/fragments.yaml"), run_, {});
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }

  struct Outcome {
    std::vector<Detection> detections;
    DetectionEvaluation evaluation;
    std::vector<ClassSliceErrors> slice_errors;
    // Frames with more than one detection of a class, per class name.
    std::map<std::string, int> frames_with_pieces;
  };

  static Outcome Detect(const BlobDetectorOptions& options) {
    const std::unique_ptr<CameraModel> camera = LoadCamera(run_ + "/camera.yaml");
    const std::vector<ObjectClass> classes = ClassesTrainedOnGroundTruth(run_);
    const GroundTruth truth = *ReadGroundTruth(run_);
    const FrameSource frames(run_);
    const BlobDetector detector(*camera, classes, options);
    Outcome outcome;
    for (size_t i = 0; i < frames.size(); ++i) {
      std::map<int, int> per_class;
      for (const Detection& d : detector.Detect(frames.Read(i), static_cast<long>(i))) {
        outcome.detections.push_back(d);
        ++per_class[d.class_index];
      }
      for (const auto& [c, count] : per_class)
        if (count > 1) ++outcome.frames_with_pieces[classes[c].name];
    }
    outcome.evaluation = EvaluateDetections(outcome.detections, truth, classes);
    outcome.slice_errors = SignedSliceErrorsPerClass(outcome.detections, truth,
                                                     ReadVisibleSlices(run_), classes, *camera);
    return outcome;
  }

  static int Pieces(const Outcome& outcome, const std::string& name) {
    const auto found = outcome.frames_with_pieces.find(name);
    return found == outcome.frames_with_pieces.end() ? 0 : found->second;
  }
  static const ClassSliceErrors& ErrorsOf(const Outcome& outcome, const std::string& name) {
    return *std::find_if(outcome.slice_errors.begin(), outcome.slice_errors.end(),
                         [&](const ClassSliceErrors& e) { return e.class_name == name; });
  }
  static const ClassDetectionStats& StatsOf(const Outcome& outcome, const std::string& name) {
    return *std::find_if(outcome.evaluation.per_class.begin(), outcome.evaluation.per_class.end(),
                         [&](const ClassDetectionStats& s) { return s.class_name == name; });
  }

  static testing::TempDir* dir_;
  static std::string run_;
};
testing::TempDir* FragmentsTest::dir_ = nullptr;
std::string FragmentsTest::run_;

// The stripes split the drum in several frames; joined, it is one detection
// per frame whose angular width is closer to its visible slice's.
TEST_F(FragmentsTest, StripedDrumIsJoinedIntoOneWiderDetection) {
  BlobDetectorOptions pieces;
  pieces.join_fragments = false;
  const Outcome before = Detect(pieces);
  const Outcome after = Detect(BlobDetectorOptions{});
  const double width_error_before = ErrorsOf(before, "striped drum").detector.mean[3];
  const double width_error_after = ErrorsOf(after, "striped drum").detector.mean[3];
  std::printf("striped drum: split in %d frames -> %d; mean s_phi error %.1f px -> %.1f px\n",
              Pieces(before, "striped drum"), Pieces(after, "striped drum"), width_error_before,
              width_error_after);
  ASSERT_GE(Pieces(before, "striped drum"), 4);  // the scene does split it
  EXPECT_LE(2 * Pieces(after, "striped drum"), Pieces(before, "striped drum"));
  EXPECT_LT(width_error_before, 0.0);  // pieces are narrower than the drum
  EXPECT_GT(width_error_after, width_error_before + 2.0);
  EXPECT_EQ(StatsOf(after, "striped drum").sightings_found,
            StatsOf(before, "striped drum").sightings_found);
  EXPECT_EQ(StatsOf(after, "striped drum").spurious, 0);
}

// Two balls side by side fit their class one by one and not together: they
// are never joined. With drop_fragments off they are both kept.
TEST_F(FragmentsTest, TwoObjectsOfOneClassSideBySideAreNotJoined) {
  BlobDetectorOptions options;
  options.drop_fragments = false;
  const Outcome outcome = Detect(options);
  const ClassDetectionStats& balls = StatsOf(outcome, "blue ball");
  std::printf("blue balls: %d of %d sightings found, %d detections, %d spurious\n",
              balls.sightings_found, balls.sightings, balls.detections, balls.spurious);
  ASSERT_GE(balls.sightings, 16);
  EXPECT_GE(balls.sightings_found, 0.9 * balls.sightings);
  EXPECT_LE(balls.detections, balls.sightings);  // no piece counted twice, none joined
  EXPECT_EQ(balls.spurious, 0);
}

}  // namespace
}  // namespace oslam

// Learning colour boxes and image shapes (colour_training.h): examples.yaml
// read with paths relative to it and errors naming the file and key; boxes
// learnt from ROI, mask-file and in-memory examples; image shapes from
// outline masks; and, on a small simulated run, examples taken from the
// ground truth (on the object, in its main colour) and image shapes learnt
// from its visible slices.
#include "detect/colour_training.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/bounding_slice.h"
#include "core/csv.h"
#include "core/error.h"
#include "detect/colour_classifier.h"
#include "detect/painted_slices.h"
#include "samples/scene.h"
#include "samples/simulator.h"
#include "test_util.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;
using testing::ClassWithColour;
using testing::kGreen;
using testing::kPink;
using testing::PaintSlice;
using testing::ToYuv;

std::vector<ObjectClass> TwoClasses() {
  return {ClassWithColour("green box", kGreen, 3), ClassWithColour("pink ball", kPink, 3)};
}

// ---- examples.yaml ----

// A folder with examples/frame.png (40 x 30) and examples/masks/frame.png.
struct ExampleFolder {
  testing::TempDir dir;
  ExampleFolder() {
    fs::create_directories(dir.Path("examples/masks"));
    cv::imwrite(dir.Path("examples/frame.png"), cv::Mat(30, 40, CV_8UC3, cv::Scalar(kGreen)));
    cv::imwrite(dir.Path("examples/masks/frame.png"), cv::Mat(30, 40, CV_8UC1, cv::Scalar(255)));
  }
  std::string Write(const std::string& yaml) const {
    const std::string path = dir.Path("examples/examples.yaml");
    std::ofstream(path) << yaml;
    return path;
  }
};

TEST(ColourExamples, AreReadWithPathsRelativeToTheirFile) {
  const ExampleFolder folder;
  const std::string path = folder.Write(
      "examples:\n"
      "  - {image: frame.png, class: green box, roi: [2, 3, 10, 5]}\n"
      "  - {image: frame.png, class: pink ball, mask: masks/frame.png}\n"
      "  - {image: frame.png, class: pink ball, mask: masks/frame.png, outline: 1}\n");
  const std::vector<ColourExample> examples = ReadColourExamples(path, TwoClasses());
  ASSERT_EQ(examples.size(), 3u);
  EXPECT_EQ(fs::path(examples[0].image_path), fs::path(folder.dir.Path("examples/frame.png")));
  EXPECT_EQ(examples[0].class_name, "green box");
  EXPECT_EQ(examples[0].roi, cv::Rect(2, 3, 10, 5));
  EXPECT_TRUE(examples[0].mask_path.empty());
  EXPECT_FALSE(examples[0].outline);
  EXPECT_EQ(fs::path(examples[1].mask_path), fs::path(folder.dir.Path("examples/masks/frame.png")));
  EXPECT_FALSE(examples[1].outline);
  EXPECT_TRUE(examples[2].outline);
  EXPECT_TRUE(examples[2].mask.empty());  // read when used
}

TEST(ColourExamples, BadEntriesNameTheFileAndTheKey) {
  const ExampleFolder folder;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"examples:\n  - {image: frame.png, class: red can, roi: [0, 0, 4, 4]}\n",
       "examples[0].class: unknown class 'red can' (not in classes.yaml)"},
      {"examples:\n  - {image: frame.png, class: green box, roi: [0, 0, 4, 4]}\n"
       "  - {image: missing.png, class: green box, roi: [0, 0, 4, 4]}\n",
       "examples[1].image: file not found: "},
      {"examples:\n  - {image: frame.png, class: green box, roi: [0, 0, 4, 4], "
       "mask: masks/frame.png}\n",
       "examples[0]: give exactly one of roi and mask"},
      {"examples:\n  - {image: frame.png, class: green box}\n",
       "examples[0]: give exactly one of roi and mask"},
      {"examples:\n  - {image: frame.png, class: green box, roi: [0, 0, 0, 4]}\n",
       "examples[0].roi: width and height must be positive"},
      {"examples:\n  - {image: frame.png, class: green box, mask: masks/none.png}\n",
       "examples[0].mask: file not found: "},
      {"examples:\n  - {image: frame.png, class: green box, mask: masks/frame.png, outline: 2}\n",
       "examples[0].outline: must be 0 or 1"},
      {"examples:\n  - {image: frame.png, class: green box, roi: [0, 0, 4, 4], outline: 1}\n",
       "examples[0].outline: needs a mask (an ROI is no object outline)"},
      {"examples:\n  - {image: frame.png, class: green box, roi: [0, 0, 4, 4], colour: 1}\n",
       "examples[0].colour: unknown key"},
      {"examples:\n  - frame.png\n", "examples[0]: must be a mapping"},
      {"examples: []\n", "examples: no examples listed"},
  };
  for (const auto& [yaml, expected] : cases) {
    const std::string path = folder.Write(yaml);
    try {
      ReadColourExamples(path, TwoClasses());
      ADD_FAILURE() << "no error for:\n" << yaml;
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(path + ": " + expected, 0), 0u) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
  }
}

// ---- colour boxes ----

TEST(TrainColourModels, LearnsEachClassFromItsOwnExamples) {
  testing::TempDir dir;
  // Left half green, right half pink, one pixel of each colour off by a few levels.
  cv::Mat image(20, 40, CV_8UC3, cv::Scalar(kGreen));
  image(cv::Rect(20, 0, 20, 20)).setTo(cv::Scalar(kPink));
  image.at<cv::Vec3b>(5, 5) = cv::Vec3b(64, 166, 44);
  image.at<cv::Vec3b>(5, 25) = cv::Vec3b(176, 109, 250);
  cv::imwrite(dir.Path("frame.png"), image);
  cv::Mat pink_mask(20, 40, CV_8UC1, cv::Scalar(0));
  pink_mask(cv::Rect(20, 0, 20, 20)).setTo(255);
  cv::imwrite(dir.Path("pink_mask.png"), pink_mask);
  ColourExample green, pink, in_memory;
  green.image_path = pink.image_path = in_memory.image_path = dir.Path("frame.png");
  green.class_name = "green box";
  green.roi = cv::Rect(0, 0, 20, 20);
  pink.class_name = "pink ball";
  pink.mask_path = dir.Path("pink_mask.png");
  std::vector<ObjectClass> classes = TwoClasses();
  classes.push_back(ClassWithColour("untrained", cv::Vec3b(10, 20, 30), 7));
  const std::vector<ObjectClass> trained = TrainColourModels(classes, {green, pink}, 2.0);
  // Each box is LearnColourBox of exactly its example pixels.
  const cv::Mat all(20, 40, CV_8UC1, cv::Scalar(255));
  const ColourBox expected_green = LearnColourBox({image(cv::Rect(0, 0, 20, 20)).clone()},
                                                  {all(cv::Rect(0, 0, 20, 20)).clone()}, 2.0);
  const ColourBox expected_pink = LearnColourBox({image}, {pink_mask}, 2.0);
  ASSERT_TRUE(trained[0].colour && trained[1].colour);
  EXPECT_EQ(trained[0].colour->yuv_mean, expected_green.yuv_mean);
  EXPECT_EQ(trained[0].colour->yuv_std, expected_green.yuv_std);
  EXPECT_EQ(trained[0].colour->k_sigma, 2.0);
  EXPECT_EQ(trained[1].colour->yuv_mean, expected_pink.yuv_mean);
  EXPECT_EQ(trained[1].colour->yuv_std, expected_pink.yuv_std);
  EXPECT_GT(trained[1].colour->yuv_std[1], 0.0);  // the odd pixel counted
  // A class without examples keeps its box.
  EXPECT_EQ(trained[2].colour->yuv_mean, classes[2].colour->yuv_mean);
  EXPECT_EQ(trained[2].colour->yuv_std, classes[2].colour->yuv_std);
  // An in-memory mask wins over an ROI: here, the pink half as the green class.
  in_memory.class_name = "green box";
  in_memory.roi = cv::Rect(0, 0, 20, 20);
  in_memory.mask = pink_mask;
  const std::vector<ObjectClass> from_memory = TrainColourModels(classes, {in_memory}, 2.0);
  EXPECT_EQ(from_memory[0].colour->yuv_mean, expected_pink.yuv_mean);
}

TEST(TrainColourModels, BadExamplesAreErrorsNamingTheirFile) {
  testing::TempDir dir;
  const std::string image = dir.Path("frame.png");
  cv::imwrite(image, cv::Mat(20, 40, CV_8UC3, cv::Scalar(kGreen)));
  cv::imwrite(dir.Path("small_mask.png"), cv::Mat(10, 40, CV_8UC1, cv::Scalar(255)));
  cv::imwrite(dir.Path("empty_mask.png"), cv::Mat(20, 40, CV_8UC1, cv::Scalar(0)));
  std::ofstream(dir.Path("not_an_image.png")) << "text";
  auto error = [&](const ColourExample& example) {
    try {
      TrainColourModels(TwoClasses(), {example}, 3.0);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    ADD_FAILURE() << "no error for " << example.image_path;
    return std::string();
  };
  ColourExample example;
  example.class_name = "green box";
  example.image_path = image;
  example.roi = cv::Rect(30, 0, 20, 5);
  EXPECT_EQ(error(example), image + ": ROI lies outside the image");
  example.image_path = dir.Path("not_an_image.png");
  EXPECT_EQ(error(example), dir.Path("not_an_image.png") +
                                ": not an image (expected PNG, JPEG, BMP, TIFF or PNM data)");
  example.image_path = image;
  example.mask_path = dir.Path("small_mask.png");
  EXPECT_EQ(error(example), dir.Path("small_mask.png") + ": mask size differs from its image");
  example.mask_path = dir.Path("no_mask.png");
  EXPECT_EQ(error(example), dir.Path("no_mask.png") + ": file not found");
  example.mask_path = dir.Path("empty_mask.png");
  EXPECT_EQ(error(example),
            "class 'green box': colour model needs at least 2 example pixels, got 0");
}

// ---- image shapes from outlines ----

// An orange ball and an orange bucket of one colour; only their image
// shapes (elongation 1.0 and 1.4) tell them apart.
std::vector<ObjectClass> LookAlikes() {
  const cv::Vec3b orange{30, 130, 250};
  return {ClassWithColour("orange ball", orange, 4), ClassWithColour("orange bucket", orange, 4)};
}

TEST(ImageShapes, LearntFromOutlineExamplesAsTheDetectorMeasuresBlobs) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const cv::Vec3b orange{30, 130, 250};
  const std::vector<ObjectClass> classes = LookAlikes();
  testing::TempDir dir;
  std::ofstream yaml(dir.Path("examples.yaml"));
  yaml << "examples:\n";
  // Three views of a bucket-shaped slice (elongation 1.4) at other places in the image.
  const std::vector<BoundingSlice> views = {{100.0, 0.3, 24.0, 24.0 / (1.4 * 112.0)},
                                            {140.0, 2.0, 30.0, 30.0 / (1.4 * 155.0)},
                                            {80.0, -2.5, 20.0, 20.0 / (1.4 * 90.0)}};
  for (size_t i = 0; i < views.size(); ++i) {
    cv::Mat image(camera.image_height(), camera.image_width(), CV_8UC3, cv::Scalar(128, 128, 128));
    PaintSlice(&image, camera, views[i], orange);
    cv::Mat mask;
    cv::inRange(image, orange, orange, mask);
    const std::string name = "view" + std::to_string(i);
    cv::imwrite(dir.Path(name + ".png"), image);
    cv::imwrite(dir.Path(name + "_mask.png"), mask);
    yaml << "  - {image: " << name << ".png, class: orange bucket, mask: " << name
         << "_mask.png, outline: 1}\n";
  }
  // A plain colour example teaches no shape.
  yaml << "  - {image: view0.png, class: orange ball, roi: [0, 0, 8, 8]}\n";
  yaml.close();
  const std::vector<ColourExample> examples =
      ReadColourExamples(dir.Path("examples.yaml"), classes);
  const std::vector<ObjectClass> learnt = LearnImageShapesFromExamples(classes, examples, camera);
  ASSERT_TRUE(learnt[1].image_shape.has_value());
  EXPECT_NEAR(learnt[1].image_shape->elongation_mean, 1.4, 0.08);
  EXPECT_GE(learnt[1].image_shape->elongation_std, 0.05);  // the floor for few views
  EXPECT_FALSE(learnt[0].image_shape.has_value());
  // The painted views are one flat colour: the colour blob is the outline
  // itself, so the detector's arc error is the floor of half a pixel.
  const std::vector<ObjectClass> measured =
      MeasureDetectorErrorsFromExamples(learnt, examples, camera);
  EXPECT_DOUBLE_EQ(measured[1].image_shape->arc_error_px, 0.5);
  EXPECT_FALSE(measured[0].image_shape.has_value());
  // ... and its mean colour is the paint's: its chroma, the spread at the
  // floor (a share of the colour box's 4 units).
  ASSERT_TRUE(measured[1].colour && measured[1].colour->blob_chroma);
  const cv::Vec3b orange_yuv = ToYuv(orange);
  for (int ch = 0; ch < 2; ++ch) {
    EXPECT_NEAR(measured[1].colour->blob_chroma->mean[ch], orange_yuv[ch + 1] - 128.0, 1e-6);
    EXPECT_DOUBLE_EQ(measured[1].colour->blob_chroma->std[ch], kDefaultBlobChromaFloor * 4);
  }
  // Fewer than three outlines: no model.
  const std::vector<ColourExample> two(examples.begin(), examples.begin() + 2);
  EXPECT_FALSE(LearnImageShapesFromExamples(classes, two, camera)[1].image_shape);
  // An outline of another image size is refused, naming the mask.
  cv::imwrite(dir.Path("small_mask.png"), cv::Mat(100, 100, CV_8UC1, cv::Scalar(255)));
  std::vector<ColourExample> wrong_size = examples;
  wrong_size[0].mask_path = dir.Path("small_mask.png");
  try {
    LearnImageShapesFromExamples(classes, wrong_size, camera);
    FAIL() << "an outline of the wrong size was taken";
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        dir.Path("small_mask.png") + ": outline mask size differs from the camera's image size");
  }
}

// ---- a simulated run ----

// Five frames of a flat-lit world (no lights, no sensor noise: every surface
// has exactly its colour) with a red can striped in blue, a green ball and a
// grey distractor of no class.
class SimulatedRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    const std::string scene = dir_->Path("scene.yaml");
    std::ofstream(scene)
        << "camera: {preset: lpa}\n"
           "classes:\n"
           "  - {name: red can, display_rgb: [200, 30, 30], diameter_mean_m: 0.3, "
           "diameter_std_m: 0.1, height_mean_m: 0.5, height_std_m: 0.1}\n"
           "  - {name: green ball, display_rgb: [40, 160, 50], diameter_mean_m: 0.25, "
           "diameter_std_m: 0.05, height_mean_m: 0.25, height_std_m: 0.05}\n"
           "floor: {colour: [100, 100, 100]}\n"
           "lighting: {ambient: 1.0}\n"
           "sensor: {noise_std: 0}\n"
           "objects:\n"
           "  - {class: red can, shape: cylinder, position_m: [1.3, 0.4], diameter_m: 0.3, "
           "height_m: 0.5, colour: [200, 30, 30], texture: {pattern: stripes, "
           "colour2: [30, 30, 200], scale_m: 0.06}}\n"
           "  - {class: green ball, shape: sphere, position_m: [0.2, -1.1], diameter_m: 0.25, "
           "colour: [40, 160, 50]}\n"
           "  - {shape: box, position_m: [-1.0, 0.9], length_m: 0.4, width_m: 0.4, "
           "height_m: 0.6, colour: [120, 120, 120]}\n"
           "path: {start_pose: [0, 0, 0], commands: F4}\n";
    SimulationOptions options;
    options.max_frames = 5;
    Simulate(LoadScene(scene), Run(), options);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string Run() { return dir_->Path("run"); }
  static std::vector<ObjectClass> Classes() { return ReadClasses(Run() + "/classes.yaml"); }
  static testing::TempDir* dir_;
};
testing::TempDir* SimulatedRun::dir_ = nullptr;

TEST_F(SimulatedRun, GroundTruthExamplesLieOnTheirObjectInItsMainColour) {
  const std::vector<ObjectClass> classes = Classes();
  const std::unique_ptr<CameraModel> camera = LoadCamera(Run() + "/camera.yaml");
  const GroundTruth truth = *ReadGroundTruth(Run());
  const std::vector<ColourExample> examples = ExamplesFromGroundTruth(Run(), classes, 3);
  const cv::Vec3b red(30, 30, 200), green(50, 160, 40);  // BGR
  for (int c = 0; c < 2; ++c) {
    long count = std::count_if(examples.begin(), examples.end(), [&](const ColourExample& e) {
      return e.class_name == classes[c].name;
    });
    EXPECT_GE(count, 1) << classes[c].name;
    EXPECT_LE(count, 3) << classes[c].name;  // one per stretch of the run
  }
  for (const ColourExample& example : examples) {
    SCOPED_TRACE(example.image_path);
    const int c = FindClass(classes, example.class_name);
    ASSERT_GE(c, 0);
    const cv::Mat frame = cv::imread(example.image_path, cv::IMREAD_COLOR);
    ASSERT_FALSE(frame.empty());
    ASSERT_EQ(example.mask.size(), frame.size());
    ASSERT_GE(cv::countNonZero(example.mask), 8);
    const long frame_index = std::stol(fs::path(example.image_path).stem().string());
    const GroundTruthSighting* sighting = nullptr;
    for (const GroundTruthSighting& s : truth.sightings)
      if (s.frame == frame_index && truth.objects[s.object_id].class_name == example.class_name)
        sighting = &s;
    ASSERT_NE(sighting, nullptr);
    for (int y = 0; y < frame.rows; ++y)
      for (int x = 0; x < frame.cols; ++x) {
        if (!example.mask.at<uint8_t>(y, x)) continue;
        // Inside the object's true slice and the mirror annulus...
        const PolarPoint p = camera->PixelToPolar(Eigen::Vector2d(x, y));
        ASSERT_TRUE(camera->IsInAnnulus(Eigen::Vector2d(x, y)));
        ASSERT_GE(p.radius_px, sighting->u_r_px);
        ASSERT_LE(p.radius_px, sighting->u_r_px + sighting->s_r_px);
        ASSERT_LE(std::abs(WrapAngle(p.angle_rad - sighting->u_phi_rad)),
                  0.5 * sighting->s_phi_rad);
        // ...and of its main colour: the can's blue stripes are left out.
        ASSERT_EQ(frame.at<cv::Vec3b>(y, x), c == 0 ? red : green) << x << " " << y;
      }
  }
  // Learnt from them, each box is its object's colour exactly (no noise, flat light).
  const std::vector<ObjectClass> trained = TrainColourModels(classes, examples, 3.0);
  for (int c = 0; c < 2; ++c) {
    const cv::Vec3b yuv = ToYuv(c == 0 ? red : green);
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_NEAR(trained[c].colour->yuv_mean[ch], yuv[ch], 1e-9) << c;
      EXPECT_NEAR(trained[c].colour->yuv_std[ch], 0.0, 1e-6) << c;
    }
  }
}

TEST_F(SimulatedRun, GroundTruthExamplesNeedTheGroundTruth) {
  testing::TempDir dir;
  const std::string copy = dir.Path("copy");
  fs::copy(Run(), copy, fs::copy_options::recursive);
  fs::remove_all(copy + "/ground_truth");
  try {
    ExamplesFromGroundTruth(copy, Classes());
    FAIL() << "examples without ground truth";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), copy + ": no ground_truth/ folder to learn colours from");
  }
  try {
    LearnImageShapes(Classes(), copy);
    FAIL() << "image shapes without ground truth";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), copy + ": no ground_truth/ folder to learn image shapes from");
  }
}

// The detector's arc error per class: the plain ball's colour blob is its
// silhouette widened by the half pixel on each side (about 1 px); the can's
// blue stripes at its edges are not its colour, so its blob loses whole
// stripes there. Measured, the can's error is the larger, and classes without
// an image shape model get none. The blobs' mean colour: in flat light and
// without noise each blob is its object's main colour exactly, so the blob
// chroma is that colour's (U − 128, V − 128) and its spread the floor.
TEST_F(SimulatedRun, DetectorErrorsAreMeasuredPerClass) {
  const std::vector<ObjectClass> untrained = Classes();
  const std::vector<ObjectClass> coloured =
      TrainColourModels(untrained, ExamplesFromGroundTruth(Run(), untrained), 3.0);
  const std::vector<ObjectClass> measured =
      MeasureDetectorErrors(LearnImageShapes(coloured, Run(), 3), Run(), 3);
  ASSERT_TRUE(measured[0].image_shape && measured[1].image_shape);
  std::printf("arc error: can %.2f px, ball %.2f px\n", measured[0].image_shape->arc_error_px,
              measured[1].image_shape->arc_error_px);
  EXPECT_GE(measured[1].image_shape->arc_error_px, 0.5);
  EXPECT_LT(measured[1].image_shape->arc_error_px, 1.6);
  EXPECT_GT(measured[0].image_shape->arc_error_px, measured[1].image_shape->arc_error_px + 1.0);
  const cv::Vec3b red(30, 30, 200), green(50, 160, 40);  // BGR
  for (int c = 0; c < 2; ++c) {
    SCOPED_TRACE(measured[c].name);
    ASSERT_TRUE(measured[c].colour && measured[c].colour->blob_chroma);
    const cv::Vec3b yuv = ToYuv(c == 0 ? red : green);
    for (int ch = 0; ch < 2; ++ch) {
      EXPECT_NEAR(measured[c].colour->blob_chroma->mean[ch], yuv[ch + 1] - 128.0, 1e-6);
      EXPECT_DOUBLE_EQ(measured[c].colour->blob_chroma->std[ch], kDefaultBlobChromaFloor);
    }
  }
  // Without a shape model there is nothing to attach the error to.
  EXPECT_FALSE(MeasureDetectorErrors(coloured, Run(), 3)[0].image_shape.has_value());
  // More views asked for than the run has: no measurement.
  EXPECT_EQ(MeasureDetectorErrors(LearnImageShapes(coloured, Run(), 3), Run(), 1000)[1]
                .image_shape->arc_error_px,
            0.0);
}

// The model is the mean and spread of SliceElongation over the views at
// least 95 % visible and 8 px long and wide, read here straight from the
// simulator's visible_slices.csv.
TEST_F(SimulatedRun, ImageShapesAreTheElongationOfTheWellSeenViews) {
  std::vector<ObjectClass> classes = Classes();
  const GroundTruth truth = *ReadGroundTruth(Run());
  const CsvTable views = CsvTable::Read(Run() + "/ground_truth/visible_slices.csv");
  std::vector<std::vector<double>> elongations(classes.size());
  for (size_t row = 0; row < views.num_rows(); ++row) {
    const int c = FindClass(
        classes, truth.objects[views.Integer(row, views.ColumnIndex("object_id"))].class_name);
    if (c < 0) continue;
    if (views.Double(row, views.ColumnIndex("visible_px")) <
        0.95 * views.Double(row, views.ColumnIndex("footprint_px")))
      continue;
    const BoundingSlice slice{views.Double(row, views.ColumnIndex("u_r_px")),
                              views.Double(row, views.ColumnIndex("u_phi_rad")),
                              views.Double(row, views.ColumnIndex("s_r_px")),
                              views.Double(row, views.ColumnIndex("s_phi_rad"))};
    if (slice.s_r_px < 8 || SliceArcWidth(slice) < 8) continue;
    elongations[c].push_back(SliceElongation(slice));
  }
  ASSERT_GE(elongations[0].size(), 3u);
  ASSERT_GE(elongations[1].size(), 3u);
  const std::vector<ObjectClass> learnt = LearnImageShapes(classes, Run(), 3);
  for (int c = 0; c < 2; ++c) {
    const std::vector<double>& values = elongations[c];
    double mean = 0, squares = 0;
    for (double e : values) mean += e / values.size();
    for (double e : values) squares += (e - mean) * (e - mean);
    ASSERT_TRUE(learnt[c].image_shape.has_value()) << c;
    EXPECT_NEAR(learnt[c].image_shape->elongation_mean, mean, 1e-12) << c;
    EXPECT_NEAR(learnt[c].image_shape->elongation_std,
                std::max(0.02, std::sqrt(squares / (values.size() - 1))), 1e-12)
        << c;
  }
  // A sphere is about as long as it is wide in the image; the can, 0.5 m tall
  // and 0.3 m wide, is longer.
  EXPECT_NEAR(learnt[1].image_shape->elongation_mean, 1.0, 0.15);
  EXPECT_GT(learnt[0].image_shape->elongation_mean, learnt[1].image_shape->elongation_mean + 0.2);
  // With fewer views than asked for, a class keeps the model it had.
  classes[1].image_shape = ImageShapeModel{2.0, 0.3};
  const int most = static_cast<int>(std::max(elongations[0].size(), elongations[1].size()));
  const std::vector<ObjectClass> kept = LearnImageShapes(classes, Run(), most + 1);
  EXPECT_FALSE(kept[0].image_shape.has_value());
  ASSERT_TRUE(kept[1].image_shape.has_value());
  EXPECT_EQ(kept[1].image_shape->elongation_mean, 2.0);
  EXPECT_EQ(kept[1].image_shape->elongation_std, 0.3);
}

TEST_F(SimulatedRun, ImageShapesFromAnInconsistentRunNameTheFileAndLine) {
  testing::TempDir dir;
  const std::string copy = dir.Path("copy");
  fs::copy(Run(), copy, fs::copy_options::recursive);
  const std::string csv = copy + "/ground_truth/visible_slices.csv";
  // The first data row names an object objects.csv does not have.
  const int column = CsvTable::Read(csv).ColumnIndex("object_id");
  std::string text = ReadTextFile(csv);
  size_t start = text.find('\n') + 1;
  for (int i = 0; i < column; ++i) start = text.find(',', start) + 1;
  text.replace(start, text.find(',', start) - start, "99");
  WriteTextFileAtomically(csv, text);
  try {
    LearnImageShapes(Classes(), copy);
    FAIL() << "an unknown object was taken";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), csv + ":2: object 99 is not in objects.csv");
  }
  fs::remove(csv);
  try {
    LearnImageShapes(Classes(), copy);
    FAIL() << "no visible slices";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("visible_slices.csv"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace oslam

// Run-folder readers and writers: round trips and one-line errors.
#include "core/run_folder.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/parallel.h"
#include "test_util.h"

namespace oslam {
namespace {

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    return e.what();
  }
  return "(no error)";
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

ObjectClass GreenBox() {
  ObjectClass c;
  c.name = "green box";
  c.display_rgb = {40, 160, 60};
  c.diameter_mean_m = 0.6;
  c.diameter_std_m = 0.3;
  c.height_mean_m = 0.6;
  c.height_std_m = 0.15;
  return c;
}

TEST(Classes, WriteThenReadRoundTrips) {
  testing::TempDir dir;
  ObjectClass ball = GreenBox();
  ball.name = "pink ball";
  ball.colour = ColourBox{{150, 120, 170}, {8, 3, 4}, 3.0, BlobChroma{{-12.5, 20}, {1.5, 0.75}}};
  ball.image_shape = ImageShapeModel{1.02, 0.04, 1.25};
  ball.shape = ObjectShape::kSphere;
  WriteClasses({GreenBox(), ball}, dir.Path("classes.yaml"));
  const std::vector<ObjectClass> read = ReadClasses(dir.Path("classes.yaml"));
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].name, "green box");
  EXPECT_EQ(read[0].display_rgb, (std::array<int, 3>{40, 160, 60}));
  EXPECT_DOUBLE_EQ(read[0].height_std_m, 0.15);
  EXPECT_FALSE(read[0].colour.has_value());
  ASSERT_TRUE(read[1].colour.has_value());
  EXPECT_DOUBLE_EQ(read[1].colour->yuv_mean[2], 170);
  ASSERT_TRUE(read[1].colour->blob_chroma.has_value());
  EXPECT_EQ(read[1].colour->blob_chroma->mean, (std::array<double, 2>{-12.5, 20}));
  EXPECT_EQ(read[1].colour->blob_chroma->std, (std::array<double, 2>{1.5, 0.75}));
  EXPECT_FALSE(read[0].image_shape.has_value());
  ASSERT_TRUE(read[1].image_shape.has_value());
  EXPECT_DOUBLE_EQ(read[1].image_shape->elongation_mean, 1.02);
  EXPECT_DOUBLE_EQ(read[1].image_shape->elongation_std, 0.04);
  EXPECT_DOUBLE_EQ(read[1].image_shape->arc_error_px, 1.25);
  EXPECT_EQ(read[0].shape, ObjectShape::kCylinder);
  EXPECT_EQ(read[1].shape, ObjectShape::kSphere);
  EXPECT_EQ(FindClass(read, "pink ball"), 1);
  EXPECT_EQ(FindClass(read, "unicorn"), -1);
}

// Numbers are stored in their shortest exact form, names quoted, so the file
// stays readable and edits by hand are easy; and they read back bit-exactly.
TEST(Classes, NumbersAreWrittenShortAndReadBackExactly) {
  testing::TempDir dir;
  ObjectClass odd = GreenBox();
  odd.name = "say \"hi\" \\ box";
  odd.diameter_std_m = 0.1 + 0.2;  // 0.30000000000000004: must survive exactly
  odd.colour = ColourBox{{150.25, 0.6, 1e-8}, {8, 3, 4}, 2.5, std::nullopt};
  const ConfusionMatrix confusion = {{0.6, 0.4}, {0.3, 0.7}};
  WriteClasses({GreenBox(), odd}, dir.Path("classes.yaml"), confusion);
  const std::string text = ReadTextFile(dir.Path("classes.yaml"));
  EXPECT_TRUE(Contains(text, "diameter_mean_m: 0.6\n")) << text;
  EXPECT_TRUE(Contains(text, "yuv_mean: [150.25, 0.6, 1e-08]")) << text;
  EXPECT_TRUE(Contains(text, "- [0.6, 0.4]")) << text;
  EXPECT_FALSE(Contains(text, "e-01")) << text;
  const std::vector<ObjectClass> read = ReadClasses(dir.Path("classes.yaml"));
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[1].name, odd.name);
  EXPECT_EQ(read[1].diameter_std_m, 0.1 + 0.2);
  ASSERT_TRUE(read[1].colour.has_value());
  EXPECT_EQ(read[1].colour->yuv_mean, odd.colour->yuv_mean);
  EXPECT_EQ(read[1].colour->k_sigma, 2.5);
  EXPECT_FALSE(read[1].colour->blob_chroma.has_value());
  EXPECT_FALSE(Contains(text, "blob_chroma")) << text;
  EXPECT_EQ(ReadConfusion(dir.Path("classes.yaml")), confusion);
}

TEST(Classes, BadFilesAreReportedWithTheKey) {
  testing::TempDir dir;
  const std::string path = dir.Path("classes.yaml");
  const std::string good =
      "classes:\n  - name: door\n    display_rgb: [255, 128, 0]\n    diameter_mean_m: 1.0\n"
      "    diameter_std_m: 0.3\n    height_mean_m: 2.2\n    height_std_m: 0.5\n";
  auto error_for = [&](const std::string& text) {
    std::ofstream(path) << text;
    return ErrorOf([&] { ReadClasses(path); });
  };
  std::ofstream(path) << good;
  EXPECT_EQ(ReadClasses(path).at(0).name, "door");
  EXPECT_EQ(error_for(good + "    size: 3\n"),
            path +
                ": classes[0].size: unknown key (allowed: name, display_rgb, shape, "
                "diameter_mean_m, diameter_std_m, height_mean_m, height_std_m, "
                "footprint_aspect, base_height_m, base_height_std_m, colour, image_shape)");
  EXPECT_EQ(error_for(good + "    footprint_aspect: 1.5\n"),
            path + ": classes[0].footprint_aspect: must be in (0, 1] (footprint width / length)");
  // The support prior: defaults, a declared height and spread, and none.
  std::ofstream(path) << good;
  EXPECT_TRUE(ReadClasses(path).at(0).supported);
  std::ofstream(path) << good + "    base_height_m: 1.2\n    base_height_std_m: 0.05\n";
  std::vector<ObjectClass> read = ReadClasses(path);
  EXPECT_EQ(read.at(0).base_height_m, 1.2);
  EXPECT_EQ(read.at(0).base_height_std_m, 0.05);
  std::ofstream(path) << good + "    base_height_std_m: none\n";
  read = ReadClasses(path);
  EXPECT_FALSE(read.at(0).supported);
  WriteClasses(read, path);  // and back: `none` survives a write
  EXPECT_FALSE(ReadClasses(path).at(0).supported);
  std::ofstream(path) << good;
  EXPECT_EQ(error_for(good + "    shape: cone\n"),
            path + ": classes[0].shape: must be one of cylinder, box, sphere, panel");
  std::ofstream(path) << good;
  EXPECT_EQ(ReadClasses(path).at(0).shape, ObjectShape::kCylinder);  // the default
  std::ofstream(path) << good << "    shape: panel\n";
  EXPECT_EQ(ReadClasses(path).at(0).shape, ObjectShape::kPanel);
  EXPECT_EQ(error_for(good + good.substr(9)), path + ": classes[1].name: duplicate class 'door'");
  EXPECT_TRUE(Contains(error_for("classes: []\n"), "no classes listed"));
  std::string negative = good;
  negative.replace(negative.find("0.5"), 3, "-0.5");
  EXPECT_EQ(error_for(negative), path + ": classes[0].height_std_m: must be positive");
  std::string no_colour = good;
  no_colour.replace(no_colour.find("[255, 128, 0]"), 13, "[255, 128]");
  EXPECT_EQ(error_for(no_colour), path + ": classes[0].display_rgb: expected 3 numbers, found 2");
  EXPECT_EQ(error_for(good + "    image_shape: {elongation_mean: 1.0, elongation_std: 0}\n"),
            path + ": classes[0].image_shape.elongation_std: must be positive");
  EXPECT_TRUE(Contains(error_for(good + "    image_shape: {elongation_mean: 1.0}\n"),
                       "classes[0].image_shape.elongation_std"));
  EXPECT_EQ(error_for(good + "    image_shape: {elongation_mean: 1.0, elongation_std: 0.1, "
                             "arc_error_px: -1}\n"),
            path + ": classes[0].image_shape.arc_error_px: must be >= 0");
  const std::string colour =
      "    colour: {yuv_mean: [100, 90, 160], yuv_std: [10, 3, 4], k_sigma: 3";
  EXPECT_EQ(error_for(good + colour + ", blob_chroma_mean: [-30, 30]}\n"),
            path +
                ": classes[0].colour.blob_chroma_std: missing: blob_chroma_mean and "
                "blob_chroma_std come together");
  EXPECT_EQ(
      error_for(good + colour + ", blob_chroma_mean: [-30, 30], blob_chroma_std: [0.5, 0]}\n"),
      path + ": classes[0].colour.blob_chroma_std: must be positive");
  EXPECT_EQ(error_for(good + colour + ", blob_chroma_mean: [-30], blob_chroma_std: [1, 1]}\n"),
            path + ": classes[0].colour.blob_chroma_mean: expected 2 numbers, found 1");
  std::string huge = good;
  huge.replace(huge.find("2.2"), 3, "2e9");
  EXPECT_EQ(error_for(huge), path +
                                 ": classes[0].height_mean_m: 2e+09 is outside [0, 100] m "
                                 "(docs/formats.md, Bounds)");
}

TEST(Odometry, PosesAndIncrementsGiveTheSamePoses) {
  testing::TempDir dir;
  std::vector<Pose2> truth = {{0, 0, 0}};
  for (const OdometryIncrement step : {OdometryIncrement{0.2, 0}, OdometryIncrement{0, 0.17},
                                       OdometryIncrement{0.2, 0}, OdometryIncrement{-0.2, 0}})
    truth.push_back(ApplyIncrement(truth.back(), step));
  WriteOdometryPoses(truth, dir.Path("poses.csv"));
  const Odometry from_poses = ReadOdometry(dir.Path("poses.csv"), 5);
  EXPECT_EQ(from_poses.kind, OdometryKind::kPoses);

  std::ofstream increments(dir.Path("increments.csv"));
  increments << "frame,distance_m,turn_rad\n";
  for (size_t i = 0; i < from_poses.increments.size(); ++i)
    increments << i << ',' << from_poses.increments[i].distance_m << ','
               << from_poses.increments[i].turn_rad << '\n';
  increments.close();
  const Odometry from_increments = ReadOdometry(dir.Path("increments.csv"));
  EXPECT_EQ(from_increments.kind, OdometryKind::kIncrements);
  ASSERT_EQ(from_increments.poses.size(), 5u);
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_NEAR(from_increments.poses[i].x, truth[i].x, 1e-12);
    EXPECT_NEAR(from_increments.poses[i].y, truth[i].y, 1e-12);
    EXPECT_NEAR(from_increments.poses[i].theta, truth[i].theta, 1e-12);
  }
  EXPECT_NEAR(from_poses.increments[2].turn_rad, 0.17, 1e-12);
  EXPECT_NEAR(from_poses.increments[4].distance_m, -0.2, 1e-12);
}

TEST(Odometry, BadFilesAreReportedWithTheLine) {
  testing::TempDir dir;
  const std::string path = dir.Path("odometry.csv");
  auto error_for = [&](const std::string& text, long rows = -1) {
    std::ofstream(path) << text;
    return ErrorOf([&] { ReadOdometry(path, rows); });
  };
  const std::string header = "frame,x_m,y_m,theta_rad\n";
  EXPECT_EQ(error_for(header + "0,0,0,0\n2,0,0,0\n"),
            path + ":3: expected frame 1, found 2 (rows must be frames 0,1,2,... in order)");
  EXPECT_EQ(error_for(header + "0,0,0,0\n1,nan,0,0\n"),
            path + ":3: column 'x_m': value is NaN or infinite");
  EXPECT_EQ(error_for(header + "0,0,0,0\n1,0,0,0\n", 3),
            path + ": has 2 rows but the run has 3 frames");
  EXPECT_EQ(error_for(header), path + ": no odometry rows");
  EXPECT_TRUE(Contains(error_for("frame,a,b\n0,1,2\n"), "needs columns x_m,y_m,theta_rad"));
  EXPECT_EQ(error_for(header + "0,0,0\n"),
            path + ":2: expected 4 fields as in the header, found 3");
  // Physical bounds: a finite but absurd position, and increments that each
  // stay in bounds but add up beyond them.
  const std::string bound = " (docs/formats.md, Bounds)";
  EXPECT_EQ(error_for(header + "0,0,0,0\n1,0,1e30,0\n"),
            path + ":3: column 'y_m': 1e+30 is outside [-100000, 100000] m" + bound);
  EXPECT_EQ(error_for(header + "0,0,0,1e9\n"),
            path + ":2: column 'theta_rad': 1e+09 is outside [-100, 100] rad" + bound);
  std::string far = "frame,distance_m,turn_rad\n0,0,0\n";
  for (int i = 1; i <= 3; ++i) far += std::to_string(i) + ",60000,0\n";
  EXPECT_EQ(error_for(far),
            path +
                ":4: the odometry reaches (120000, 0) m at frame 2, beyond the position bound "
                "of +-100000 m" +
                bound);
  EXPECT_EQ(error_for(header + "0,0,0,0\n1,0,0,99999999999999999999\n"),
            path + ":3: column 'theta_rad': 1e+20 is outside [-100, 100] rad" + bound);
}

TEST(Frames, ImagesAreSortedByNameAndBadImagesNamed) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir.Path("frames"));
  const cv::Mat image(4, 6, CV_8UC3, cv::Scalar(10, 20, 30));
  cv::imwrite(dir.Path("frames/000002.png"), image);
  cv::imwrite(dir.Path("frames/000001.png"), image * 2);
  std::ofstream(dir.Path("frames/000003.jpg")) << "not a jpeg";
  std::ofstream(dir.Path("frames/notes.txt")) << "ignored";
  const FrameSource frames(dir.Path());
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames.Read(0).at<cv::Vec3b>(0, 0), cv::Vec3b(20, 40, 60));
  EXPECT_EQ(frames.Read(1).cols, 6);
  EXPECT_EQ(
      ErrorOf([&] { frames.Read(2); }),
      dir.Path("frames/000003.jpg") + ": not an image (expected PNG, JPEG, BMP, TIFF or PNM data)");
}

// A short video whose frame i is a flat grey of level 10·i: lossy codecs
// shift flat frames by a few levels (about -4 here), less than the half step
// that would mistake one frame for its neighbour.
std::string WriteGreyVideo(const std::string& path, int frames, double fps) {
  cv::VideoWriter writer;
  for (const char* codec : {"avc1", "mp4v"})
    if (writer.open(path, cv::CAP_FFMPEG,
                    cv::VideoWriter::fourcc(codec[0], codec[1], codec[2], codec[3]), fps,
                    cv::Size(64, 48)))
      break;
  EXPECT_TRUE(writer.isOpened());
  for (int i = 0; i < frames; ++i)
    writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(10.0 * i)));
  writer.release();
  return path;
}

double GreyLevel(const cv::Mat& frame) {
  return cv::mean(frame)[0];
}

TEST(Frames, VideoFramesAreTheRightOnesInAnyOrderOfReading) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir.Path("run"));
  const std::string video = WriteGreyVideo(dir.Path("run/robot.mp4"), 25, 25.0);
  // The video file itself names the run (its folder).
  const FrameSource frames(video);
  ASSERT_TRUE(frames.is_video());
  ASSERT_EQ(frames.size(), 25u);
  for (size_t i : {0, 1, 2, 20, 5, 6, 24, 7})
    EXPECT_NEAR(GreyLevel(frames.Read(i)), 10.0 * i, 5.0) << i;
  // Several threads reading in (nearly) increasing order share one decoder.
  std::vector<double> levels(25);
  ParallelFor(0, 25, 3, [&](size_t i) { levels[i] = GreyLevel(frames.Read(i)); });
  for (size_t i = 0; i < 25; ++i) EXPECT_NEAR(levels[i], 10.0 * i, 5.0) << i;
  // Frame times from the container's frame rate.
  ASSERT_EQ(frames.times().size(), 25u);
  EXPECT_EQ(frames.times_source(), "video frame rate");
  EXPECT_NEAR(frames.times()[10], 10 / 25.0, 1e-9);
  EXPECT_EQ(RunFolderPaths::Of(video).dir, dir.Path("run"));
  EXPECT_EQ(RunFolderPaths::Of(video).odometry, dir.Path("run/odometry.csv"));
}

TEST(Frames, FrameTimesCsvGivesTheTimesAndIsChecked) {
  testing::TempDir dir;
  WriteGreyVideo(dir.Path("video.mp4"), 4, 30.0);
  WriteTextFileAtomically(dir.Path("frame_times.csv"),
                          "frame,stamp_s\n0,100.5\n1,100.53\n2,100.6\n3,100.61\n");
  const FrameSource frames(dir.Path());
  EXPECT_EQ(frames.times(), (std::vector<double>{100.5, 100.53, 100.6, 100.61}));
  EXPECT_EQ(frames.times_source(), "frame_times.csv");
  WriteTextFileAtomically(dir.Path("frame_times.csv"), "frame,stamp_s\n0,1\n1,1\n2,2\n3,3\n");
  EXPECT_EQ(
      ErrorOf([&] { FrameSource again(dir.Path()); }),
      dir.Path("frame_times.csv") + ":3: stamp_s must be finite and increase from row to row");
  WriteTextFileAtomically(dir.Path("frame_times.csv"), "frame,stamp_s\n0,1\n");
  EXPECT_EQ(ErrorOf([&] { FrameSource again(dir.Path()); }),
            dir.Path("frame_times.csv") + ": has 1 rows but the run has 4 frames");
}

TEST(Frames, MissingOrEmptyFoldersAreReported) {
  testing::TempDir dir;
  EXPECT_EQ(ErrorOf([&] { FrameSource frames(dir.Path("absent")); }),
            dir.Path("absent") + ": run folder (or video file) not found");
  EXPECT_EQ(ErrorOf([&] { FrameSource frames(dir.Path()); }),
            dir.Path() + ": no frames/ folder and no video.* file");
  std::filesystem::create_directories(dir.Path("frames"));
  EXPECT_EQ(ErrorOf([&] { FrameSource frames(dir.Path()); }),
            dir.Path("frames") + ": no image files (png, jpg, bmp, tif)");
}

TEST(GroundTruth, WriteThenReadRoundTrips) {
  testing::TempDir dir;
  EXPECT_FALSE(ReadGroundTruth(dir.Path()).has_value());
  GroundTruth truth;
  truth.trajectory = {{0, 0, 0}, {0.2, 0.01, 0.1}};
  GroundTruthObject box;
  box.id = 7;
  box.class_name = "green box";
  box.shape = "box";
  box.base_world = {1.5, -0.5, 0};
  box.length_m = 0.49;
  box.width_m = 0.47;
  box.diameter_m = std::hypot(0.49, 0.47);
  box.height_m = 0.57;
  box.yaw_rad = 0.3;
  truth.objects = {box};
  truth.sightings = {{1, 7, 120.5, -0.4, 30.25, 0.3, 0.8}};
  WriteGroundTruth(truth, dir.Path());
  const std::optional<GroundTruth> read = ReadGroundTruth(dir.Path());
  ASSERT_TRUE(read.has_value());
  ASSERT_EQ(read->objects.size(), 1u);
  EXPECT_EQ(read->objects[0].class_name, "green box");
  EXPECT_EQ(read->objects[0].base_world, box.base_world);
  EXPECT_EQ(read->objects[0].diameter_m, box.diameter_m);
  ASSERT_EQ(read->sightings.size(), 1u);
  EXPECT_EQ(read->sightings[0].s_r_px, 30.25);
  EXPECT_EQ(read->trajectory[1].theta, 0.1);

  std::ofstream(dir.Path("ground_truth/sightings.csv"), std::ios::app) << "1,8,1,1,1,1,1\n";
  EXPECT_EQ(ErrorOf([&] { ReadGroundTruth(dir.Path()); }),
            dir.Path("ground_truth/sightings.csv") + ": object_id 8 not in " +
                dir.Path("ground_truth/objects.csv"));
}

}  // namespace
}  // namespace oslam

namespace oslam {
namespace {

TEST(Classes, ConfusionMatrixRoundTripsAndIsChecked) {
  testing::TempDir dir;
  ObjectClass door = GreenBox();
  door.name = "orange door";
  const ConfusionMatrix confusion = {{0.9, 0.1}, {0.25, 0.75}};
  WriteClasses({GreenBox(), door}, dir.Path("classes.yaml"), confusion);
  EXPECT_EQ(ReadClasses(dir.Path("classes.yaml")).size(), 2u);
  const std::optional<ConfusionMatrix> read = ReadConfusion(dir.Path("classes.yaml"));
  ASSERT_TRUE(read.has_value());
  EXPECT_EQ(*read, confusion);

  WriteClasses({GreenBox(), door}, dir.Path("plain.yaml"));
  EXPECT_FALSE(ReadConfusion(dir.Path("plain.yaml")).has_value());

  WriteClasses({GreenBox(), door}, dir.Path("bad.yaml"), ConfusionMatrix{{0.9, 0.2}, {0.25, 0.75}});
  EXPECT_EQ(ErrorOf([&] { ReadConfusion(dir.Path("bad.yaml")); }),
            dir.Path("bad.yaml") + ": confusion[0]: must sum to 1, sums to 1.100000");
  WriteClasses({GreenBox(), door}, dir.Path("short.yaml"), ConfusionMatrix{{1.0}});
  EXPECT_EQ(ErrorOf([&] { ReadConfusion(dir.Path("short.yaml")); }),
            dir.Path("short.yaml") + ": confusion: must be a list of 2 rows, one per class");
}

}  // namespace
}  // namespace oslam

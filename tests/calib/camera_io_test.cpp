// camera.yaml (camera_io.h): every camera of camera_cases.h survives a save
// and load bit for bit; hand-written files load; the model registry; bad
// files and refused saves give one-line errors that start with the file.
#include "calib/camera_io.h"

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "calib/camera_cases.h"
#include "calib/hyperbolic_camera.h"
#include "calib/mei_camera.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

using testing::CameraCase;

class SaveAndLoad : public ::testing::TestWithParam<CameraCase> {};

TEST_P(SaveAndLoad, GivesTheSameCamera) {
  const std::unique_ptr<CameraModel> camera = GetParam().make();
  testing::TempDir dir;
  const std::string path = dir.Path("camera.yaml");
  SaveCamera(*camera, path);
  const std::unique_ptr<CameraModel> loaded = LoadCamera(path);
  EXPECT_EQ(loaded->ModelName(), camera->ModelName());
  EXPECT_EQ(loaded->image_width(), camera->image_width());
  EXPECT_EQ(loaded->image_height(), camera->image_height());
  EXPECT_DOUBLE_EQ(loaded->annulus().rim_radius_px, camera->annulus().rim_radius_px);
  EXPECT_DOUBLE_EQ(loaded->annulus().blind_radius_px, camera->annulus().blind_radius_px);
  EXPECT_EQ((loaded->Intrinsics() - camera->Intrinsics()).norm(), 0.0);
  // Same projection, including the flip flag that is not an intrinsic.
  for (const Eigen::Vector3d& point :
       {Eigen::Vector3d(1.0, 2.0, 0.3), Eigen::Vector3d(-2.5, 0.4, 0.0)}) {
    Eigen::Vector2d a, b;
    ASSERT_TRUE(camera->ProjectToPixel(point, &a));
    ASSERT_TRUE(loaded->ProjectToPixel(point, &b));
    EXPECT_EQ((a - b).norm(), 0.0);
  }
  // Saving what was loaded gives the same file.
  SaveCamera(*loaded, dir.Path("again.yaml"));
  EXPECT_EQ(ReadTextFile(dir.Path("again.yaml")), ReadTextFile(path));
}

INSTANTIATE_TEST_SUITE_P(AllModels, SaveAndLoad, ::testing::ValuesIn(testing::Cameras()),
                         [](const auto& info) { return info.param.name; });

TEST(CameraYaml, TheWrittenFileIsPlainOpenCvYaml) {
  testing::TempDir dir;
  const std::string path = dir.Path("camera.yaml");
  SaveCamera(HyperbolicCamera::Preset("lpa"), path);
  // Readable by OpenCV tools: cv::FileStorage alone, no oslam reader.
  cv::FileStorage fs(path, cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  EXPECT_EQ(static_cast<std::string>(fs["model"]), "hyperbolic");
  EXPECT_EQ(static_cast<int>(fs["image_width"]), 640);
  EXPECT_EQ(static_cast<int>(fs["flip_image_angle"]), 0);
  const cv::FileNode intrinsics = fs["intrinsics"];
  ASSERT_TRUE(intrinsics.isMap());
  const HyperbolicCamera lpa = HyperbolicCamera::Preset("lpa");
  const std::vector<std::string> names = lpa.IntrinsicNames();
  EXPECT_EQ(intrinsics.size(), names.size());
  for (size_t i = 0; i < names.size(); ++i)
    EXPECT_EQ(static_cast<double>(intrinsics[names[i]]), lpa.Intrinsics()[i]) << names[i];
}

TEST(CameraYaml, EveryRegisteredModelIsCreatedByItsName) {
  const std::vector<std::string> names = CameraModelNames();
  EXPECT_EQ(names, (std::vector<std::string>{"hyperbolic", "mei"}));
  for (const std::string& name : names) {
    const std::unique_ptr<CameraModel> camera = CreateCameraModel(name);
    ASSERT_NE(camera, nullptr);
    EXPECT_EQ(camera->ModelName(), name);
  }
  EXPECT_NE(dynamic_cast<HyperbolicCamera*>(CreateCameraModel("hyperbolic").get()), nullptr);
  EXPECT_NE(dynamic_cast<MeiCamera*>(CreateCameraModel("mei").get()), nullptr);
  try {
    CreateCameraModel("fisheye");
    FAIL() << "an unknown model was created";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "unknown camera model 'fisheye' (known: hyperbolic, mei)");
  }
}

// ---- hand-written files ----

const char* kGoodCamera =
    "model: hyperbolic\nimage_width: 640\nimage_height: 480\nblind_radius_px: 40\n"
    "rim_radius_px: 236\nintrinsics:\n  mirror_a_m: 0.03929\n  mirror_b_m: 0.01965\n"
    "  focus_height_m: 0.76\n  focal_px: 1800\n  center_x_px: 320\n  center_y_px: 240\n"
    "  angle_offset_rad: 0\n";

const char* kGoodMei =
    "model: mei\nimage_width: 800\nimage_height: 600\nblind_radius_px: 45\n"
    "rim_radius_px: 290\nintrinsics:\n  xi: 0.9\n  fx_px: 260\n  fy_px: 258\n  skew_px: 0.3\n"
    "  cx_px: 402\n  cy_px: 297\n  k1: -0.05\n  k2: 0.01\n  p1: 0.001\n  p2: -0.0005\n"
    "  focus_height_m: 1.06\n  mount_roll_rad: 0.02\n  mount_pitch_rad: -0.03\n"
    "  mount_yaw_rad: 0.5\n";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(CameraYaml, HandWrittenFileWithoutYamlDirectiveLoads) {
  testing::TempDir dir;
  std::ofstream(dir.Path("camera.yaml")) << kGoodCamera;
  const std::unique_ptr<CameraModel> camera = LoadCamera(dir.Path("camera.yaml"));
  EXPECT_EQ(camera->ModelName(), "hyperbolic");
  EXPECT_DOUBLE_EQ(camera->Intrinsics()[3], 1800.0);
  // flip_image_angle is optional and off by default.
  const auto* hyperbolic = dynamic_cast<const HyperbolicCamera*>(camera.get());
  ASSERT_NE(hyperbolic, nullptr);
  EXPECT_FALSE(hyperbolic->parameters().flip_image_angle);
  std::ofstream(dir.Path("flipped.yaml")) << kGoodCamera << "flip_image_angle: 1\n";
  const std::unique_ptr<CameraModel> flipped = LoadCamera(dir.Path("flipped.yaml"));
  EXPECT_TRUE(dynamic_cast<const HyperbolicCamera&>(*flipped).parameters().flip_image_angle);
}

// flip_image_angle is the hyperbolic model's: a Mei file with it set is
// refused (never silently unflipped); 0 is accepted; only 0 and 1 are values.
TEST(CameraYaml, FlipImageAngleIsRefusedWhereTheModelHasNone) {
  testing::TempDir dir;
  std::ofstream(dir.Path("mei_flipped.yaml")) << kGoodMei << "flip_image_angle: 1\n";
  try {
    LoadCamera(dir.Path("mei_flipped.yaml"));
    ADD_FAILURE() << "a mei camera with flip_image_angle: 1 was loaded";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), dir.Path("mei_flipped.yaml") +
                                         ": flip_image_angle: only the hyperbolic model has "
                                         "it; the mei model does not");
  }
  std::ofstream(dir.Path("mei_unflipped.yaml")) << kGoodMei << "flip_image_angle: 0\n";
  EXPECT_EQ(LoadCamera(dir.Path("mei_unflipped.yaml"))->ModelName(), "mei");
  std::ofstream(dir.Path("two.yaml")) << kGoodCamera << "flip_image_angle: 2\n";
  try {
    LoadCamera(dir.Path("two.yaml"));
    ADD_FAILURE() << "flip_image_angle: 2 was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), dir.Path("two.yaml") + ": flip_image_angle: must be 0 or 1");
  }
}

TEST(CameraYaml, HandWrittenMeiFileSetsEveryParameterByName) {
  testing::TempDir dir;
  std::ofstream(dir.Path("camera.yaml")) << kGoodMei;
  const std::unique_ptr<CameraModel> camera = LoadCamera(dir.Path("camera.yaml"));
  const auto* mei = dynamic_cast<const MeiCamera*>(camera.get());
  ASSERT_NE(mei, nullptr);
  const MeiParameters& p = mei->parameters();
  EXPECT_EQ(p.xi, 0.9);
  EXPECT_EQ(p.fx_px, 260.0);
  EXPECT_EQ(p.fy_px, 258.0);
  EXPECT_EQ(p.skew, 0.3);
  EXPECT_EQ(p.cx_px, 402.0);
  EXPECT_EQ(p.cy_px, 297.0);
  EXPECT_EQ(p.k1, -0.05);
  EXPECT_EQ(p.k2, 0.01);
  EXPECT_EQ(p.p1, 0.001);
  EXPECT_EQ(p.p2, -0.0005);
  EXPECT_EQ(p.focus_height_m, 1.06);
  EXPECT_EQ(p.mount_roll_rad, 0.02);
  EXPECT_EQ(p.mount_pitch_rad, -0.03);
  EXPECT_EQ(p.mount_yaw_rad, 0.5);
  EXPECT_EQ(camera->image_width(), 800);
  EXPECT_EQ(camera->image_height(), 600);
  EXPECT_EQ(camera->annulus().blind_radius_px, 45.0);
  EXPECT_EQ(camera->annulus().rim_radius_px, 290.0);
}

// ---- errors: one line, starting with the file, naming the problem ----

std::string LoadError(const std::string& text) {
  testing::TempDir dir;
  const std::string path = dir.Path("camera.yaml");
  std::ofstream(path) << text;
  try {
    LoadCamera(path);
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path, 0), 0u) << "message must start with the file: " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos);
    return message;
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return "";
}

TEST(CameraYaml, BadFilesGiveOneLineErrorsNamingTheProblem) {
  const std::string good = kGoodCamera;
  EXPECT_NE(
      LoadError(Replace(good, "model: hyperbolic", "model: fisheye")).find("unknown camera model"),
      std::string::npos);
  EXPECT_NE(LoadError(Replace(good, "  focal_px: 1800\n", "")).find("intrinsics.focal_px: missing"),
            std::string::npos);
  EXPECT_NE(LoadError(Replace(good, "focal_px: 1800", "focal_px: .nan")).find("NaN"),
            std::string::npos);
  EXPECT_NE(LoadError(Replace(good, "focal_px: 1800", "focal_px: abc")).find("must be a number"),
            std::string::npos);
  EXPECT_NE(LoadError(good + "colour: red\n").find("colour: unknown key"), std::string::npos);
  EXPECT_NE(LoadError(Replace(good, "mirror_a_m: 0.03929", "mirror_a_m: -1")).find("mirror_a_m"),
            std::string::npos);
  EXPECT_NE(LoadError(Replace(good, "rim_radius_px: 236", "rim_radius_px: 10")).find("annulus"),
            std::string::npos);
  EXPECT_NE(LoadError(Replace(good, "image_width: 640\n", "")).find("image_width: missing"),
            std::string::npos);
  EXPECT_NE(LoadError("model: [oops\n").find("line 1"), std::string::npos);
  EXPECT_NE(LoadError("").find("mapping"), std::string::npos);
}

TEST(CameraYaml, IntrinsicsMustBeExactlyTheModelsOwn) {
  const std::string mei = kGoodMei;
  // A Mei file missing one of its parameters, or carrying another model's.
  EXPECT_NE(LoadError(Replace(mei, "  xi: 0.9\n", "")).find("intrinsics.xi: missing"),
            std::string::npos);
  EXPECT_NE(LoadError(Replace(mei, "  k2: 0.01\n", "  k2: 0.01\n  focal_px: 1800\n"))
                .find("intrinsics.focal_px: unknown key"),
            std::string::npos);
  // The model's own checks apply: fx must be positive, xi non-negative.
  EXPECT_NE(LoadError(Replace(mei, "fx_px: 260", "fx_px: 0")).find("invalid camera: fx_px"),
            std::string::npos);
  EXPECT_NE(LoadError(Replace(mei, "xi: 0.9", "xi: -0.1")).find("xi must be >= 0"),
            std::string::npos);
  EXPECT_NE(LoadError(Replace(mei, "model: mei\n", "")).find("model: missing"), std::string::npos);
}

TEST(CameraYaml, MissingFileIsReported) {
  try {
    LoadCamera("/nonexistent/camera.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/camera.yaml: file not found");
  }
}

// ---- saving ----

int FilesIn(const std::string& folder) {
  int count = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(folder)) ++count;
  return count;
}

TEST(CameraYaml, AnInvalidCameraIsNotSavedAndAnOldFileIsKept) {
  testing::TempDir dir;
  const std::string path = dir.Path("camera.yaml");
  SaveCamera(HyperbolicCamera::Preset("lpa"), path);
  const std::string before = ReadTextFile(path);
  MeiParameters p;
  p.fx_px = -1.0;  // invalid
  p.fy_px = 200.0;
  const MeiCamera invalid(p, 640, 480, MirrorAnnulus{40.0, 236.0});
  try {
    SaveCamera(invalid, path);
    FAIL() << "an invalid camera was saved";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message,
              path + ": refusing to save an invalid camera: fx_px and fy_px must be positive");
  }
  EXPECT_EQ(ReadTextFile(path), before);
  EXPECT_EQ(FilesIn(dir.Path()), 1);
}

TEST(CameraYaml, SavingReplacesTheFileWholeAndLeavesNoTempFile) {
  testing::TempDir dir;
  const std::string path = dir.Path("camera.yaml");
  SaveCamera(HyperbolicCamera::Preset("lpa"), path);
  SaveCamera(HyperbolicCamera::Preset("cogniron"), path);
  EXPECT_EQ(FilesIn(dir.Path()), 1);
  const std::unique_ptr<CameraModel> loaded = LoadCamera(path);
  EXPECT_EQ(loaded->Intrinsics(), HyperbolicCamera::Preset("cogniron").Intrinsics());
}

TEST(CameraYaml, SavingCreatesTheFolderOrNamesTheFileItCannotWrite) {
  testing::TempDir dir;
  const std::string nested = dir.Path("calibration/run1/camera.yaml");
  SaveCamera(HyperbolicCamera::Preset("lpa"), nested);
  EXPECT_EQ(LoadCamera(nested)->ModelName(), "hyperbolic");
  // A folder that cannot be made: a file stands where it would go.
  std::ofstream(dir.Path("plain_file")) << "x";
  const std::string blocked = dir.Path("plain_file/camera.yaml");
  try {
    SaveCamera(HyperbolicCamera::Preset("lpa"), blocked);
    FAIL() << "saved under a regular file";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(blocked, 0), 0u) << e.what();
  }
}

}  // namespace
}  // namespace oslam

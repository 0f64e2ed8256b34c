#include "samples/scene.h"

#include <fstream>
#include <functional>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

const char* kGoodScene = R"(name: tiny
camera: {preset: lpa}
classes:
  - {name: red can, display_rgb: [200, 30, 30], diameter_mean_m: 0.3, diameter_std_m: 0.1, height_mean_m: 0.5, height_std_m: 0.1}
objects:
  - {class: red can, shape: cylinder, position_m: [2, 1], diameter_m: 0.3, height_m: 0.5, colour: [200, 30, 30]}
path: {start_pose: [0, 0, 0], commands: "F3 L2"}
)";

// Writes `text` as a scene file and returns the error LoadScene raises ("" if none).
std::string LoadError(const testing::TempDir& dir, const std::string& text) {
  const std::string path = dir.Path("scene.yaml");
  std::ofstream(path) << text;
  try {
    LoadScene(path);
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << "error must be one line: " << message;
    return message;
  }
  return "";
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(Scene, ParsesAGoodSceneWithDefaults) {
  testing::TempDir dir;
  std::ofstream(dir.Path("scene.yaml")) << kGoodScene;
  const Scene scene = LoadScene(dir.Path("scene.yaml"));
  EXPECT_EQ(scene.name, "tiny");
  EXPECT_EQ(scene.seed, 1u);
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_EQ(scene.objects[0].class_name, "red can");
  EXPECT_EQ(scene.objects[0].shape, ShapeKind::kCylinder);
  EXPECT_DOUBLE_EQ(scene.objects[0].diameter_m, 0.3);
  EXPECT_EQ(scene.camera->image_width(), 640);
  EXPECT_DOUBLE_EQ(scene.path_spec.step_m, 0.2);
  EXPECT_NEAR(scene.path_spec.turn_step_rad, DegToRad(10.0), 1e-12);
  EXPECT_EQ(scene.odometry.scale, 1.0);
  EXPECT_EQ(scene.path_spec.commands, "F3 L2");
}

TEST(Scene, BadInputGivesOneLineErrorsNamingFileAndKey) {
  testing::TempDir dir;
  const std::string file = dir.Path("scene.yaml") + ": ";
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "shape: cylinder", "shape: cone")),
            file +
                "objects[0].shape: unknown shape 'cone' (known: cylinder, box, sphere, panel, "
                "checkerboard)");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "class: red can,", "class: blue can,")),
            file + "objects[0].class: 'blue can' is not listed under classes");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "height_m: 0.5, colour", "width_m: 0.5, colour")),
            file + "objects[0].width_m: not used by shape cylinder");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "diameter_m: 0.3, height_m",
                                   "diameter_m: -0.3, height_m")),
            file + "objects[0].diameter_m: must be positive");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "position_m: [2, 1]", "position_m: [2]")),
            file + "objects[0].position_m: expected 2 numbers, found 1");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "colour: [200, 30, 30]}", "colour: [300, 30, 30]}")),
            file + "objects[0].colour: entries must be 0..255");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "colour: [200, 30, 30]}", "colur: [200, 30, 30]}"))
                .rfind(file + "objects[0].colur: unknown key (allowed: class, shape,", 0),
            0u);
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "{preset: lpa}", "{preset: fisheye}")),
            file + "camera.preset: unknown camera preset 'fisheye' (known: lpa, cogniron)");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "camera: {preset: lpa}\n", "")),
            file + "camera: missing");
  EXPECT_EQ(LoadError(dir, "camera: {preset: lpa}\nclasses: []\n"),
            file + "classes: no classes listed");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "\"F3 L2\"", "\"F3 X2\"")),
            file +
                "path.commands: unknown command letter 'X' (use F, B, L, R with an optional "
                "repeat count, e.g. F5 L9)");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "commands: \"F3 L2\"", "step_m: 0.2")),
            file + "path: give exactly one of waypoints_m and commands");
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "path:", "odometry: {noise_scale: -1}\npath:")),
            file + "odometry.noise_scale: must not be negative");
  EXPECT_EQ(
      LoadError(dir, Replace(kGoodScene, "objects:", "walls:\n  - {points_m: [[0, 0]]}\nobjects:")),
      file + "walls[0].points_m: needs at least 2 points");
  EXPECT_EQ(
      LoadError(dir, Replace(kGoodScene, "colour: [200, 30, 30]}",
                             "colour: [200, 30, 30], texture: {pattern: image, file: nothere.png, "
                             "size_m: [1, 1]}}")),
      file + "objects[0].texture.file: " + dir.Path("nothere.png") + ": file not found");
}

TEST(Scene, ParsesACheckerboard) {
  testing::TempDir dir;
  const std::string board =
      "{shape: checkerboard, position_m: [1, 0.5, 0.8], cols: 8, rows: 7, square_m: 0.03}";
  std::ofstream(dir.Path("scene.yaml"))
      << Replace(kGoodScene, "objects:\n", "objects:\n  - " + board + "\n");
  const Scene scene = LoadScene(dir.Path("scene.yaml"));
  ASSERT_EQ(scene.objects.size(), 2u);
  const SceneObject& b = scene.objects[0];
  EXPECT_EQ(b.shape, ShapeKind::kCheckerboard);
  EXPECT_EQ(b.board_cols, 8);
  EXPECT_EQ(b.board_rows, 7);
  EXPECT_DOUBLE_EQ(b.margin_m, 0.03);  // default: one square
  EXPECT_DOUBLE_EQ(b.center_z_m, 0.8);
  EXPECT_NEAR(b.length_m, 0.30, 1e-12);
  EXPECT_NEAR(b.height_m, 0.27, 1e-12);
  EXPECT_NEAR(b.base_z_m, 0.8 - 0.135, 1e-12);  // upright: lowest point of the margin
  EXPECT_EQ(b.material.albedo_rgb, Eigen::Vector3f(1, 1, 1));
  EXPECT_EQ(b.material.albedo2_rgb, Eigen::Vector3f(0, 0, 0));
  // Upright, facing -y, rows horizontal: the first inner corner is one square
  // in from the pattern's lower-left corner.
  const std::vector<Eigen::Vector3d> corners = CheckerboardInnerCorners(b);
  ASSERT_EQ(corners.size(), 42u);
  EXPECT_LT((corners[0] - Eigen::Vector3d(1 - 0.09, 0.5, 0.8 - 0.075)).norm(), 1e-12);
  EXPECT_LT((corners[6] - Eigen::Vector3d(1 + 0.09, 0.5, 0.8 - 0.075)).norm(), 1e-12);
  EXPECT_EQ(GroundTruthOf(b, 0).shape, "checkerboard");
  // Tilt and roll keep the board's axes orthonormal and right-handed.
  SceneObject tilted = b;
  tilted.yaw_rad = 0.4, tilted.pitch_rad = -0.3, tilted.roll_rad = 1.1;
  const Eigen::Matrix3d r = CheckerboardRotation(tilted);
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_LT((r.col(0).cross(r.col(1)) - r.col(2)).norm(), 1e-12);

  const std::string file = dir.Path("scene.yaml") + ": ";
  auto with_board = [&](const std::string& from, const std::string& to) {
    return LoadError(
        dir, Replace(kGoodScene, "objects:\n", "objects:\n  - " + Replace(board, from, to) + "\n"));
  };
  EXPECT_EQ(with_board("[1, 0.5, 0.8]", "[1, 0.5]"),
            file + "objects[0].position_m: expected 3 numbers, found 2");
  EXPECT_EQ(with_board("cols: 8", "cols: 2"), file + "objects[0].cols: must be at least 3 squares");
  EXPECT_EQ(with_board("square_m: 0.03", "square_m: 0"),
            file + "objects[0].square_m: must be positive");
  EXPECT_EQ(with_board("square_m: 0.03", "square_m: 0.03, height_m: 1"),
            file + "objects[0].height_m: not used by shape checkerboard");
  EXPECT_EQ(with_board("square_m: 0.03", "square_m: 0.03, base_z_m: 1"),
            file + "objects[0].base_z_m: not used by shape checkerboard");
  EXPECT_EQ(with_board("square_m: 0.03", "square_m: 0.03, margin_m: -1"),
            file + "objects[0].margin_m: must not be negative");
  EXPECT_EQ(with_board("square_m: 0.03", "square_m: 0.03, tilt_rad: 1")
                .rfind(file + "objects[0].tilt_rad: unknown key (allowed: class, shape,", 0),
            0u);
  EXPECT_EQ(LoadError(dir, Replace(kGoodScene, "height_m: 0.5, colour",
                                   "height_m: 0.5, rows: 3, colour")),
            file + "objects[0].rows: not used by shape cylinder");
}

TEST(Scene, BoxGroundTruthDiameterIsTheFootprintDiagonal) {
  SceneObject box;
  box.shape = ShapeKind::kBox;
  box.length_m = 0.49;
  box.width_m = 0.47;
  box.height_m = 0.57;
  const GroundTruthObject truth = GroundTruthOf(box, 3);
  EXPECT_NEAR(truth.diameter_m, 0.679, 1e-3);  // thesis Table 6.3, green box: 0.68 m
  EXPECT_EQ(truth.shape, "box");
  EXPECT_EQ(truth.id, 3);
}

TEST(Scene, ShippedScenesLoad) {
  for (const char* name : {"lab", "long_loop", "house", "look_alike_room", "look_alike_hall"}) {
    const std::string path = std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/" + name + ".yaml";
    SCOPED_TRACE(path);
    const Scene scene = LoadScene(path);
    EXPECT_FALSE(scene.classes.empty());
    // LoadScene checks every object's class is listed; here every listed
    // class must also appear in the scene.
    for (const ObjectClass& c : scene.classes) {
      bool used = false;
      for (const SceneObject& object : scene.objects) used = used || object.class_name == c.name;
      EXPECT_TRUE(used) << c.name;
    }
  }
}

}  // namespace
}  // namespace oslam

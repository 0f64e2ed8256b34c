// End-to-end calibration on simulator renders
// (docs/calibration.md): checkerboard views of a known
// camera are rendered by the simulator (shape: checkerboard), written as
// PNGs, and calibrated by the real `oslam calibrate` (corner detection on the
// raw image, rim detection, LM). Tolerances from the issue: f/c (Mei: fx/(1+ξ),
// fy/(1+ξ)) within 0.5 %, image centre within 1 px, RMS <= 0.3 px.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "calib/mei_camera.h"
#include "core/atomic_file.h"
#include "samples/renderer.h"
#include "samples/scene.h"
#include "test_util.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

constexpr int kViews = 14;
constexpr int kCols = 8, kRows = 7;  // squares: 7x6 inner corners
constexpr double kSquare = 0.03;

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.9g", value);
  return text;
}

// One flat-lit scene with a single board; sensor noise 2 grey levels.
std::string SceneText(const std::string& camera, const SceneObject& board) {
  std::ostringstream out;
  out << "camera: " << camera << "\n"
      << "classes:\n"
         "  - {name: thing, display_rgb: [200, 30, 30], diameter_mean_m: 0.3, "
         "diameter_std_m: 0.1, height_mean_m: 0.5, height_std_m: 0.1}\n"
         "floor: {colour: [110, 105, 100]}\n"
         "ceiling: {height_m: 2.4, colour: [170, 170, 165]}\n"
         "lighting: {ambient: 1.0}\n"
         "sensor: {noise_std: 2.0}\n"
         "objects:\n"
      << "  - {shape: checkerboard, position_m: [" << Number(board.position.x()) << ", "
      << Number(board.position.y()) << ", " << Number(board.center_z_m) << "], cols: " << kCols
      << ", rows: " << kRows << ", square_m: " << kSquare << ", yaw_rad: " << Number(board.yaw_rad)
      << ", pitch_rad: " << Number(board.pitch_rad) << ", roll_rad: " << Number(board.roll_rad)
      << ", colour: [235, 235, 235], colour2: [20, 20, 20]}\n"
      << "path: {start_pose: [0, 0, 0], commands: F1}\n";
  return out.str();
}

// True when the whole board (margin included) images inside the annulus,
// `margin_px` clear of the blind disc and the rim.
bool BoardInAnnulus(const CameraModel& camera, const SceneObject& board, double margin_px) {
  const Eigen::Matrix3d rotation = CheckerboardRotation(board);
  const Eigen::Vector3d centre(board.position.x(), board.position.y(), board.center_z_m);
  const double half_u = 0.5 * board.length_m, half_v = 0.5 * board.height_m;
  for (int i = 0; i <= 10; ++i) {
    for (int j = 0; j <= 10; ++j) {
      if (i % 10 != 0 && j % 10 != 0) continue;  // the outline only
      const Eigen::Vector3d point = centre + rotation.col(0) * half_u * (i / 5.0 - 1.0) +
                                    rotation.col(1) * half_v * (j / 5.0 - 1.0);
      Eigen::Vector2d pixel;
      if (!camera.ProjectToPixel(point, &pixel)) return false;
      const double radius = camera.PixelToPolar(pixel).radius_px;
      if (radius < camera.annulus().blind_radius_px + margin_px ||
          radius > camera.annulus().rim_radius_px - margin_px || pixel.x() < margin_px ||
          pixel.y() < margin_px || pixel.x() > camera.image_width() - 1 - margin_px ||
          pixel.y() > camera.image_height() - 1 - margin_px)
        return false;
    }
  }
  return true;
}

// Board poses around the camera (robot at the origin, viewpoint at
// focus_height_m): all bearings, 0.3..0.45 m away, elevations between
// `min_elevation` and `max_elevation`, facing the viewpoint with random tilt
// and in-plane roll. Seeded.
std::vector<SceneObject> BoardPoses(const CameraModel& camera, double focus_height_m,
                                    double min_elevation, double max_elevation,
                                    std::uint64_t seed) {
  std::mt19937_64 engine(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<SceneObject> boards;
  for (int attempt = 0; static_cast<int>(boards.size()) < kViews && attempt < 5000; ++attempt) {
    const double bearing = 2.0 * M_PI * boards.size() / kViews + 0.3 * (uniform(engine) - 0.5);
    const double distance = 0.3 + 0.15 * uniform(engine);
    const double elevation = min_elevation + (max_elevation - min_elevation) * uniform(engine);
    SceneObject board;
    board.shape = ShapeKind::kCheckerboard;
    board.board_cols = kCols;
    board.board_rows = kRows;
    board.square_m = board.margin_m = kSquare;
    board.length_m = kCols * kSquare + 2 * kSquare;
    board.height_m = kRows * kSquare + 2 * kSquare;
    board.position = distance * Eigen::Vector2d(std::cos(bearing), std::sin(bearing));
    board.center_z_m = focus_height_m + distance * std::tan(elevation);
    board.yaw_rad = bearing + M_PI / 2;  // board plane across the line of sight
    board.pitch_rad = -elevation + 0.7 * (uniform(engine) - 0.5);
    board.roll_rad = 0.8 * (uniform(engine) - 0.5);
    if (BoardInAnnulus(camera, board, 4.0)) boards.push_back(board);
  }
  EXPECT_EQ(static_cast<int>(boards.size()), kViews);
  return boards;
}

// Renders one PNG per board into `dir`; returns the render time.
double RenderViews(const std::string& camera_line, const std::vector<SceneObject>& boards,
                   const std::string& scene_dir, const std::string& image_dir) {
  fs::create_directories(image_dir);
  const auto start = std::chrono::steady_clock::now();
  for (size_t k = 0; k < boards.size(); ++k) {
    const std::string scene_path = scene_dir + "/view_" + std::to_string(k) + ".yaml";
    std::ofstream(scene_path) << SceneText(camera_line, boards[k]);
    const Scene scene = LoadScene(scene_path);
    const Renderer renderer(scene);
    FrameConditions conditions;
    conditions.noise_key = 1000 + k;
    FrameRender render;
    renderer.Render(Pose2{0.0, 0.0, 0.0}, conditions, &render);
    char name[32];
    std::snprintf(name, sizeof(name), "/view_%02zu.png", k);
    EXPECT_TRUE(cv::imwrite(image_dir + name, render.image));
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

testing::CommandResult Calibrate(const std::string& image_dir, const std::string& options,
                                 const std::string& output) {
  const auto start = std::chrono::steady_clock::now();
  const testing::CommandResult result =
      testing::RunShellCommand(std::string(OSLAM_BINARY) + " calibrate " + image_dir +
                               " --pattern 7x6 --square 0.03 " + options + " -o " + output);
  std::printf("oslam calibrate %s: %.1f s\n%s%s", options.c_str(),
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
              result.out.c_str(), result.err.c_str());
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out.find("BOARD NOT FOUND"), std::string::npos) << "every view has a board";
  EXPECT_EQ(result.out.find("OUTLIER"), std::string::npos);
  return result;
}

// The final RMS oslam calibrate prints in its LM summary ("RMS a -> b px").
double PrintedRms(const std::string& out) {
  const size_t at = out.find(" px", out.find("LM:"));
  const size_t arrow = out.rfind("-> ", at);
  EXPECT_NE(arrow, std::string::npos) << out;
  return arrow == std::string::npos ? 1e9 : std::atof(out.c_str() + arrow + 3);
}

TEST(CalibrationOnRenders, RecoversTheLpaHyperbolicCamera) {
  testing::TempDir dir;
  const HyperbolicCamera lpa = HyperbolicCamera::Preset("lpa");
  const HyperbolicMirrorParameters& truth = lpa.parameters();
  const std::vector<SceneObject> boards = BoardPoses(lpa, truth.focus_height_m, -0.8, 0.05, 11);
  const double render_seconds =
      RenderViews("{preset: lpa}", boards, dir.Path(), dir.Path("images"));
  std::printf("rendered %d LPA views in %.1f s\n", kViews, render_seconds);

  // b from the data sheet (the setting; f/c and b are nearly
  // interchangeable for this almost-parabolic mirror).
  const testing::CommandResult fixed_b =
      Calibrate(dir.Path("images"),
                "--model hyperbolic --mirror-a 0.03929 --mirror-b 0.01965 --focus-height 0.76 "
                "--mount-yaw 0",
                dir.Path("lpa.yaml"));
  const std::unique_ptr<CameraModel> calibrated = LoadCamera(dir.Path("lpa.yaml"));
  const auto* hyperbolic = dynamic_cast<const HyperbolicCamera*>(calibrated.get());
  ASSERT_NE(hyperbolic, nullptr);
  const double f_error = hyperbolic->parameters().focal_px / truth.focal_px - 1.0;
  const double centre_error = (hyperbolic->ImageCenter() - lpa.ImageCenter()).norm();
  const double rms = PrintedRms(fixed_b.out);
  std::printf("LPA, b fixed: f/c %.2f (%.3f %%), centre (%.2f, %.2f) %.3f px off, RMS %.4f px\n",
              hyperbolic->parameters().focal_px, 100 * f_error, hyperbolic->ImageCenter().x(),
              hyperbolic->ImageCenter().y(), centre_error, rms);
  EXPECT_LT(std::abs(f_error), 0.005);
  EXPECT_LT(centre_error, 1.0);
  EXPECT_LE(rms, 0.3);

  // b estimated: reported; only the fit quality and the centre are asserted.
  const testing::CommandResult free_b = Calibrate(
      dir.Path("images"), "--model hyperbolic --mirror-a 0.03929 --focus-height 0.76 --mount-yaw 0",
      dir.Path("lpa_free_b.yaml"));
  const std::unique_ptr<CameraModel> free_camera = LoadCamera(dir.Path("lpa_free_b.yaml"));
  const auto* free_hyperbolic = dynamic_cast<const HyperbolicCamera*>(free_camera.get());
  ASSERT_NE(free_hyperbolic, nullptr);
  std::printf("LPA, b estimated: f/c %.2f, b %.5f (%.5f), centre %.3f px off, RMS %.4f px\n",
              free_hyperbolic->parameters().focal_px, free_hyperbolic->parameters().mirror_b_m,
              truth.mirror_b_m, (free_hyperbolic->ImageCenter() - lpa.ImageCenter()).norm(),
              PrintedRms(free_b.out));
  EXPECT_LE(PrintedRms(free_b.out), 0.3);
  EXPECT_LT((free_hyperbolic->ImageCenter() - lpa.ImageCenter()).norm(), 1.0);
}

TEST(CalibrationOnRenders, RecoversAMeiCameraFromItsCameraYaml) {
  testing::TempDir dir;
  const std::string camera_file =
      std::string(OSLAM_SOURCE_DIR) + "/tests/data/calib_sim/mei_camera.yaml";
  const std::unique_ptr<CameraModel> loaded = LoadCamera(camera_file);
  const auto* truth_camera = dynamic_cast<const MeiCamera*>(loaded.get());
  ASSERT_NE(truth_camera, nullptr);
  const MeiParameters& truth = truth_camera->parameters();
  const std::vector<SceneObject> boards =
      BoardPoses(*truth_camera, truth.focus_height_m, -1.0, 0.15, 12);
  const double render_seconds =
      RenderViews("{file: " + camera_file + "}", boards, dir.Path(), dir.Path("images"));
  std::printf("rendered %d Mei views in %.1f s\n", kViews, render_seconds);

  const testing::CommandResult result = Calibrate(
      dir.Path("images"), "--model mei --focus-height 1.0 --mount-yaw 0", dir.Path("mei.yaml"));
  const std::unique_ptr<CameraModel> calibrated = LoadCamera(dir.Path("mei.yaml"));
  const auto* mei = dynamic_cast<const MeiCamera*>(calibrated.get());
  ASSERT_NE(mei, nullptr);
  const MeiParameters& p = mei->parameters();
  // fx, fy alone trade against ξ and k1 (both fit the corners equally well);
  // the generalised focal length f / (1 + ξ) (the image scale at the mirror
  // axis, the Mei counterpart of the hyperbolic f/c) is what the views fix.
  const double gx_error = (p.fx_px / (1 + p.xi)) / (truth.fx_px / (1 + truth.xi)) - 1.0;
  const double gy_error = (p.fy_px / (1 + p.xi)) / (truth.fy_px / (1 + truth.xi)) - 1.0;
  const double centre_error = (mei->ImageCenter() - truth_camera->ImageCenter()).norm();
  const double rms = PrintedRms(result.out);
  // The calibrated camera images every ray of the annulus where the true one does.
  double max_image_error = 0.0;
  for (int y = 0; y < truth_camera->image_height(); y += 8) {
    for (int x = 0; x < truth_camera->image_width(); x += 8) {
      const Eigen::Vector2d pixel(x, y);
      Ray ray;
      if (!truth_camera->IsInAnnulus(pixel) || !truth_camera->BackProjectPixel(pixel, &ray))
        continue;
      Eigen::Vector2d again;
      ASSERT_TRUE(mei->ProjectToPixel(ray.origin_robot + ray.direction_robot, &again));
      max_image_error = std::max(max_image_error, (again - pixel).norm());
    }
  }
  std::printf(
      "Mei: xi %.4f (%.4f), fx %.2f (%.3f %%), fy %.2f (%.3f %%), fx/(1+xi) %.3f %%, "
      "fy/(1+xi) %.3f %%, centre (%.2f, %.2f) %.3f px off, k1 %.4f (%.4f), k2 %.4f (%.4f), "
      "RMS %.4f px, max image difference over the annulus %.3f px\n",
      p.xi, truth.xi, p.fx_px, 100 * (p.fx_px / truth.fx_px - 1), p.fy_px,
      100 * (p.fy_px / truth.fy_px - 1), 100 * gx_error, 100 * gy_error, p.cx_px, p.cy_px,
      centre_error, p.k1, truth.k1, p.k2, truth.k2, rms, max_image_error);
  EXPECT_LT(std::abs(gx_error), 0.005);
  EXPECT_LT(std::abs(gy_error), 0.005);
  EXPECT_LT(centre_error, 1.0);
  EXPECT_LT(max_image_error, 1.0);
  EXPECT_LE(rms, 0.3);

  // --quiet prints nothing, also with cv::omnidir's comparison table, and
  // writes the same camera.
  const testing::CommandResult quiet = testing::RunShellCommand(
      std::string(OSLAM_BINARY) + " calibrate " + dir.Path("images") +
      " --pattern 7x6 --square 0.03 --model mei --focus-height 1.0 --mount-yaw 0 "
      "--compare-opencv --quiet -o " +
      dir.Path("mei_quiet.yaml"));
  EXPECT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.out, "");
  EXPECT_EQ(quiet.err, "");
  EXPECT_EQ(ReadTextFile(dir.Path("mei_quiet.yaml")), ReadTextFile(dir.Path("mei.yaml")));
}

}  // namespace
}  // namespace oslam

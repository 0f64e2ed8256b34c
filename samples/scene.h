// A simulated world: walls, floor, objects, lights, sensor effects, the robot's
// path and its odometry noise, read from a scene YAML file (reference in
// docs/simulator.md). Everything is in SI units; colours are 0..255 RGB.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"
#include "core/motion_model.h"
#include "core/pose2.h"
#include "core/run_folder.h"

namespace oslam {

enum class TexturePattern { kNone, kChecker, kStripes, kNoise, kImage };

// Surface appearance. Texture coordinates (u, v) are metres on the surface, so
// a pattern keeps its physical size whatever the object.
struct Material {
  Eigen::Vector3f albedo_rgb{0.5f, 0.5f, 0.5f};  // 0..1, from the 0..255 colour
  TexturePattern pattern = TexturePattern::kNone;
  Eigen::Vector3f albedo2_rgb{0.f, 0.f, 0.f};  // second colour of checker/stripes/noise
  double scale_m = 0.1;                  // pattern period (checker square, stripe, noise cell)
  std::uint64_t seed = 0;                // noise pattern
  std::shared_ptr<const cv::Mat> image;  // CV_32FC3 RGB 0..1, for kImage
  double image_width_m = 1.0, image_height_m = 1.0;  // physical size of one image tile
};

// A vertical wall between two floor points, from the floor to height_m.
struct WallSegment {
  Eigen::Vector2d from = Eigen::Vector2d::Zero();
  Eigen::Vector2d to = Eigen::Vector2d::Zero();
  double height_m = 2.5;
  Material material;
};

enum class ShapeKind { kCylinder, kBox, kSphere, kPanel, kCheckerboard };
const char* ShapeName(ShapeKind kind);

// One object. position is the centre of its footprint on the floor plan,
// base_z_m the height of its lowest point (the O-Map base point is
// (position, base_z_m)). Boxes: length along the object's own x (yaw_rad from
// the world x axis), width along its y. Panels: a flat vertical rectangle of
// length_m x height_m (a door), seen from both sides. Checkerboards: a flat
// calibration board of board_cols x board_rows squares of square_m with a
// margin_m light border, centred at (position, center_z_m), oriented by
// yaw_rad, pitch_rad, roll_rad (CheckerboardRotation); material.albedo_rgb is
// the light colour (squares and margin), material.albedo2_rgb the dark one.
struct SceneObject {
  std::string class_name;  // empty: a distractor of no class
  ShapeKind shape = ShapeKind::kCylinder;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double base_z_m = 0.0;
  double diameter_m = 0.0;  // cylinder, sphere
  double length_m = 0.0;    // box, panel
  double width_m = 0.0;     // box
  double height_m = 0.0;    // cylinder, box, panel (sphere: = diameter)
  double yaw_rad = 0.0;     // box, panel, checkerboard
  Material material;
  // Checkerboard only (the board's extent is also in length_m x height_m of
  // its plane; base_z_m is its lowest point, for the ground truth).
  int board_cols = 0, board_rows = 0;  // squares
  double square_m = 0.0;
  double margin_m = 0.0;
  double center_z_m = 0.0;
  double pitch_rad = 0.0;  // tilt about the board's own horizontal axis
  double roll_rad = 0.0;   // rotation of the pattern in the board plane
};

// World-from-board rotation of a checkerboard: column 0 is the board's u axis
// (along a row of squares), column 1 its v axis (along a column), column 2 the
// normal u x v. R = Rz(yaw) Rx(pitch) B Rz(roll), with B mapping the board's
// (u, v, n) to world (x, z, -y): at zero angles the board stands upright in
// the x-z plane, rows horizontal.
Eigen::Matrix3d CheckerboardRotation(const SceneObject& board);

// World positions of a checkerboard's (board_cols - 1) x (board_rows - 1)
// inner corners, row-major (u fastest), the points `oslam calibrate` detects.
std::vector<Eigen::Vector3d> CheckerboardInnerCorners(const SceneObject& board);

struct PointLight {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double intensity = 1.0;
  // Distance at which the light has fallen to half; 0 = no fall-off. A dark
  // corridor is a corridor far from every light.
  double range_m = 0.0;
};

struct Lighting {
  double ambient = 0.4;
  std::vector<PointLight> lights;
};

// Imperfections of the camera, applied per frame.
struct SensorEffects {
  double noise_std = 2.0;      // additive Gaussian noise, grey levels (0..255)
  double blur_sigma_px = 0.0;  // Gaussian defocus blur; 0 = sharp
  double exposure_std = 0.0;   // std of the log of a random per-frame gain
  double gain = 1.0;           // overall brightness
};

// Stop-and-go driving (docs/method.md §11.3): every command is one step_m move or one
// turn_step_rad turn, and the robot takes one frame after each.
struct PathSpec {
  Pose2 start;
  double step_m = 0.2;
  double turn_step_rad = 0.17453292519943295;  // 10 degrees
  // How much an executed command differs from the nominal one (standard
  // deviations); the wheel encoders see this, so it shows in the odometry
  // but is not odometry error. 0 gives exact 20 cm / 10 degree increments.
  double step_jitter_m = 0.01;
  double turn_jitter_rad = 0.008726646259971648;  // 0.5 degrees
  // Either waypoints (the driver steers towards each in turn, looking at the
  // true robot) or a fixed command string such as "F5 L9 B2 R1".
  std::vector<Eigen::Vector2d> waypoints;
  std::string commands;
};

struct OdometryNoise {
  MotionNoiseOptions model;  // docs/method.md §4.1 Q_add, Q_mult (standard deviations)
  double scale = 1.0;        // multiplies every standard deviation; 0 = perfect odometry
};

struct Scene {
  std::string path;  // the scene file, for messages
  std::string name;
  std::uint64_t seed = 1;
  long max_frames = -1;  // -1: as many as the path gives
  std::unique_ptr<CameraModel> camera;
  std::string camera_description;  // "preset lpa" or the file
  std::vector<ObjectClass> classes;
  std::vector<WallSegment> walls;
  Material floor;
  bool has_ceiling = false;
  double ceiling_height_m = 0.0;
  Material ceiling;
  Eigen::Vector3f background_rgb{0.f, 0.f, 0.f};  // rays that leave the scene
  std::vector<SceneObject> objects;
  Lighting lighting;
  SensorEffects sensor;
  PathSpec path_spec;
  OdometryNoise odometry;
};

// Parses and validates a scene; throws oslam::Error "FILE: key.path: problem".
Scene LoadScene(const std::string& path);

// The O-Map cylinder equivalent of an object (boxes: diameter sqrt(L^2 + W^2),
// as the thesis' Table 6.3; panels: their length; spheres: height = diameter).
GroundTruthObject GroundTruthOf(const SceneObject& object, int id);

}  // namespace oslam

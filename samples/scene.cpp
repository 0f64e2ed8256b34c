#include "samples/scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "core/bounds.h"
#include "core/error.h"
#include "core/image_file.h"
#include "core/yaml.h"

namespace oslam {

const char* ShapeName(ShapeKind kind) {
  switch (kind) {
    case ShapeKind::kCylinder:
      return "cylinder";
    case ShapeKind::kBox:
      return "box";
    case ShapeKind::kSphere:
      return "sphere";
    case ShapeKind::kPanel:
      return "panel";
    case ShapeKind::kCheckerboard:
      return "checkerboard";
  }
  return "?";
}

Eigen::Matrix3d CheckerboardRotation(const SceneObject& board) {
  const double cy = std::cos(board.yaw_rad), sy = std::sin(board.yaw_rad);
  const double cp = std::cos(board.pitch_rad), sp = std::sin(board.pitch_rad);
  const double cr = std::cos(board.roll_rad), sr = std::sin(board.roll_rad);
  Eigen::Matrix3d yaw, pitch, upright, roll;
  yaw << cy, -sy, 0, sy, cy, 0, 0, 0, 1;
  pitch << 1, 0, 0, 0, cp, -sp, 0, sp, cp;
  upright << 1, 0, 0, 0, 0, -1, 0, 1, 0;  // board (u, v, n) -> world (x, z, -y)
  roll << cr, -sr, 0, sr, cr, 0, 0, 0, 1;
  return yaw * pitch * upright * roll;
}

std::vector<Eigen::Vector3d> CheckerboardInnerCorners(const SceneObject& board) {
  const Eigen::Matrix3d rotation = CheckerboardRotation(board);
  const Eigen::Vector3d centre(board.position.x(), board.position.y(), board.center_z_m);
  std::vector<Eigen::Vector3d> corners;
  for (int j = 1; j < board.board_rows; ++j)
    for (int i = 1; i < board.board_cols; ++i)
      corners.push_back(centre + rotation.col(0) * ((i - 0.5 * board.board_cols) * board.square_m) +
                        rotation.col(1) * ((j - 0.5 * board.board_rows) * board.square_m));
  return corners;
}

GroundTruthObject GroundTruthOf(const SceneObject& object, int id) {
  GroundTruthObject truth;
  truth.id = id;
  truth.class_name = object.class_name;
  truth.shape = ShapeName(object.shape);
  truth.base_world = {object.position.x(), object.position.y(), object.base_z_m};
  truth.yaw_rad = object.yaw_rad;
  switch (object.shape) {
    case ShapeKind::kCylinder:
      truth.diameter_m = object.diameter_m;
      truth.height_m = object.height_m;
      break;
    case ShapeKind::kSphere:
      truth.diameter_m = truth.height_m = object.diameter_m;
      break;
    case ShapeKind::kBox:
      truth.diameter_m = std::hypot(object.length_m, object.width_m);
      truth.height_m = object.height_m;
      truth.length_m = object.length_m;
      truth.width_m = object.width_m;
      break;
    case ShapeKind::kPanel:
    case ShapeKind::kCheckerboard:
      truth.diameter_m = object.length_m;
      truth.height_m = object.height_m;
      truth.length_m = object.length_m;
      break;
  }
  return truth;
}

namespace {

namespace fs = std::filesystem;

constexpr double kSize = bounds::kObjectSizeM, kCoordinate = bounds::kCoordinateM,
                 kAngle = bounds::kAngleRad;
// Squares of a checkerboard along each side: far more than any printed board.
constexpr int kMaxBoardSquares = 1000;
// The sensor blur's kernel grows with its sigma.
constexpr double kMaxBlurPx = 100.0;
// Light intensities and the ambient term, relative to a white surface.
constexpr double kMaxIntensity = 1e6;

// Parsing context: the file (for messages) and the folder relative paths start from.
// Every number is checked against its physical bound (core/bounds.h): the
// renderer's and the path's work grows with them.
struct Reader {
  const YamlFile& file;
  fs::path folder;

  bool Has(const cv::FileNode& node, const std::string& key) const {
    const cv::FileNode value = node[key];
    return !value.empty() && !value.isNone();
  }
  double Positive(const cv::FileNode& node, const std::string& key, const std::string& prefix,
                  double max = kSize) const {
    const double value = file.Double(node, key, prefix);
    if (!(value > 0)) file.Fail(prefix + key, "must be positive");
    return file.Within(value, prefix + key, 0, max);
  }
  double NonNegative(const cv::FileNode& node, const std::string& key, double fallback,
                     const std::string& prefix, double max = kSize) const {
    const double value = file.OptionalDouble(node, key, fallback, prefix);
    if (value < 0) file.Fail(prefix + key, "must not be negative");
    return file.Within(value, prefix + key, 0, max);
  }
  double Angle(const cv::FileNode& node, const std::string& key, const std::string& prefix) const {
    return file.Within(file.OptionalDouble(node, key, 0.0, prefix), prefix + key, -kAngle, kAngle,
                       "rad");
  }
  // `size` numbers, each a coordinate (metres) within the bounds.
  std::vector<double> Coordinates(const cv::FileNode& node, const std::string& key, int size,
                                  const std::string& prefix) const {
    const std::vector<double> v = file.Doubles(node, key, size, prefix);
    for (double value : v) file.Within(value, prefix + key, -kCoordinate, kCoordinate, "m");
    return v;
  }
  Eigen::Vector2d Point2(const cv::FileNode& node, const std::string& key,
                         const std::string& prefix) const {
    const std::vector<double> v = Coordinates(node, key, 2, prefix);
    return {v[0], v[1]};
  }
  // An [x, y] entry of a list of points.
  Eigen::Vector2d ListPoint(const cv::FileNode& point, const std::string& key) const {
    if (!point.isSeq() || point.size() != 2 || !(point[0].isReal() || point[0].isInt()) ||
        !(point[1].isReal() || point[1].isInt()))
      file.Fail(key, "expected [x, y] in metres");
    const Eigen::Vector2d p(static_cast<double>(point[0]), static_cast<double>(point[1]));
    for (int k = 0; k < 2; ++k) file.Within(p[k], key, -kCoordinate, kCoordinate, "m");
    return p;
  }
  Eigen::Vector3f Colour(const cv::FileNode& node, const std::string& key,
                         const std::string& prefix) const {
    const std::vector<double> rgb = file.Doubles(node, key, 3, prefix);
    for (double c : rgb)
      if (c < 0 || c > 255) file.Fail(prefix + key, "entries must be 0..255");
    return Eigen::Vector3f(rgb[0], rgb[1], rgb[2]) / 255.0f;
  }
  cv::FileNode MapOrFail(const cv::FileNode& node, const std::string& key_path) const {
    if (!node.isMap()) file.Fail(key_path, "must be a mapping of key: value");
    return node;
  }
};

TexturePattern ParsePattern(const Reader& r, const std::string& text, const std::string& key) {
  if (text == "none") return TexturePattern::kNone;
  if (text == "checker") return TexturePattern::kChecker;
  if (text == "stripes") return TexturePattern::kStripes;
  if (text == "noise") return TexturePattern::kNoise;
  if (text == "image") return TexturePattern::kImage;
  r.file.Fail(key, "unknown pattern '" + text + "' (known: none, checker, stripes, noise, image)");
}

void ParseTexture(const Reader& r, const cv::FileNode& node, const std::string& prefix,
                  Material* material) {
  r.MapOrFail(node, prefix.substr(0, prefix.size() - 1));
  r.file.RequireOnlyKeys(node, prefix, {"pattern", "colour2", "scale_m", "seed", "file", "size_m"});
  material->pattern = ParsePattern(r, r.file.String(node, "pattern", prefix), prefix + "pattern");
  if (r.Has(node, "colour2")) material->albedo2_rgb = r.Colour(node, "colour2", prefix);
  if (r.Has(node, "scale_m")) material->scale_m = r.Positive(node, "scale_m", prefix);
  material->seed = static_cast<std::uint64_t>(r.file.OptionalInt(node, "seed", 0, prefix));
  if (material->pattern != TexturePattern::kImage) {
    if (r.Has(node, "file")) r.file.Fail(prefix + "file", "only used by pattern: image");
    return;
  }
  const std::string name = r.file.String(node, "file", prefix);
  const std::string image_path = (r.folder / name).string();
  cv::Mat bgr;
  try {
    bgr = ReadImage(image_path);
  } catch (const Error& e) {
    r.file.Fail(prefix + "file", e.what());
  }
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  auto image = std::make_shared<cv::Mat>();
  rgb.convertTo(*image, CV_32FC3, 1.0 / 255.0);
  material->image = image;
  const std::vector<double> size = r.file.Doubles(node, "size_m", 2, prefix);
  if (!(size[0] > 0 && size[1] > 0)) r.file.Fail(prefix + "size_m", "must be positive");
  material->image_width_m = size[0];
  material->image_height_m = size[1];
}

// Reads "colour" and "texture" of `node` (both optional) into a material.
Material ParseMaterial(const Reader& r, const cv::FileNode& node, const std::string& prefix,
                       const Eigen::Vector3f& default_rgb) {
  Material material;
  material.albedo_rgb = r.Has(node, "colour") ? r.Colour(node, "colour", prefix) : default_rgb;
  if (r.Has(node, "texture")) ParseTexture(r, node["texture"], prefix + "texture.", &material);
  return material;
}

std::unique_ptr<CameraModel> ParseCamera(const Reader& r, const cv::FileNode& root,
                                         std::string* description) {
  const cv::FileNode node = r.file.Map(root, "camera");
  r.file.RequireOnlyKeys(node, "camera.", {"preset", "file"});
  if (r.Has(node, "preset") == r.Has(node, "file"))
    r.file.Fail("camera", "give exactly one of preset (lpa, cogniron) and file");
  if (r.Has(node, "preset")) {
    const std::string name = r.file.String(node, "preset", "camera.");
    *description = "preset " + name;
    try {
      return HyperbolicCamera::Preset(name).Clone();
    } catch (const Error& e) {
      r.file.Fail("camera.preset", e.what());
    }
  }
  const std::string camera_path = (r.folder / r.file.String(node, "file", "camera.")).string();
  *description = camera_path;
  return LoadCamera(camera_path);
}

std::vector<ObjectClass> ParseClasses(const Reader& r, const cv::FileNode& root) {
  // classes.yaml must list at least one class for the rest of oslam to read it.
  std::vector<ObjectClass> classes;
  const cv::FileNode list = r.file.Seq(root, "classes");
  if (list.size() == 0) r.file.Fail("classes", "no classes listed");
  for (int i = 0; i < static_cast<int>(list.size()); ++i) {
    const std::string prefix = "classes[" + std::to_string(i) + "].";
    const cv::FileNode node = r.MapOrFail(list[i], prefix.substr(0, prefix.size() - 1));
    r.file.RequireOnlyKeys(node, prefix,
                           {"name", "display_rgb", "shape", "footprint_aspect", "diameter_mean_m",
                            "diameter_std_m", "height_mean_m", "height_std_m"});
    ObjectClass c;
    c.name = r.file.String(node, "name", prefix);
    if (c.name.empty() || c.name.find(',') != std::string::npos)
      r.file.Fail(prefix + "name", "must be non-empty and without commas");
    if (FindClass(classes, c.name) >= 0)
      r.file.Fail(prefix + "name", "duplicate class '" + c.name + "'");
    const Eigen::Vector3f rgb = r.Colour(node, "display_rgb", prefix) * 255.0f;
    for (int k = 0; k < 3; ++k) c.display_rgb[k] = static_cast<int>(std::lround(rgb[k]));
    // The class's shape and box footprint, for the silhouette model (docs/method.md §4.2).
    if (r.Has(node, "shape")) {
      const std::optional<ObjectShape> shape =
          ParseObjectShape(r.file.String(node, "shape", prefix));
      if (!shape) r.file.Fail(prefix + "shape", "must be one of cylinder, box, sphere, panel");
      c.shape = *shape;
    }
    c.footprint_aspect = r.file.OptionalDouble(node, "footprint_aspect", 1.0, prefix);
    if (!(c.footprint_aspect > 0 && c.footprint_aspect <= 1))
      r.file.Fail(prefix + "footprint_aspect", "must be in (0, 1] (footprint width / length)");
    c.diameter_mean_m = r.Positive(node, "diameter_mean_m", prefix);
    c.diameter_std_m = r.Positive(node, "diameter_std_m", prefix);
    r.file.Within(c.diameter_std_m, prefix + "diameter_std_m", bounds::kMinStdM, kSize, "m");
    c.height_mean_m = r.Positive(node, "height_mean_m", prefix);
    c.height_std_m = r.Positive(node, "height_std_m", prefix);
    r.file.Within(c.height_std_m, prefix + "height_std_m", bounds::kMinStdM, kSize, "m");
    classes.push_back(c);
  }
  return classes;
}

// walls: polylines of vertical walls; a gap between two polylines is a doorway.
std::vector<WallSegment> ParseWalls(const Reader& r, const cv::FileNode& root) {
  std::vector<WallSegment> walls;
  if (!r.Has(root, "walls")) return walls;
  const cv::FileNode list = r.file.Seq(root, "walls");
  for (int i = 0; i < static_cast<int>(list.size()); ++i) {
    const std::string prefix = "walls[" + std::to_string(i) + "].";
    const cv::FileNode node = r.MapOrFail(list[i], prefix.substr(0, prefix.size() - 1));
    r.file.RequireOnlyKeys(node, prefix, {"points_m", "closed", "height_m", "colour", "texture"});
    const cv::FileNode points = r.file.Seq(node, "points_m", prefix);
    std::vector<Eigen::Vector2d> corners;
    for (int k = 0; k < static_cast<int>(points.size()); ++k) {
      corners.push_back(r.ListPoint(points[k], prefix + "points_m[" + std::to_string(k) + "]"));
    }
    if (corners.size() < 2) r.file.Fail(prefix + "points_m", "needs at least 2 points");
    const bool closed = r.file.OptionalInt(node, "closed", 0, prefix) != 0;
    const double height = r.Has(node, "height_m") ? r.Positive(node, "height_m", prefix) : 2.5;
    const Material material = ParseMaterial(r, node, prefix, {0.75f, 0.75f, 0.72f});
    const size_t count = closed ? corners.size() : corners.size() - 1;
    for (size_t k = 0; k < count; ++k) {
      WallSegment wall{corners[k], corners[(k + 1) % corners.size()], height, material};
      if ((wall.to - wall.from).norm() < 1e-6)
        r.file.Fail(prefix + "points_m", "two consecutive points coincide");
      walls.push_back(wall);
    }
  }
  return walls;
}

ShapeKind ParseShape(const Reader& r, const std::string& text, const std::string& key) {
  if (text == "cylinder") return ShapeKind::kCylinder;
  if (text == "box") return ShapeKind::kBox;
  if (text == "sphere") return ShapeKind::kSphere;
  if (text == "panel") return ShapeKind::kPanel;
  if (text == "checkerboard") return ShapeKind::kCheckerboard;
  r.file.Fail(key,
              "unknown shape '" + text + "' (known: cylinder, box, sphere, panel, checkerboard)");
}

// Which size keys each shape needs; any other size key is an error, so a
// "width_m" on a cylinder is not silently ignored.
std::vector<std::string> SizeKeysOf(ShapeKind shape) {
  switch (shape) {
    case ShapeKind::kCylinder:
      return {"diameter_m", "height_m"};
    case ShapeKind::kSphere:
      return {"diameter_m"};
    case ShapeKind::kBox:
      return {"length_m", "width_m", "height_m"};
    case ShapeKind::kPanel:
      return {"length_m", "height_m"};
    case ShapeKind::kCheckerboard:
      return {};
  }
  return {};
}

// The checkerboard's own keys (position_m is then [x, y, z] of its centre).
// Its extent in its plane goes to length_m x height_m, and base_z_m / height_m
// are replaced by its lowest point / vertical extent for the ground truth.
void ParseCheckerboard(const Reader& r, const cv::FileNode& node, const std::string& prefix,
                       SceneObject* board) {
  for (const char* key : {"base_z_m", "texture"})
    if (r.Has(node, key)) r.file.Fail(prefix + key, "not used by shape checkerboard");
  const std::vector<double> centre = r.Coordinates(node, "position_m", 3, prefix);
  board->position = {centre[0], centre[1]};
  board->center_z_m = centre[2];
  board->board_cols = r.file.Int(node, "cols", prefix);
  board->board_rows = r.file.Int(node, "rows", prefix);
  if (board->board_cols < 3) r.file.Fail(prefix + "cols", "must be at least 3 squares");
  if (board->board_rows < 3) r.file.Fail(prefix + "rows", "must be at least 3 squares");
  r.file.Within(board->board_cols, prefix + "cols", 3, kMaxBoardSquares);
  r.file.Within(board->board_rows, prefix + "rows", 3, kMaxBoardSquares);
  board->square_m = r.Positive(node, "square_m", prefix);
  board->margin_m = r.NonNegative(node, "margin_m", board->square_m, prefix);
  board->pitch_rad = r.Angle(node, "pitch_rad", prefix);
  board->roll_rad = r.Angle(node, "roll_rad", prefix);
  board->material.albedo_rgb =
      r.Has(node, "colour") ? r.Colour(node, "colour", prefix) : Eigen::Vector3f(1.f, 1.f, 1.f);
  board->material.albedo2_rgb =
      r.Has(node, "colour2") ? r.Colour(node, "colour2", prefix) : Eigen::Vector3f(0.f, 0.f, 0.f);
  board->length_m = board->board_cols * board->square_m + 2.0 * board->margin_m;
  const double plane_height = board->board_rows * board->square_m + 2.0 * board->margin_m;
  // Vertical extent of the rectangle (for the ground truth's base and height).
  const Eigen::Matrix3d rotation = CheckerboardRotation(*board);
  const double half_z =
      0.5 * (board->length_m * std::abs(rotation(2, 0)) + plane_height * std::abs(rotation(2, 1)));
  board->base_z_m = board->center_z_m - half_z;
  board->height_m = plane_height;
}

SceneObject ParseObject(const Reader& r, const cv::FileNode& node, const std::string& prefix,
                        const std::vector<ObjectClass>& classes) {
  const std::vector<std::string> size_keys = {"diameter_m", "length_m", "width_m", "height_m"};
  const std::vector<std::string> board_keys = {"cols",      "rows",     "square_m", "margin_m",
                                               "pitch_rad", "roll_rad", "colour2"};
  std::vector<std::string> allowed = {"class",      "shape",    "position_m", "base_z_m",
                                      "diameter_m", "length_m", "width_m",    "height_m",
                                      "yaw_rad",    "colour",   "texture"};
  allowed.insert(allowed.end(), board_keys.begin(), board_keys.end());
  r.file.RequireOnlyKeys(node, prefix, allowed);
  SceneObject object;
  object.class_name = r.file.OptionalString(node, "class", "", prefix);
  if (!object.class_name.empty() && FindClass(classes, object.class_name) < 0)
    r.file.Fail(prefix + "class", "'" + object.class_name + "' is not listed under classes");
  object.shape = ParseShape(r, r.file.String(node, "shape", prefix), prefix + "shape");
  if (object.shape != ShapeKind::kCheckerboard) {
    for (const std::string& key : board_keys)
      if (r.Has(node, key))
        r.file.Fail(prefix + key, std::string("not used by shape ") + ShapeName(object.shape));
  }
  object.yaw_rad = r.Angle(node, "yaw_rad", prefix);
  if (object.shape == ShapeKind::kCheckerboard) {
    for (const std::string& key : size_keys)
      if (r.Has(node, key)) r.file.Fail(prefix + key, "not used by shape checkerboard");
    ParseCheckerboard(r, node, prefix, &object);
    return object;
  }
  object.position = r.Point2(node, "position_m", prefix);
  object.base_z_m = r.NonNegative(node, "base_z_m", 0.0, prefix, kCoordinate);
  const std::vector<std::string> needed = SizeKeysOf(object.shape);
  for (const std::string& key : size_keys) {
    const bool wanted = std::find(needed.begin(), needed.end(), key) != needed.end();
    if (!wanted && r.Has(node, key))
      r.file.Fail(prefix + key, std::string("not used by shape ") + ShapeName(object.shape));
  }
  auto size = [&](const std::string& key) {
    return std::find(needed.begin(), needed.end(), key) != needed.end()
               ? r.Positive(node, key, prefix)
               : 0.0;
  };
  object.diameter_m = size("diameter_m");
  object.length_m = size("length_m");
  object.width_m = size("width_m");
  object.height_m = object.shape == ShapeKind::kSphere ? object.diameter_m : size("height_m");
  object.material = ParseMaterial(r, node, prefix, {0.5f, 0.5f, 0.5f});
  return object;
}

Lighting ParseLighting(const Reader& r, const cv::FileNode& root) {
  Lighting lighting;
  if (!r.Has(root, "lighting")) return lighting;
  const cv::FileNode node = r.file.Map(root, "lighting");
  r.file.RequireOnlyKeys(node, "lighting.", {"ambient", "lights"});
  lighting.ambient = r.NonNegative(node, "ambient", lighting.ambient, "lighting.", kMaxIntensity);
  if (!r.Has(node, "lights")) return lighting;
  const cv::FileNode list = r.file.Seq(node, "lights", "lighting.");
  for (int i = 0; i < static_cast<int>(list.size()); ++i) {
    const std::string prefix = "lighting.lights[" + std::to_string(i) + "].";
    const cv::FileNode light_node = r.MapOrFail(list[i], prefix.substr(0, prefix.size() - 1));
    r.file.RequireOnlyKeys(light_node, prefix, {"position_m", "intensity", "range_m"});
    PointLight light;
    const std::vector<double> p = r.Coordinates(light_node, "position_m", 3, prefix);
    light.position = {p[0], p[1], p[2]};
    light.intensity = r.NonNegative(light_node, "intensity", 1.0, prefix, kMaxIntensity);
    light.range_m = r.NonNegative(light_node, "range_m", 0.0, prefix, kCoordinate);
    lighting.lights.push_back(light);
  }
  return lighting;
}

SensorEffects ParseSensor(const Reader& r, const cv::FileNode& root) {
  SensorEffects sensor;
  if (!r.Has(root, "sensor")) return sensor;
  const cv::FileNode node = r.file.Map(root, "sensor");
  r.file.RequireOnlyKeys(node, "sensor.", {"noise_std", "blur_sigma_px", "exposure_std", "gain"});
  sensor.noise_std = r.NonNegative(node, "noise_std", sensor.noise_std, "sensor.");
  sensor.blur_sigma_px =
      r.NonNegative(node, "blur_sigma_px", sensor.blur_sigma_px, "sensor.", kMaxBlurPx);
  sensor.exposure_std = r.NonNegative(node, "exposure_std", sensor.exposure_std, "sensor.");
  sensor.gain = r.NonNegative(node, "gain", sensor.gain, "sensor.");
  return sensor;
}

// Command strings are checked here so a typo fails before any rendering.
void CheckCommands(const Reader& r, const std::string& commands) {
  long count = 0;  // the repeat count being read
  for (size_t i = 0; i < commands.size(); ++i) {
    const char c = commands[i];
    count = c >= '0' && c <= '9' ? count * 10 + (c - '0') : 0;
    if (count > bounds::kFrames)
      r.file.Fail("path.commands", "a repeat count beyond " + std::to_string(bounds::kFrames) +
                                       " frames (docs/formats.md, Bounds)");
    if (c == ' ' || c == ',' || (c >= '0' && c <= '9')) continue;
    if (c == 'F' || c == 'B' || c == 'L' || c == 'R') continue;
    r.file.Fail("path.commands",
                std::string("unknown command letter '") + c +
                    "' (use F, B, L, R with an optional repeat count, e.g. F5 L9)");
  }
}

PathSpec ParsePath(const Reader& r, const cv::FileNode& root) {
  const cv::FileNode node = r.file.Map(root, "path");
  r.file.RequireOnlyKeys(node, "path.",
                         {"start_pose", "step_m", "turn_step_rad", "step_jitter_m",
                          "turn_jitter_rad", "waypoints_m", "commands"});
  PathSpec spec;
  const std::vector<double> start = r.file.Doubles(node, "start_pose", 3, "path.");
  for (int k = 0; k < 2; ++k)
    r.file.Within(start[k], "path.start_pose", -kCoordinate, kCoordinate, "m");
  r.file.Within(start[2], "path.start_pose", -kAngle, kAngle, "rad");
  spec.start = {start[0], start[1], WrapAngle(start[2])};
  if (r.Has(node, "step_m")) spec.step_m = r.Positive(node, "step_m", "path.");
  if (r.Has(node, "turn_step_rad"))
    spec.turn_step_rad = r.Positive(node, "turn_step_rad", "path.", kAngle);
  spec.step_jitter_m = r.NonNegative(node, "step_jitter_m", spec.step_jitter_m, "path.");
  spec.turn_jitter_rad =
      r.NonNegative(node, "turn_jitter_rad", spec.turn_jitter_rad, "path.", kAngle);
  if (r.Has(node, "waypoints_m") == r.Has(node, "commands"))
    r.file.Fail("path", "give exactly one of waypoints_m and commands");
  if (r.Has(node, "commands")) {
    spec.commands = r.file.String(node, "commands", "path.");
    CheckCommands(r, spec.commands);
    return spec;
  }
  const cv::FileNode points = r.file.Seq(node, "waypoints_m", "path.");
  for (int k = 0; k < static_cast<int>(points.size()); ++k) {
    spec.waypoints.push_back(r.ListPoint(points[k], "path.waypoints_m[" + std::to_string(k) + "]"));
  }
  if (spec.waypoints.empty()) r.file.Fail("path.waypoints_m", "needs at least one waypoint");
  return spec;
}

OdometryNoise ParseOdometry(const Reader& r, const cv::FileNode& root) {
  OdometryNoise noise;
  if (!r.Has(root, "odometry")) return noise;
  const cv::FileNode node = r.file.Map(root, "odometry");
  r.file.RequireOnlyKeys(node, "odometry.", {"noise_scale", "additive_std", "multiplicative"});
  noise.scale = r.NonNegative(node, "noise_scale", 1.0, "odometry.");
  for (const char* key : {"additive_std", "multiplicative"}) {
    if (!r.Has(node, key)) continue;
    const std::vector<double> v = r.file.Doubles(node, key, 3, "odometry.");
    const Eigen::Vector3d vector(v[0], v[1], v[2]);
    if (std::string(key) == "additive_std")
      noise.model.additive_std = vector;
    else
      noise.model.multiplicative = vector;
  }
  std::string why;
  if (noise.scale > 0 && !noise.model.Validate(&why)) r.file.Fail("odometry", why);
  return noise;
}

void ParseSurfaces(const Reader& r, const cv::FileNode& root, Scene* scene) {
  if (r.Has(root, "floor")) {
    const cv::FileNode node = r.file.Map(root, "floor");
    r.file.RequireOnlyKeys(node, "floor.", {"colour", "texture"});
    scene->floor = ParseMaterial(r, node, "floor.", {0.45f, 0.42f, 0.4f});
  } else {
    scene->floor.albedo_rgb = {0.45f, 0.42f, 0.4f};
  }
  if (r.Has(root, "ceiling")) {
    const cv::FileNode node = r.file.Map(root, "ceiling");
    r.file.RequireOnlyKeys(node, "ceiling.", {"height_m", "colour", "texture"});
    scene->has_ceiling = true;
    scene->ceiling_height_m = r.Positive(node, "height_m", "ceiling.");
    scene->ceiling = ParseMaterial(r, node, "ceiling.", {0.9f, 0.9f, 0.9f});
  }
  if (r.Has(root, "background")) scene->background_rgb = r.Colour(root, "background", "");
}

}  // namespace

Scene LoadScene(const std::string& path) {
  const YamlFile file(path);
  const Reader r{file, fs::path(path).parent_path()};
  const cv::FileNode root = file.root();
  file.RequireOnlyKeys(root, "",
                       {"name", "seed", "frames", "camera", "classes", "walls", "floor", "ceiling",
                        "background", "objects", "lighting", "sensor", "path", "odometry"});
  Scene scene;
  scene.path = path;
  scene.name = file.OptionalString(root, "name", fs::path(path).stem().string());
  const int seed = file.OptionalInt(root, "seed", 1);
  if (seed < 0) file.Fail("seed", "must not be negative");
  scene.seed = static_cast<std::uint64_t>(seed);
  scene.max_frames = file.OptionalInt(root, "frames", -1);
  if (r.Has(root, "frames") && scene.max_frames < 1) file.Fail("frames", "must be at least 1");
  file.Within(static_cast<double>(scene.max_frames), "frames", -1, bounds::kFrames);
  scene.camera = ParseCamera(r, root, &scene.camera_description);
  scene.classes = ParseClasses(r, root);
  scene.walls = ParseWalls(r, root);
  ParseSurfaces(r, root, &scene);
  if (r.Has(root, "objects")) {
    const cv::FileNode list = file.Seq(root, "objects");
    for (int i = 0; i < static_cast<int>(list.size()); ++i) {
      const std::string prefix = "objects[" + std::to_string(i) + "].";
      r.MapOrFail(list[i], prefix.substr(0, prefix.size() - 1));
      scene.objects.push_back(ParseObject(r, list[i], prefix, scene.classes));
    }
  }
  // A class is exported in the shape of its objects in the scene (the first
  // one's; cylinder when the scene has none of the class).
  for (ObjectClass& c : scene.classes) {
    for (const SceneObject& object : scene.objects) {
      if (object.class_name != c.name) continue;
      if (const std::optional<ObjectShape> shape = ParseObjectShape(ShapeName(object.shape)))
        c.shape = *shape;
      break;
    }
  }
  scene.lighting = ParseLighting(r, root);
  scene.sensor = ParseSensor(r, root);
  scene.path_spec = ParsePath(r, root);
  scene.odometry = ParseOdometry(r, root);
  return scene;
}

}  // namespace oslam

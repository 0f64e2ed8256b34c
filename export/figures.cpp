#include "export/figures.h"

#include <cstdio>

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "export/cylinder_mesh.h"
#include "export/raster.h"

namespace oslam {
namespace {

const cv::Scalar kBlack(0, 0, 0), kWhite(255, 255, 255), kGrid(215, 215, 215);

// ---------------------------------------------------------------- bird's eye

// World floor coordinates to pixels: uniform scale, the floor extent centred,
// world y pointing up the image.
class FloorToImage {
 public:
  FloorToImage(const Eigen::Vector4d& extent, cv::Size size) : extent_(extent) {
    scale_ = std::min(size.width / (extent[2] - extent[0]), size.height / (extent[3] - extent[1]));
    offset_ = {0.5 * (size.width - scale_ * (extent[2] - extent[0])),
               0.5 * (size.height - scale_ * (extent[3] - extent[1]))};
    height_ = size.height;
  }
  cv::Point2d operator()(double x, double y) const {
    return {offset_.x + scale_ * (x - extent_[0]), height_ - offset_.y - scale_ * (y - extent_[1])};
  }
  double scale() const { return scale_; }

 private:
  Eigen::Vector4d extent_;
  double scale_ = 1.0;
  cv::Point2d offset_;
  int height_ = 0;
};

cv::Point Rounded(const cv::Point2d& p) {
  return {cvRound(p.x), cvRound(p.y)};
}

// Grid spacing: 1 m (0.5 m when a metre is wider than 150 px) for room-sized
// maps; for larger ones the smallest of 1, 2, 5 x 10^k m that leaves a cell
// at least 40 px wide (a park 300 m across would otherwise be solid grid).
double GridStep(double pixels_per_metre) {
  constexpr double kMinCellPx = 40.0;
  if (pixels_per_metre >= kMinCellPx) return pixels_per_metre > 150.0 ? 0.5 : 1.0;
  for (double decade = 1.0;; decade *= 10.0)
    for (double mantissa : {1.0, 2.0, 5.0})
      if (mantissa * decade * pixels_per_metre >= kMinCellPx) return mantissa * decade;
}

std::string MetresText(double metres) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g m", metres);
  return text;
}

void DrawFloorGrid(cv::Mat* image, const FloorToImage& to_image, const Eigen::Vector4d& extent) {
  const double step = GridStep(to_image.scale());
  for (double x = std::ceil(extent[0] / step) * step; x <= extent[2]; x += step)
    cv::line(*image, Rounded(to_image(x, extent[1])), Rounded(to_image(x, extent[3])), kGrid, 1);
  for (double y = std::ceil(extent[1] / step) * step; y <= extent[3]; y += step)
    cv::line(*image, Rounded(to_image(extent[0], y)), Rounded(to_image(extent[2], y)), kGrid, 1);
}

// A bar one metre long, or one grid cell when a metre is shorter than a cell.
void DrawScaleBar(cv::Mat* image, double pixels_per_metre) {
  const double metres = std::max(1.0, GridStep(pixels_per_metre));
  const int length = cvRound(metres * pixels_per_metre);
  const cv::Point left(10, image->rows - 12), right(10 + length, image->rows - 12);
  cv::line(*image, left, right, kBlack, 2);
  cv::line(*image, left - cv::Point(0, 4), left + cv::Point(0, 4), kBlack, 1);
  cv::line(*image, right - cv::Point(0, 4), right + cv::Point(0, 4), kBlack, 1);
  DrawLabel(image, MetresText(metres), left + cv::Point(length / 2 - 8, -6), kBlack, 0.35);
}

// In the bird's-eye view the estimate is drawn dotted, as in the thesis, and
// references as lines; its legend uses the same style.
void DrawTrajectoryLine(cv::Mat* image, const std::vector<cv::Point2d>& points,
                        const NamedTrajectory& trajectory) {
  if (trajectory.name == "estimated") {
    DrawDotted(image, points, Bgr(trajectory.rgb), 5.0, 1);
    return;
  }
  std::vector<cv::Point> line;
  for (const cv::Point2d& p : points) line.push_back(Rounded(p));
  cv::polylines(*image, line, false, Bgr(trajectory.rgb), 1, cv::LINE_AA);
}

void DrawTrajectory(cv::Mat* image, const FloorToImage& to_image,
                    const NamedTrajectory& trajectory) {
  std::vector<cv::Point2d> points;
  for (const Pose2& pose : trajectory.poses) points.push_back(to_image(pose.x, pose.y));
  DrawTrajectoryLine(image, points, trajectory);
}

// `dotted_estimate`: the figure draws the estimate dotted (bird's-eye view).
void DrawLegend(cv::Mat* image, const std::vector<NamedTrajectory>& trajectories,
                bool dotted_estimate) {
  int y = 14;
  for (const NamedTrajectory& trajectory : trajectories) {
    if (dotted_estimate)
      DrawTrajectoryLine(image, {{8, y - 4.0}, {28, y - 4.0}}, trajectory);
    else
      cv::line(*image, {8, y - 4}, {26, y - 4}, Bgr(trajectory.rgb), 2, cv::LINE_AA);
    DrawLabel(image, trajectory.name, {30, y}, kBlack, 0.35);
    y += 14;
  }
}

// Red triangle at an object's centre (docs/method.md §2 display conventions).
void DrawCentreMarker(cv::Mat* image, cv::Point centre) {
  const std::vector<cv::Point> triangle = {centre + cv::Point(0, -4), centre + cv::Point(-4, 3),
                                           centre + cv::Point(4, 3)};
  cv::fillConvexPoly(*image, triangle, cv::Scalar(0, 0, 220), cv::LINE_AA);
}

// ---------------------------------------------------------------- perspective

// Pinhole camera looking at `target` from a direction given by azimuth and
// elevation, far enough back that a sphere of `radius` fits the view.
class ViewCamera {
 public:
  ViewCamera(const Eigen::Vector3d& target, double radius, const FigureOptions& options,
             cv::Size size) {
    const double fov = 45.0 * M_PI / 180.0;
    const Eigen::Vector3d direction(
        std::cos(options.view_elevation_rad) * std::cos(options.view_azimuth_rad),
        std::cos(options.view_elevation_rad) * std::sin(options.view_azimuth_rad),
        std::sin(options.view_elevation_rad));
    eye_ = target + direction * (radius / std::sin(0.5 * fov));
    forward_ = (target - eye_).normalized();
    right_ = forward_.cross(Eigen::Vector3d::UnitZ()).normalized();
    up_ = right_.cross(forward_);
    focal_ = 0.5 * std::min(size.width, size.height) / std::tan(0.5 * fov);
    centre_ = {0.5 * size.width, 0.5 * size.height};
  }
  double Depth(const Eigen::Vector3d& p) const { return forward_.dot(p - eye_); }
  cv::Point2d Project(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d d = p - eye_;
    const double z = std::max(forward_.dot(d), 1e-3);
    return {centre_.x + focal_ * right_.dot(d) / z, centre_.y - focal_ * up_.dot(d) / z};
  }
  const Eigen::Vector3d& eye() const { return eye_; }

 private:
  Eigen::Vector3d eye_, forward_, right_, up_;
  double focal_ = 1.0;
  cv::Point2d centre_;
};

struct Face {
  std::vector<Eigen::Vector3d> corners;
  cv::Scalar colour;
  double alpha = 1.0;
  double depth = 0.0;
};

// Lambert shading from a fixed light over the viewer's shoulder, plus ambient,
// so the cylinders read as solids.
cv::Scalar Shade(const Rgb& rgb, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d light = Eigen::Vector3d(-0.4, -0.6, 0.7).normalized();
  const double lambert = 0.5 + 0.5 * std::abs(normal.dot(light));  // double-sided
  return Bgr(rgb) * lambert;
}

// Each triangle of the cylinder mesh is a face: simple, and small enough for
// a painter's sort of a few thousand faces.
void AppendObjectFaces(const OMapObject& object, const Rgb& rgb, int segments,
                       const ViewCamera& camera, std::vector<Face>* faces) {
  const TriangleMesh mesh = CylinderMesh(object.diameter_m, object.height_m, segments);
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    Face face;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[t + k];
      face.corners.push_back(object.base_world + mesh.positions[v].cast<double>());
      centroid += face.corners.back() / 3.0;
      normal += mesh.normals[v].cast<double>();
    }
    face.colour = Shade(rgb, normal.normalized());
    face.alpha = object.existence_probability;
    face.depth = camera.Depth(centroid);
    faces->push_back(face);
  }
}

void DrawFloorLines(cv::Mat* image, const ViewCamera& camera, const Eigen::Vector4d& extent) {
  const double x0 = std::floor(extent[0]), y0 = std::floor(extent[1]);
  const double x1 = std::ceil(extent[2]), y1 = std::ceil(extent[3]);
  auto segment = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    cv::line(*image, Rounded(camera.Project(a)), Rounded(camera.Project(b)), kGrid, 2, cv::LINE_AA);
  };
  for (double x = x0; x <= x1 + 1e-9; x += 1.0) segment({x, y0, 0}, {x, y1, 0});
  for (double y = y0; y <= y1 + 1e-9; y += 1.0) segment({x0, y, 0}, {x1, y, 0});
}

// ---------------------------------------------------------------- plot

// A "nice" tick step (1, 2 or 5 times a power of ten) giving about `ticks` ticks.
double NiceStep(double range, int ticks) {
  const double raw = range / std::max(ticks, 1);
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0})
    if (m * power >= raw) return m * power;
  return 10.0 * power;
}

std::string FormatTick(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", std::abs(value) < 1e-12 ? 0.0 : value);
  return text;
}

std::vector<double> PositionErrors(const std::vector<Pose2>& poses,
                                   const std::vector<Pose2>& truth) {
  std::vector<double> errors;
  for (size_t i = 0; i < std::min(poses.size(), truth.size()); ++i)
    errors.push_back(std::hypot(poses[i].x - truth[i].x, poses[i].y - truth[i].y));
  return errors;
}

}  // namespace

bool FigureOptions::Validate(std::string* why) const {
  if (width_px < 64 || height_px < 64) {
    *why = "figures must be at least 64x64 pixels";
    return false;
  }
  if (!(min_existence >= 0.0 && min_existence <= 1.0)) {
    *why = "min-existence must be in [0, 1]";
    return false;
  }
  if (cylinder_segments < 3) {
    *why = "a cylinder needs at least 3 segments";
    return false;
  }
  return true;
}

cv::Mat RenderBirdsEye(const ExportScene& scene, const FigureOptions& options) {
  cv::Mat image(options.height_px, options.width_px, CV_8UC3, kWhite);
  const Eigen::Vector4d extent = FloorExtent(scene, options.min_existence, 0.5);
  const FloorToImage to_image(extent, image.size());
  DrawFloorGrid(&image, to_image, extent);
  const std::vector<NamedTrajectory> trajectories = SceneTrajectories(scene);
  // Reference trajectories first, the estimate on top.
  for (auto it = trajectories.rbegin(); it != trajectories.rend(); ++it)
    DrawTrajectory(&image, to_image, *it);
  const std::vector<const OMapObject*> objects = ShownObjects(scene.map, options.min_existence);
  for (const OMapObject* object : objects) {
    const cv::Point centre = Rounded(to_image(object->base_world.x(), object->base_world.y()));
    const int radius = cvRound(0.5 * object->diameter_m * to_image.scale());
    BlendDisc(&image, centre, radius, Bgr(ClassColour(scene.classes, object->class_name)),
              object->existence_probability);
    DrawCentreMarker(&image, centre);
  }
  // Labels last so no disc covers them; beyond kMaxLabels objects (a park
  // of trees) they would only cover each other.
  constexpr size_t kMaxLabels = 60;
  for (const OMapObject* object : objects) {
    if (objects.size() > kMaxLabels) break;
    const cv::Point2d centre = to_image(object->base_world.x(), object->base_world.y());
    const int radius = cvRound(0.5 * object->diameter_m * to_image.scale());
    DrawLabel(&image, ObjectLabel(*object) + " " + FormatProbability(object->existence_probability),
              Rounded(centre) + cv::Point(radius / 2 + 4, -radius / 2 - 2), kBlack, 0.35);
  }
  DrawLegend(&image, trajectories, /*dotted_estimate=*/true);
  DrawScaleBar(&image, to_image.scale());
  return image;
}

cv::Mat RenderPerspective(const ExportScene& scene, const FigureOptions& options) {
  // Drawn at twice the size and reduced: polygons are filled without
  // anti-aliasing (AA edges would leave seams between blended faces).
  constexpr int kSupersample = 2;
  const cv::Size size(options.width_px * kSupersample, options.height_px * kSupersample);
  cv::Mat image(size, CV_8UC3, kWhite);
  const Eigen::Vector4d extent = FloorExtent(scene, options.min_existence, 0.5);
  const std::vector<const OMapObject*> objects = ShownObjects(scene.map, options.min_existence);
  double top = 0.0;
  for (const OMapObject* object : objects)
    top = std::max(top, object->base_world.z() + object->height_m);
  const Eigen::Vector3d target(0.5 * (extent[0] + extent[2]), 0.5 * (extent[1] + extent[3]),
                               0.5 * top);
  const double radius =
      0.5 * Eigen::Vector3d(extent[2] - extent[0], extent[3] - extent[1], top).norm();
  const ViewCamera camera(target, radius, options, size);

  DrawFloorLines(&image, camera, extent);
  // Reference trajectories first, the estimate on top.
  const std::vector<NamedTrajectory> trajectories = SceneTrajectories(scene);
  for (auto it = trajectories.rbegin(); it != trajectories.rend(); ++it) {
    std::vector<cv::Point> line;
    for (const Pose2& pose : it->poses)
      line.push_back(Rounded(camera.Project({pose.x, pose.y, 0.0})));
    cv::polylines(image, line, false, Bgr(it->rgb), kSupersample, cv::LINE_AA);
  }
  std::vector<Face> faces;
  for (const OMapObject* object : objects)
    AppendObjectFaces(*object, ClassColour(scene.classes, object->class_name),
                      options.cylinder_segments, camera, &faces);
  // Far to near; ties (shared depths) keep mesh order for determinism.
  std::stable_sort(faces.begin(), faces.end(),
                   [](const Face& a, const Face& b) { return a.depth > b.depth; });
  for (const Face& face : faces) {
    std::vector<cv::Point> polygon;
    for (const Eigen::Vector3d& corner : face.corners)
      polygon.push_back(Rounded(camera.Project(corner)));
    BlendPolygon(&image, polygon, face.colour, face.alpha);
  }
  cv::Mat reduced;
  cv::resize(image, reduced, cv::Size(options.width_px, options.height_px), 0, 0, cv::INTER_AREA);
  for (const OMapObject* object : objects) {
    const cv::Point2d tip =
        camera.Project(object->base_world + Eigen::Vector3d(0, 0, object->height_m));
    DrawLabel(&reduced, object->class_name,
              Rounded(tip * (1.0 / kSupersample)) + cv::Point(-10, -6), kBlack, 0.35);
  }
  DrawLegend(&reduced, SceneTrajectories(scene), /*dotted_estimate=*/false);
  return reduced;
}

cv::Mat PlotTrajectoryErrors(const ExportScene& scene, const FigureOptions& options) {
  if (scene.ground_truth.empty()) throw Error("trajectory plot: no ground truth to compare with");
  struct Series {
    std::string name;
    std::vector<double> errors;
    Rgb rgb;
  };
  std::vector<Series> series;
  for (const NamedTrajectory& t : SceneTrajectories(scene))
    if (t.name != "ground truth")
      series.push_back({t.name, PositionErrors(t.poses, scene.ground_truth), t.rgb});
  size_t frames = 1;
  double max_error = 0.0;
  for (const Series& s : series) {
    frames = std::max(frames, s.errors.size());
    for (const double e : s.errors) max_error = std::max(max_error, e);
  }
  max_error = std::max(max_error, 0.01);

  cv::Mat image(options.height_px, options.width_px, CV_8UC3, kWhite);
  const cv::Rect plot(52, 24, options.width_px - 64, options.height_px - 60);
  const double y_step = NiceStep(max_error, 5), x_step = NiceStep(static_cast<double>(frames), 6);
  const double y_top = std::ceil(max_error / y_step) * y_step;
  const double x_right = std::max(1.0, static_cast<double>(frames - 1));
  auto to_pixel = [&](double frame, double error) {
    return cv::Point2d(plot.x + plot.width * frame / x_right,
                       plot.y + plot.height * (1.0 - error / y_top));
  };
  for (double y = 0.0; y <= y_top + 1e-9; y += y_step) {
    const cv::Point p = Rounded(to_pixel(0, y));
    cv::line(image, p, {plot.x + plot.width, p.y}, kGrid, 1);
    DrawLabel(&image, FormatTick(y), p + cv::Point(-44, 4), kBlack, 0.35);
  }
  for (double x = 0.0; x <= x_right + 1e-9; x += x_step) {
    const cv::Point p = Rounded(to_pixel(x, 0));
    cv::line(image, p, {p.x, plot.y}, kGrid, 1);
    DrawLabel(&image, FormatTick(x), p + cv::Point(-8, 16), kBlack, 0.35);
  }
  cv::rectangle(image, plot, kBlack, 1);
  for (const Series& s : series) {
    std::vector<cv::Point> line;
    for (size_t i = 0; i < s.errors.size(); ++i) line.push_back(Rounded(to_pixel(i, s.errors[i])));
    cv::polylines(image, line, false, Bgr(s.rgb), 1, cv::LINE_AA);
  }
  DrawLabel(&image, "position error vs ground truth [m]", {plot.x, 16}, kBlack, 0.4);
  DrawLabel(&image, "frame", {plot.x + plot.width / 2 - 16, options.height_px - 6}, kBlack, 0.4);
  int legend_y = plot.y + 14;
  for (const Series& s : series) {
    cv::line(image, {plot.x + 8, legend_y - 4}, {plot.x + 26, legend_y - 4}, Bgr(s.rgb), 2,
             cv::LINE_AA);
    DrawLabel(&image, s.name, {plot.x + 30, legend_y}, kBlack, 0.35);
    legend_y += 14;
  }
  return image;
}

void WritePng(const cv::Mat& image, const std::string& path, FileSync sync) {
  // Encoded in memory, so the only write is WriteFileAtomically's, checked.
  std::vector<unsigned char> png;
  if (image.empty() || !cv::imencode(".png", image, png))
    throw Error::InFile(path, "cannot encode the image as PNG");
  WriteFileAtomically(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()),
                      sync);
}

}  // namespace oslam

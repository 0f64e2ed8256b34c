#include "samples/renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "core/angles.h"
#include "core/error.h"
#include "samples/texture.h"

namespace oslam {

namespace {

constexpr int kNumBins = 1024;  // bearing bins (power of two: modulo by mask)
constexpr double kBinWidth = 2.0 * kPi / kNumBins;
constexpr double kMinT = 1e-9;  // ignore hits at the ray origin
constexpr int kFloor = -1, kCeiling = -2, kNothing = -3;

using Primitive = Renderer::Primitive;
using Hit = Renderer::Hit;

long FloorDiv(double x) {
  return static_cast<long>(std::floor(x));
}
int WrapBin(long bin) {
  return static_cast<int>(bin & (kNumBins - 1));
}

Primitive MakeWall(const WallSegment& wall) {
  Primitive p;
  p.kind = Renderer::Kind::kVertical;
  p.material = &wall.material;
  p.from = wall.from;
  p.edge = wall.to - wall.from;
  p.z0 = 0.0;
  p.z1 = wall.height_m;
  return p;
}

Primitive MakeObject(const SceneObject& object, int index) {
  Primitive p;
  p.object = index;
  p.material = &object.material;
  p.z0 = object.base_z_m;
  p.z1 = object.base_z_m + object.height_m;
  p.center = {object.position.x(), object.position.y(), 0.5 * (p.z0 + p.z1)};
  p.cos_yaw = std::cos(object.yaw_rad);
  p.sin_yaw = std::sin(object.yaw_rad);
  switch (object.shape) {
    case ShapeKind::kCylinder:
      p.kind = Renderer::Kind::kCylinder;
      p.radius = p.bound_radius = 0.5 * object.diameter_m;
      break;
    case ShapeKind::kSphere:
      p.kind = Renderer::Kind::kSphere;
      p.radius = p.bound_radius = 0.5 * object.diameter_m;
      break;
    case ShapeKind::kBox:
      p.kind = Renderer::Kind::kBox;
      p.half = {0.5 * object.length_m, 0.5 * object.width_m, 0.5 * object.height_m};
      p.bound_radius = std::hypot(p.half.x(), p.half.y());
      break;
    case ShapeKind::kPanel: {
      p.kind = Renderer::Kind::kVertical;
      const Eigen::Vector2d axis(p.cos_yaw, p.sin_yaw);
      p.from = object.position - 0.5 * object.length_m * axis;
      p.edge = object.length_m * axis;
      break;
    }
    case ShapeKind::kCheckerboard:
      p.kind = Renderer::Kind::kBoard;
      p.center = {object.position.x(), object.position.y(), object.center_z_m};
      p.axes = CheckerboardRotation(object);
      p.half = {0.5 * object.length_m, 0.5 * object.height_m, 0.0};
      p.bound_radius = std::hypot(p.half.x(), p.half.y());  // covers any tilt
      p.z0 = object.base_z_m;
      p.z1 = 2.0 * object.center_z_m - object.base_z_m;
      break;
  }
  return p;
}

// Checkerboard albedo at board-plane coordinates (u, v) from the board centre:
// light margin around cols x rows squares, the square at the (-u, -v) corner dark.
Eigen::Vector3f CheckerAlbedo(const SceneObject& board, double u, double v) {
  const double x = u / board.square_m + 0.5 * board.board_cols;
  const double y = v / board.square_m + 0.5 * board.board_rows;
  if (x < 0 || y < 0 || x >= board.board_cols || y >= board.board_rows)
    return board.material.albedo_rgb;
  const long i = static_cast<long>(x), j = static_cast<long>(y);
  return (i + j) % 2 == 0 ? board.material.albedo2_rgb : board.material.albedo_rgb;
}

// ---- analytic intersections; each returns the nearest t in (kMinT, best) ----

bool HitVertical(const Primitive& p, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                 double best, double* t) {
  const double denominator = d.x() * p.edge.y() - d.y() * p.edge.x();
  if (std::abs(denominator) < 1e-15) return false;  // ray parallel to the wall
  const double wx = p.from.x() - o.x(), wy = p.from.y() - o.y();
  const double tt = (wx * p.edge.y() - wy * p.edge.x()) / denominator;
  if (!(tt > kMinT && tt < best)) return false;
  const double u = (d.y() * wx - d.x() * wy) / denominator;
  if (u < 0.0 || u > 1.0) return false;
  const double z = o.z() + tt * d.z();
  if (z < p.z0 || z > p.z1) return false;
  *t = tt;
  return true;
}

bool HitCylinder(const Primitive& p, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                 double best, double* t, int* part) {
  const double ox = o.x() - p.center.x(), oy = o.y() - p.center.y();
  const double r2 = p.radius * p.radius;
  bool found = false;
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > 1e-18) {
    const double b = ox * d.x() + oy * d.y();
    const double c = ox * ox + oy * oy - r2;
    const double discriminant = b * b - a * c;
    if (discriminant >= 0.0) {
      const double tt = (-b - std::sqrt(discriminant)) / a;  // entry point (camera outside)
      const double z = o.z() + tt * d.z();
      if (tt > kMinT && tt < best && z >= p.z0 && z <= p.z1) {
        best = *t = tt, *part = 0, found = true;
      }
    }
  }
  if (std::abs(d.z()) > 1e-15) {
    // Caps: the top is seen from above, the bottom (of a raised cylinder) from below.
    const double cap_z = d.z() < 0 ? p.z1 : p.z0;
    const double tt = (cap_z - o.z()) / d.z();
    const double x = ox + tt * d.x(), y = oy + tt * d.y();
    if (tt > kMinT && tt < best && x * x + y * y <= r2) *t = tt, *part = 1, found = true;
  }
  return found;
}

bool HitSphere(const Primitive& p, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double best,
               double* t) {
  const Eigen::Vector3d oc = o - p.center;
  const double b = oc.dot(d);
  const double c = oc.squaredNorm() - p.radius * p.radius;
  const double discriminant = b * b - c;
  if (discriminant < 0.0) return false;
  const double tt = -b - std::sqrt(discriminant);
  if (!(tt > kMinT && tt < best)) return false;
  *t = tt;
  return true;
}

bool HitBox(const Primitive& p, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double best,
            double* t, int* part) {
  // Slab test in the box frame (rotated by -yaw about z).
  const Eigen::Vector3d q = o - p.center;
  const double lo[3] = {p.cos_yaw * q.x() + p.sin_yaw * q.y(),
                        -p.sin_yaw * q.x() + p.cos_yaw * q.y(), q.z()};
  const double ld[3] = {p.cos_yaw * d.x() + p.sin_yaw * d.y(),
                        -p.sin_yaw * d.x() + p.cos_yaw * d.y(), d.z()};
  double t_enter = -std::numeric_limits<double>::infinity();
  double t_exit = std::numeric_limits<double>::infinity();
  int axis_enter = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const double h = p.half[axis];
    if (std::abs(ld[axis]) < 1e-15) {
      if (std::abs(lo[axis]) > h) return false;
      continue;
    }
    double t1 = (-h - lo[axis]) / ld[axis], t2 = (h - lo[axis]) / ld[axis];
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > t_enter) t_enter = t1, axis_enter = axis;
    t_exit = std::min(t_exit, t2);
  }
  if (!(t_enter <= t_exit && t_enter > kMinT && t_enter < best)) return false;
  *t = t_enter;
  *part = axis_enter;
  return true;
}

bool HitBoard(const Primitive& p, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double best,
              double* t) {
  const Eigen::Vector3d normal = p.axes.col(2);
  const double denominator = normal.dot(d);
  if (std::abs(denominator) < 1e-15) return false;  // ray in the board plane
  const double tt = normal.dot(p.center - o) / denominator;
  if (!(tt > kMinT && tt < best)) return false;
  const Eigen::Vector3d q = o + tt * d - p.center;
  if (std::abs(q.dot(p.axes.col(0))) > p.half.x() || std::abs(q.dot(p.axes.col(1))) > p.half.y())
    return false;
  *t = tt;
  return true;
}

bool HitPrimitive(const Primitive& p, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                  double best, double* t, int* part) {
  switch (p.kind) {
    case Renderer::Kind::kVertical:
      return HitVertical(p, o, d, best, t);
    case Renderer::Kind::kCylinder:
      return HitCylinder(p, o, d, best, t, part);
    case Renderer::Kind::kSphere:
      return HitSphere(p, o, d, best, t);
    case Renderer::Kind::kBox:
      return HitBox(p, o, d, best, t, part);
    case Renderer::Kind::kBoard:
      return HitBoard(p, o, d, best, t);
  }
  return false;
}

// ---- surface normal and texture coordinates at a hit point ----

struct SurfacePoint {
  Eigen::Vector3d normal;
  double u = 0.0, v = 0.0;  // metres on the surface
};

SurfacePoint SurfaceOf(const Primitive& p, int part, const Eigen::Vector3d& x) {
  SurfacePoint s;
  switch (p.kind) {
    case Renderer::Kind::kVertical: {
      const double length = p.edge.norm();
      const Eigen::Vector2d along = p.edge / length;
      s.normal = {along.y(), -along.x(), 0.0};
      s.u = (x.head<2>() - p.from).dot(along);
      s.v = x.z() - p.z0;
      break;
    }
    case Renderer::Kind::kCylinder: {
      const Eigen::Vector2d r = x.head<2>() - p.center.head<2>();
      if (part == 0) {
        s.normal = Eigen::Vector3d(r.x(), r.y(), 0.0).normalized();
        s.u = p.radius * std::atan2(r.y(), r.x());
        s.v = x.z() - p.z0;
      } else {
        s.normal = Eigen::Vector3d::UnitZ();
        s.u = r.x();
        s.v = r.y();
      }
      break;
    }
    case Renderer::Kind::kSphere: {
      s.normal = (x - p.center) / p.radius;
      s.u = p.radius * std::atan2(s.normal.y(), s.normal.x());
      s.v = p.radius * std::asin(std::clamp(s.normal.z(), -1.0, 1.0));
      break;
    }
    case Renderer::Kind::kBox: {
      const Eigen::Vector3d q = x - p.center;
      const Eigen::Vector3d local(p.cos_yaw * q.x() + p.sin_yaw * q.y(),
                                  -p.sin_yaw * q.x() + p.cos_yaw * q.y(), q.z());
      Eigen::Vector3d n_local = Eigen::Vector3d::Zero();
      n_local[part] = local[part] > 0 ? 1.0 : -1.0;
      s.normal = {p.cos_yaw * n_local.x() - p.sin_yaw * n_local.y(),
                  p.sin_yaw * n_local.x() + p.cos_yaw * n_local.y(), n_local.z()};
      const int a = part == 0 ? 1 : 0, b = part == 2 ? 1 : 2;
      s.u = local[a] + p.half[a];
      s.v = local[b] + p.half[b];
      break;
    }
    case Renderer::Kind::kBoard: {
      const Eigen::Vector3d q = x - p.center;
      s.normal = p.axes.col(2);
      s.u = q.dot(p.axes.col(0));  // from the board centre (CheckerAlbedo)
      s.v = q.dot(p.axes.col(1));
      break;
    }
  }
  return s;
}

}  // namespace

Renderer::Renderer(const Scene& scene, const RendererOptions& options)
    : scene_(scene), options_(options) {
  for (const WallSegment& wall : scene.walls) primitives_.push_back(MakeWall(wall));
  for (size_t i = 0; i < scene.objects.size(); ++i)
    primitives_.push_back(MakeObject(scene.objects[i], static_cast<int>(i)));

  // Back-project every annulus pixel once; group by robot-frame bearing bin.
  const CameraModel& camera = *scene.camera;
  std::vector<std::vector<int>> pixels_of_bin(kNumBins);
  std::vector<Eigen::Vector3d> ray_of_pixel(static_cast<size_t>(camera.image_width()) *
                                            camera.image_height());
  bool have_origin = false;
  for (int y = 0; y < camera.image_height(); ++y) {
    for (int x = 0; x < camera.image_width(); ++x) {
      const Eigen::Vector2d pixel(x, y);
      Ray ray;
      if (!camera.IsInAnnulus(pixel) || !camera.BackProjectPixel(pixel, &ray)) continue;
      if (!have_origin) origin_robot_ = ray.origin_robot, have_origin = true;
      // The renderer assumes a central camera: one viewpoint for all rays.
      if ((ray.origin_robot - origin_robot_).norm() > 1e-9)
        throw Error("simulator: camera model " + camera.ModelName() + " is not central");
      const int index = y * camera.image_width() + x;
      ray_of_pixel[index] = ray.direction_robot.normalized();
      const double bearing = std::atan2(ray_of_pixel[index].y(), ray_of_pixel[index].x());
      pixels_of_bin[WrapBin(FloorDiv((bearing + kPi) / kBinWidth))].push_back(index);
    }
  }
  robot_bin_start_.push_back(0);
  for (const std::vector<int>& pixels : pixels_of_bin) {
    for (int index : pixels) {
      pixel_index_.push_back(index);
      ray_robot_.push_back(ray_of_pixel[index]);
      const double bearing = std::atan2(ray_of_pixel[index].y(), ray_of_pixel[index].x());
      bin_position_.push_back(std::clamp((bearing + kPi) / kBinWidth, 0.0, kNumBins - 1e-9));
    }
    robot_bin_start_.push_back(static_cast<int>(pixel_index_.size()));
  }
}

bool Renderer::BinRange(const Primitive& p, const Eigen::Vector2d& robot_xy, long* first,
                        long* last) const {
  double start = 0.0, length = 0.0;
  if (p.kind == Kind::kVertical) {
    const Eigen::Vector2d a = p.from - robot_xy, b = p.from + p.edge - robot_xy;
    // Distance from the robot to the segment: too close means "all bearings".
    const double u = std::clamp(-a.dot(p.edge) / p.edge.squaredNorm(), 0.0, 1.0);
    if ((a + u * p.edge).norm() < 1e-6) return false;
    const double bearing_a = std::atan2(a.y(), a.x()), bearing_b = std::atan2(b.y(), b.x());
    const double sweep = WrapAngle(bearing_b - bearing_a);
    start = sweep >= 0 ? bearing_a : bearing_b;
    length = std::abs(sweep);
  } else {
    const Eigen::Vector2d c = p.center.head<2>() - robot_xy;
    const double distance = c.norm();
    if (distance <= p.bound_radius + 1e-6) return false;
    const double half = std::asin(p.bound_radius / distance);
    start = std::atan2(c.y(), c.x()) - half;
    length = 2.0 * half;
  }
  // One bin of margin on each side absorbs rounding at bin edges.
  *first = FloorDiv((start + kPi) / kBinWidth) - 1;
  *last = FloorDiv((start + length + kPi) / kBinWidth) + 1;
  return *last - *first + 1 < kNumBins;
}

Renderer::BinLists Renderer::BuildBins(const Eigen::Vector2d& robot_xy) const {
  // Counting sort into compressed lists: two passes over the primitives.
  std::vector<std::pair<long, long>> ranges(primitives_.size());
  BinLists bins;
  bins.start.assign(kNumBins + 1, 0);
  for (size_t i = 0; i < primitives_.size(); ++i) {
    long first = 0, last = kNumBins - 1;
    if (options_.brute_force || !BinRange(primitives_[i], robot_xy, &first, &last))
      first = 0, last = kNumBins - 1;
    ranges[i] = {first, last};
    for (long b = first; b <= last; ++b) ++bins.start[WrapBin(b) + 1];
  }
  for (int b = 0; b < kNumBins; ++b) bins.start[b + 1] += bins.start[b];
  bins.items.resize(bins.start[kNumBins]);
  std::vector<int> fill(bins.start.begin(), bins.start.end() - 1);
  for (size_t i = 0; i < primitives_.size(); ++i)
    for (long b = ranges[i].first; b <= ranges[i].second; ++b)
      bins.items[fill[WrapBin(b)]++] = static_cast<int>(i);
  return bins;
}

Eigen::Vector3d Renderer::WorldDirection(size_t k, double c, double s) const {
  const Eigen::Vector3d& r = ray_robot_[k];
  return {c * r.x() - s * r.y(), s * r.x() + c * r.y(), r.z()};
}

Hit Renderer::Trace(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const int* candidates,
                    int count) const {
  Hit hit;
  hit.t = std::numeric_limits<double>::infinity();
  hit.primitive = kNothing;
  if (d.z() < 0.0) {
    hit.t = -o.z() / d.z();
    hit.primitive = kFloor;
  } else if (scene_.has_ceiling && d.z() > 0.0) {
    hit.t = (scene_.ceiling_height_m - o.z()) / d.z();
    hit.primitive = kCeiling;
  }
  for (int i = 0; i < count; ++i) {
    double t = 0.0;
    int part = 0;
    if (HitPrimitive(primitives_[candidates[i]], o, d, hit.t, &t, &part)) {
      hit.t = t;
      hit.primitive = candidates[i];
      hit.part = part;
    }
  }
  return hit;
}

Eigen::Vector3f Renderer::BoardAlbedo(const Primitive& board, const Eigen::Vector3d& o,
                                      const Eigen::Vector3d& d, long k, double c, double s) const {
  const SceneObject& object = scene_.objects[board.object];
  const Eigen::Vector3d normal = board.axes.col(2);
  auto albedo_along = [&](const Eigen::Vector3d& direction, Eigen::Vector3f* albedo) {
    const double denominator = normal.dot(direction);
    if (std::abs(denominator) < 1e-15) return false;
    const double t = normal.dot(board.center - o) / denominator;
    if (!(t > kMinT)) return false;
    const Eigen::Vector3d q = o + t * direction - board.center;
    *albedo = CheckerAlbedo(object, q.dot(board.axes.col(0)), q.dot(board.axes.col(1)));
    return true;
  };
  Eigen::Vector3f centre_albedo = object.material.albedo_rgb;
  albedo_along(d, &centre_albedo);
  if (k < 0) return centre_albedo;
  // Box filter over the pixel: kBoardSamples^2 rays through sub-pixel
  // positions, each intersected with the board's plane (edges and corners land
  // at sub-pixel accuracy, like a real sensor integrating over the pixel).
  constexpr int kBoardSamples = 4;
  const CameraModel& camera = *scene_.camera;
  const int index = pixel_index_[k];
  const double px = index % camera.image_width(), py = index / camera.image_width();
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
  for (int sy = 0; sy < kBoardSamples; ++sy) {
    for (int sx = 0; sx < kBoardSamples; ++sx) {
      const Eigen::Vector2d sub(px + (sx + 0.5) / kBoardSamples - 0.5,
                                py + (sy + 0.5) / kBoardSamples - 0.5);
      Ray ray;
      Eigen::Vector3f albedo = centre_albedo;
      if (camera.BackProjectPixel(sub, &ray)) {
        const Eigen::Vector3d r = ray.direction_robot.normalized();
        albedo_along(Eigen::Vector3d(c * r.x() - s * r.y(), s * r.x() + c * r.y(), r.z()), &albedo);
      }
      sum += albedo;
    }
  }
  return sum / static_cast<float>(kBoardSamples * kBoardSamples);
}

Eigen::Vector3f Renderer::Shade(const Hit& hit, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                long k, double c, double s) const {
  if (hit.primitive == kNothing) return scene_.background_rgb;
  const Eigen::Vector3d x = o + hit.t * d;
  const Material* material = nullptr;
  SurfacePoint surface;
  if (hit.primitive == kFloor || hit.primitive == kCeiling) {
    material = hit.primitive == kFloor ? &scene_.floor : &scene_.ceiling;
    surface.normal = Eigen::Vector3d(0.0, 0.0, hit.primitive == kFloor ? 1.0 : -1.0);
    surface.u = x.x();
    surface.v = x.y();
  } else {
    const Primitive& p = primitives_[hit.primitive];
    material = p.material;
    surface = SurfaceOf(p, hit.part, x);
  }
  // Surfaces are two-sided: light the side the camera sees.
  if (surface.normal.dot(d) > 0) surface.normal = -surface.normal;
  double light = scene_.lighting.ambient;
  for (const PointLight& lamp : scene_.lighting.lights) {
    const Eigen::Vector3d to_light = lamp.position - x;
    const double distance = to_light.norm();
    const double cosine = surface.normal.dot(to_light) / distance;
    if (cosine <= 0) continue;
    const double falloff = lamp.range_m > 0
                               ? 1.0 / (1.0 + (distance / lamp.range_m) * (distance / lamp.range_m))
                               : 1.0;
    light += lamp.intensity * cosine * falloff;
  }
  const Eigen::Vector3f albedo =
      hit.primitive >= 0 && primitives_[hit.primitive].kind == Kind::kBoard
          ? BoardAlbedo(primitives_[hit.primitive], o, d, k, c, s)
          : AlbedoAt(*material, surface.u, surface.v);
  return albedo * static_cast<float>(light);
}

void Renderer::Render(const Pose2& pose, const FrameConditions& conditions,
                      FrameRender* out) const {
  const CameraModel& camera = *scene_.camera;
  const int width = camera.image_width(), height = camera.image_height();
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const Eigen::Vector3d origin = pose.RobotToWorld(origin_robot_);
  const BinLists bins = BuildBins(origin.head<2>());
  const double shift = pose.theta / kBinWidth + kNumBins;  // keeps bin positions positive

  cv::Mat radiance(height, width, CV_32FC3, cv::Scalar::all(0));
  out->object_ids.create(height, width, CV_32SC1);
  out->object_ids.setTo(-1);
  out->visible_pixels.assign(scene_.objects.size(), 0);
  auto* radiance_data = radiance.ptr<cv::Vec3f>();
  auto* ids = out->object_ids.ptr<int>();
  for (size_t k = 0; k < pixel_index_.size(); ++k) {
    const Eigen::Vector3d d = WorldDirection(k, c, s);
    const int bin = WrapBin(static_cast<long>(bin_position_[k] + shift));
    const int first = bins.start[bin];
    const Hit hit = Trace(origin, d, bins.items.data() + first, bins.start[bin + 1] - first);
    const Eigen::Vector3f rgb = Shade(hit, origin, d, static_cast<long>(k), c, s);
    const int index = pixel_index_[k];
    radiance_data[index] = cv::Vec3f(rgb.x(), rgb.y(), rgb.z());
    if (hit.primitive >= 0 && primitives_[hit.primitive].object >= 0) {
      ids[index] = primitives_[hit.primitive].object;
      ++out->visible_pixels[ids[index]];
    }
  }
  if (scene_.sensor.blur_sigma_px > 0)
    cv::GaussianBlur(radiance, radiance, cv::Size(), scene_.sensor.blur_sigma_px);

  // Exposure, sensor noise, 8-bit quantisation; outside the annulus stays black.
  out->image.create(height, width, CV_8UC3);
  out->image.setTo(cv::Scalar::all(0));
  auto* bgr = out->image.ptr<cv::Vec3b>();
  const float scale = static_cast<float>(255.0 * conditions.gain * scene_.sensor.gain);
  const float noise_std = static_cast<float>(scene_.sensor.noise_std);
  const std::uint64_t key = MixBits(conditions.noise_key);
  for (int index : pixel_index_) {
    const cv::Vec3f& rgb = radiance_data[index];
    for (int channel = 0; channel < 3; ++channel) {
      float value = rgb[channel] * scale;
      if (noise_std > 0)
        value += noise_std *
                 NormalFromBits(MixBits(key ^ (static_cast<std::uint64_t>(index) * 3 + channel)));
      bgr[index][2 - channel] = cv::saturate_cast<uchar>(value);
    }
  }
}

std::vector<BoundingSlice> Renderer::VisibleSlices(const FrameRender& render) const {
  const size_t count = scene_.objects.size();
  std::vector<std::vector<double>> radii(count), angles(count);
  const int* ids = render.object_ids.ptr<int>();
  const int width = render.object_ids.cols;
  for (int index : pixel_index_) {
    if (ids[index] < 0) continue;
    const PolarPoint polar =
        scene_.camera->PixelToPolar(Eigen::Vector2d(index % width, index / width));
    radii[ids[index]].push_back(polar.radius_px);
    angles[ids[index]].push_back(polar.angle_rad);
  }
  std::vector<BoundingSlice> slices(count);
  for (size_t j = 0; j < count; ++j) slices[j] = SliceOfPolarPoints(radii[j], angles[j]);
  return slices;
}

long Renderer::FootprintPixels(const Pose2& pose, int object) const {
  const Primitive* primitive = nullptr;
  for (const Primitive& candidate : primitives_)
    if (candidate.object == object) primitive = &candidate;
  if (!primitive) return 0;
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const Eigen::Vector3d origin = pose.RobotToWorld(origin_robot_);
  long first = 0, last = kNumBins - 1;
  // A pixel in robot bin r lands in world bin r + floor(shift) or one more.
  const long offset = FloorDiv(pose.theta / kBinWidth);
  if (BinRange(*primitive, origin.head<2>(), &first, &last))
    first -= offset + 1, last -= offset;
  else
    first = 0, last = kNumBins - 1;
  long count = 0;
  for (long b = first; b <= last; ++b) {
    const int bin = WrapBin(b);
    for (int k = robot_bin_start_[bin]; k < robot_bin_start_[bin + 1]; ++k) {
      double t = 0.0;
      int part = 0;
      if (HitPrimitive(*primitive, origin, WorldDirection(k, c, s),
                       std::numeric_limits<double>::infinity(), &t, &part))
        ++count;
    }
  }
  return count;
}

}  // namespace oslam

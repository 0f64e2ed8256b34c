#include "calib/observation_model.h"

#include <algorithm>
#include <cmath>

namespace oslam {

double ViewpointHeight(const CameraModel& camera) {
  const MirrorAnnulus& annulus = camera.annulus();
  const double radius = annulus.rim_radius_px > annulus.blind_radius_px
                            ? 0.5 * (annulus.blind_radius_px + annulus.rim_radius_px)
                            : 100.0;
  Ray ray;
  if (!camera.BackProjectPixel(camera.ImageCenter() + Eigen::Vector2d(radius, 0.0), &ray))
    return 0.0;
  return ray.origin_robot.z();
}

SilhouetteModel SilhouetteOf(const CameraModel& camera, ObjectShape shape,
                             double footprint_aspect) {
  constexpr double kPi = 3.14159265358979323846;
  SilhouetteModel model;
  model.enabled = true;
  switch (shape) {
    case ObjectShape::kCylinder:
      break;
    case ObjectShape::kBox: {
      // Mean over yaw of a rectangle's half extent in one direction:
      // (L + W) / pi; per unit diagonal sqrt(L^2 + W^2).
      const double a = std::clamp(footprint_aspect, 0.0, 1.0);
      model.depth_half_extent = model.width_half_extent = (1.0 + a) / (kPi * std::hypot(1.0, a));
      break;
    }
    case ObjectShape::kSphere:
      model.sphere = true;
      model.depth_half_extent = 0.0;
      model.viewpoint_height_m = ViewpointHeight(camera);
      break;
    case ObjectShape::kPanel:
      // Its extents follow from its orientation (PanelExtents); these are
      // their means over the front half space, for code that has none.
      model.panel = true;
      model.depth_half_extent = model.width_half_extent = 1.0 / kPi;
      break;
  }
  return model;
}

namespace {

// The silhouette's radial ends (docs/method.md §4.2, "Silhouette model"): the
// footprint points at +-delta along the line of sight, at the base and at the
// top; the inner end is the smaller radius at the base, the outer end the
// larger at the top. Each end's derivative is taken with respect to the base
// point in the robot frame (3), the diameter and the height.
struct SilhouetteEnd {
  double radius_px = 0.0;
  Eigen::RowVector3d wrt_point = Eigen::RowVector3d::Zero();
  double wrt_diameter = 0.0, wrt_height = 0.0;
};

bool SilhouetteEnds(const CameraModel& camera, const Eigen::Vector3d& base_robot, double range,
                    const CylinderGeometry& object, double depth_half_extent, bool jacobians,
                    SilhouetteEnd* inner, SilhouetteEnd* outer, bool* outer_beyond) {
  const double delta = depth_half_extent * object.diameter_m;
  if (!(range > delta)) return false;  // the robot inside the footprint
  const Eigen::Vector2d along = base_robot.head<2>() / range;
  bool first_base = true, first_top = true;
  for (const int side : {-1, 1}) {
    const double scale = 1.0 + side * delta / range;
    // d(point)/d(base point): the horizontal part scales with the range.
    Eigen::Matrix3d point_wrt_base = Eigen::Matrix3d::Zero();
    point_wrt_base.topLeftCorner<2, 2>() =
        scale * Eigen::Matrix2d::Identity() - side * delta / range * along * along.transpose();
    point_wrt_base(2, 2) = 1.0;
    const Eigen::Vector3d point_wrt_diameter(side * depth_half_extent * along.x(),
                                             side * depth_half_extent * along.y(), 0.0);
    for (const bool top : {false, true}) {
      Eigen::Vector3d point(scale * base_robot.x(), scale * base_robot.y(), base_robot.z());
      if (top) point.z() += object.height_m;
      double radius = 0.0;
      Eigen::RowVector3d wrt = Eigen::RowVector3d::Zero();
      if (!camera.ProjectRadius(point, &radius, jacobians ? &wrt : nullptr)) {
        if (!top || !outer_beyond) return false;
        *outer_beyond = true;  // a top edge beyond the mirror's field of view
        continue;
      }
      SilhouetteEnd* end = top ? outer : inner;
      bool& first = top ? first_top : first_base;
      const bool better = first || (top ? radius > end->radius_px : radius < end->radius_px);
      first = false;
      if (!better) continue;
      end->radius_px = radius;
      if (!jacobians) continue;
      end->wrt_point = wrt * point_wrt_base;
      end->wrt_diameter = wrt.dot(point_wrt_diameter);
      end->wrt_height = top ? wrt(2) : 0.0;
    }
  }
  return true;
}

// A ball's radial ends: the rays from the viewpoint tangent to it in the
// vertical plane through its centre, at elevations atan2(w, rho) -+ asin(r /
// D), r = h/2 its vertical radius, w = z + r - z_v the centre's height above
// the viewpoint, D = sqrt(rho^2 + w^2). Each end is imaged through the point
// at unit distance along its ray.
bool SphereEnds(const CameraModel& camera, const Eigen::Vector3d& base_robot, double range,
                const CylinderGeometry& object, double viewpoint_height, bool jacobians,
                SilhouetteEnd* inner, SilhouetteEnd* outer, bool* outer_beyond) {
  const double r = 0.5 * object.height_m;
  const double w = base_robot.z() + r - viewpoint_height;
  const double distance2 = range * range + w * w;
  const double tangent = std::sqrt(std::max(0.0, distance2 - r * r));  // sqrt(D^2 - r^2)
  if (!(tangent > 0.0)) return false;  // the viewpoint inside the ball
  const double distance = std::sqrt(distance2);
  const double centre = std::atan2(w, range), half = std::asin(r / distance);
  const Eigen::Vector2d along = base_robot.head<2>() / range;
  for (const int side : {-1, 1}) {
    const double elevation = centre + side * half;
    const double c = std::cos(elevation), s = std::sin(elevation);
    const Eigen::Vector3d point(c * along.x(), c * along.y(), viewpoint_height + s);
    SilhouetteEnd* end = side < 0 ? inner : outer;
    Eigen::RowVector3d wrt = Eigen::RowVector3d::Zero();
    if (!camera.ProjectRadius(point, &end->radius_px, jacobians ? &wrt : nullptr)) {
      if (side < 0 || !outer_beyond) return false;
      *outer_beyond = true;
      continue;
    }
    if (!jacobians) continue;
    // d(elevation)/d(rho, w, r).
    const double d_half_d_distance = -r / (distance * tangent);
    const double d_rho = -w / distance2 + side * d_half_d_distance * range / distance;
    const double d_w = range / distance2 + side * d_half_d_distance * w / distance;
    const double d_r = side / tangent;
    const double along_elevation = wrt.dot(Eigen::Vector3d(-s * along.x(), -s * along.y(), c));
    // The point's horizontal direction turns with the base's bearing.
    const Eigen::Matrix2d d_along =
        (Eigen::Matrix2d::Identity() - along * along.transpose()) / range;
    end->wrt_point.head<2>() =
        along_elevation * d_rho * along.transpose() + c * wrt.head<2>() * d_along;
    end->wrt_point(2) = along_elevation * d_w;
    end->wrt_diameter = 0.0;
    end->wrt_height = along_elevation * 0.5 * (d_w + d_r);
  }
  return true;
}

// A panel's half extents per unit width along and across the line of sight
// (docs/method.md §4.2, "Panels"), with their derivatives with respect to
// alpha, the angle from the line of sight to the panel.
struct PanelExtents {
  double depth = 0.0, width = 0.0;
  double depth_wrt_alpha = 0.0, width_wrt_alpha = 0.0;
};

PanelExtents PanelExtentsAt(double alpha) {
  const double c = std::cos(alpha), s = std::sin(alpha);
  constexpr double e2 = kPanelSmoothing * kPanelSmoothing;
  const double smooth_cos = std::sqrt(c * c + e2), smooth_sin = std::sqrt(s * s + e2);
  PanelExtents extents;
  extents.depth = 0.5 * smooth_cos;
  extents.width = 0.5 * smooth_sin;
  extents.depth_wrt_alpha = -0.5 * s * c / smooth_cos;
  extents.width_wrt_alpha = 0.5 * s * c / smooth_sin;
  return extents;
}

}  // namespace

SliceCensoring CensoringOf(const CameraModel& camera, const BoundingSlice& measured,
                           double margin_px) {
  SliceCensoring censoring;
  const MirrorAnnulus& annulus = camera.annulus();
  const double outer_radius = measured.u_r_px + measured.s_r_px;
  censoring.inner = measured.u_r_px <= annulus.blind_radius_px + margin_px;
  censoring.outer = annulus.rim_radius_px > 0 && outer_radius >= annulus.rim_radius_px - margin_px;
  // The image border: the slice's outer corners and middle.
  const int width = camera.image_width(), height = camera.image_height();
  if (!censoring.outer && width > 0 && height > 0) {
    for (const double offset : {-0.5, 0.0, 0.5}) {
      const Eigen::Vector2d pixel =
          camera.PolarToPixel({outer_radius, measured.u_phi_rad + offset * measured.s_phi_rad});
      const double clearance = std::min(
          {pixel.x() + 0.5, width - 0.5 - pixel.x(), pixel.y() + 0.5, height - 0.5 - pixel.y()});
      if (clearance <= margin_px) censoring.outer = true;
    }
  }
  return censoring;
}

bool PredictSlice(const CameraModel& camera, const Pose2& robot_pose_world,
                  const CylinderGeometry& object, BoundingSlice* slice, SliceJacobians* jacobians,
                  const SilhouetteModel& silhouette, bool* top_beyond_view) {
  // Pose2::WorldToRobot, with cos and sin kept for the Jacobians below (one
  // sincos per prediction instead of two).
  const double c = std::cos(robot_pose_world.theta), s = std::sin(robot_pose_world.theta);
  const double dx = object.base_world.x() - robot_pose_world.x,
               dy = object.base_world.y() - robot_pose_world.y;
  const Eigen::Vector3d base_robot(c * dx + s * dy, -s * dx + c * dy, object.base_world.z());
  const Eigen::Vector3d top_robot = base_robot + Eigen::Vector3d(0, 0, object.height_m);
  const double range = std::sqrt(base_robot.x() * base_robot.x() + base_robot.y() * base_robot.y());
  if (!(range > 0.0)) return false;

  PolarPoint base_polar;
  double top_radius = 0.0;
  Eigen::Matrix<double, 2, 3> base_jacobian;
  Eigen::RowVector3d top_jacobian;
  Eigen::Matrix<double, 2, 3>* want_base = jacobians ? &base_jacobian : nullptr;
  Eigen::RowVector3d* want_top = jacobians ? &top_jacobian : nullptr;
  if (!camera.ProjectToPolar(base_robot, &base_polar, want_base)) return false;
  // The top has the base's bearing: only its radius is needed.
  bool beyond = false;
  if (!silhouette.enabled && !camera.ProjectRadius(top_robot, &top_radius, want_top)) {
    if (!top_beyond_view) return false;
    beyond = true;
  }

  const double d = object.diameter_m;
  // A panel's extents depend on alpha = yaw - theta - bearing (robot frame).
  const bool panel = silhouette.enabled && silhouette.panel && !silhouette.sphere;
  PanelExtents extents;
  if (panel)
    extents = PanelExtentsAt(object.yaw_rad - robot_pose_world.theta -
                             std::atan2(base_robot.y(), base_robot.x()));
  const double depth_half_extent = panel ? extents.depth : silhouette.depth_half_extent;
  // s_phi = 2 atan(k d / rho), k = 1/2 in the thesis (A.10).
  const double k = !silhouette.enabled ? 0.5 : panel ? extents.width : silhouette.width_half_extent;
  SilhouetteEnd inner, outer;
  if (silhouette.enabled && silhouette.sphere) {
    if (!SphereEnds(camera, base_robot, range, object, silhouette.viewpoint_height_m,
                    jacobians != nullptr, &inner, &outer, top_beyond_view ? &beyond : nullptr))
      return false;
  } else if (silhouette.enabled) {
    if (!SilhouetteEnds(camera, base_robot, range, object, depth_half_extent, jacobians != nullptr,
                        &inner, &outer, top_beyond_view ? &beyond : nullptr))
      return false;
  } else {
    inner.radius_px = base_polar.radius_px;
    outer.radius_px = top_radius;
    if (jacobians) {
      inner.wrt_point = base_jacobian.row(0);
      outer.wrt_point = top_jacobian;
      outer.wrt_height = top_jacobian(2);
    }
  }
  if (top_beyond_view) *top_beyond_view = beyond;
  if (beyond) {
    // The outer end is past every radius the mirror images.
    outer.radius_px = kBeyondViewRadiusPx;
    outer.wrt_point.setZero();
    outer.wrt_diameter = outer.wrt_height = 0.0;
  }
  slice->u_r_px = inner.radius_px;
  slice->u_phi_rad = base_polar.angle_rad;
  slice->s_r_px = outer.radius_px - inner.radius_px;
  slice->s_phi_rad = 2.0 * std::atan(k * d / range);
  if (!jacobians) return true;

  // d(slice)/d(point in robot frame); the top point moves with the base.
  Eigen::Matrix<double, 4, 3> wrt_point;
  wrt_point.row(0) = inner.wrt_point;
  wrt_point.row(1) = base_jacobian.row(1);
  wrt_point.row(2) = outer.wrt_point - inner.wrt_point;
  const double denominator = range * range + k * k * d * d;
  const double d_width_d_range = -2.0 * k * d / denominator;
  wrt_point.row(3) << d_width_d_range * base_robot.x() / range,
      d_width_d_range * base_robot.y() / range, 0.0;
  // A panel: d(slice)/d(alpha). An end's derivative with respect to the
  // diameter is delta'(d) = k_depth times that with respect to delta.
  Eigen::Vector4d wrt_alpha = Eigen::Vector4d::Zero();
  if (panel) {
    const double per_depth = d / depth_half_extent * extents.depth_wrt_alpha;
    wrt_alpha(0) = inner.wrt_diameter * per_depth;
    wrt_alpha(2) = (outer.wrt_diameter - inner.wrt_diameter) * per_depth;
    wrt_alpha(3) = 2.0 * d * range / denominator * extents.width_wrt_alpha;
    // alpha = yaw - theta - atan2(y, x) of the base point in the robot frame.
    const Eigen::RowVector3d alpha_wrt_point(base_robot.y() / (range * range),
                                             -base_robot.x() / (range * range), 0.0);
    wrt_point += wrt_alpha * alpha_wrt_point;
  }

  // point_robot = R(theta)^T (base_world - t) with z passed through.
  Eigen::Matrix3d point_wrt_base;
  point_wrt_base << c, s, 0, -s, c, 0, 0, 0, 1;
  Eigen::Matrix3d point_wrt_pose;
  point_wrt_pose << -c, -s, base_robot.y(),  //
      s, -c, -base_robot.x(),                //
      0, 0, 0;
  jacobians->wrt_base = wrt_point * point_wrt_base;
  jacobians->wrt_pose = wrt_point * point_wrt_pose;
  jacobians->wrt_pose.col(2) -= wrt_alpha;  // alpha's explicit -theta
  jacobians->wrt_yaw = wrt_alpha;
  jacobians->wrt_size.setZero();
  jacobians->wrt_size(0, 0) = inner.wrt_diameter;
  jacobians->wrt_size(2, 0) = outer.wrt_diameter - inner.wrt_diameter;
  // A ball's lower tangent moves with its height too; a cylinder's base not.
  jacobians->wrt_size(0, 1) = inner.wrt_height;
  jacobians->wrt_size(2, 1) = outer.wrt_height - inner.wrt_height;
  jacobians->wrt_size(3, 0) = 2.0 * k * range / denominator;
  return true;
}

}  // namespace oslam

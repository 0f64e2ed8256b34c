// The one camera-model interface used by detect, mapping, export and the
// simulator (COLMAP-style: one interface, a short list of models, a recipe).
//
// Frames and units
//   robot frame: x forward, y left, z up, origin on the floor below the
//                camera axis; metres.
//   image:       pixels, OpenCV convention (x right, y down, pixel centres at
//                integer coordinates).
//   polar image coordinates: (radius_px, angle_rad) of a pixel around the
//                model's image centre, angle = atan2(y - cy, x - cx) wrapped
//                to (-pi, pi]. Detections ("bounding slices") live here.
//
// Adding a model (recipe)
//   1. Derive from CameraModel; name the intrinsics (IntrinsicNames) so
//      camera.yaml can store them; implement Validate, ProjectToPixel (with the
//      analytic 2x3 Jacobian) and BackProjectPixel.
//   2. Register it in CreateCameraModel() in camera_io.cpp.
//   3. Add it to the camera list of tests/calib/camera_cases.h, which the
//      model tests (Jacobians, projection round trips) and the camera.yaml
//      tests (save/load) run over.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace oslam {

struct PolarPoint {
  double radius_px = 0.0;
  double angle_rad = 0.0;
};

// A ray in the robot frame, from the camera's single effective viewpoint.
struct Ray {
  Eigen::Vector3d origin_robot = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction_robot = Eigen::Vector3d::UnitZ();  // unit length
};

// Where the mirror is imaged: an annulus around the image centre, between the
// central blind disc (camera and robot reflected in the mirror) and the rim.
struct MirrorAnnulus {
  double blind_radius_px = 0.0;
  double rim_radius_px = 0.0;
};

class CameraModel {
 public:
  virtual ~CameraModel() = default;

  virtual std::string ModelName() const = 0;
  virtual std::unique_ptr<CameraModel> Clone() const = 0;

  // Named intrinsic parameters (SI units and pixels, names carry the unit).
  virtual std::vector<std::string> IntrinsicNames() const = 0;
  virtual Eigen::VectorXd Intrinsics() const = 0;
  // Throws oslam::Error when the vector has the wrong size; call Validate after.
  virtual void SetIntrinsics(const Eigen::VectorXd& intrinsics) = 0;
  // Checks every parameter (finite, in range); fills `why` on failure.
  virtual bool Validate(std::string* why) const;

  // Centre of the polar image coordinates (pixels).
  virtual Eigen::Vector2d ImageCenter() const = 0;

  // Projects a point in the robot frame. Returns false when the point has no
  // image (outside the mirror's field of view, or at the viewpoint). The
  // Jacobian is d(pixel)/d(point_robot).
  virtual bool ProjectToPixel(const Eigen::Vector3d& point_robot, Eigen::Vector2d* pixel,
                              Eigen::Matrix<double, 2, 3>* jacobian = nullptr) const = 0;

  // The ray that images at `pixel`. Returns false for pixels no ray reaches.
  virtual bool BackProjectPixel(const Eigen::Vector2d& pixel, Ray* ray) const = 0;

  // The projection in polar image coordinates, with d(radius, angle)/d(point).
  // By default through ProjectToPixel; a model whose polar form is direct
  // (the hyperbolic mirror: radius = T(r, z), angle = bearing) overrides it,
  // as it is the inner loop of the bounding-slice factor.
  virtual bool ProjectToPolar(const Eigen::Vector3d& point_robot, PolarPoint* polar,
                              Eigen::Matrix<double, 2, 3>* jacobian = nullptr) const;
  // The radius alone, with d(radius)/d(point) (the top of a bounding slice,
  // whose angle is the base's). By default the first row of ProjectToPolar;
  // the hyperbolic mirror skips the angle's atan2.
  virtual bool ProjectRadius(const Eigen::Vector3d& point_robot, double* radius_px,
                             Eigen::RowVector3d* jacobian = nullptr) const;

  // ---- shared by every model ----

  PolarPoint PixelToPolar(const Eigen::Vector2d& pixel) const;
  Eigen::Vector2d PolarToPixel(const PolarPoint& polar) const;
  // d(radius, angle)/d(pixel) at `pixel`.
  Eigen::Matrix2d PolarJacobianWrtPixel(const Eigen::Vector2d& pixel) const;

  int image_width() const { return image_width_; }
  int image_height() const { return image_height_; }
  void set_image_size(int width, int height) {
    image_width_ = width;
    image_height_ = height;
  }
  const MirrorAnnulus& annulus() const { return annulus_; }
  void set_annulus(const MirrorAnnulus& annulus) { annulus_ = annulus; }
  // Inside the image and inside the mirror annulus.
  bool IsInAnnulus(const Eigen::Vector2d& pixel) const;

 protected:
  // For the models' Validate: true when `value` lies in [low, high] (the
  // bounds of docs/formats.md), else false with `why` naming the parameter.
  static bool CheckIntrinsic(const std::string& name, double value, double low, double high,
                             const std::string& unit, std::string* why);
  // The principal point within the image, give or take one image size.
  bool CheckPrincipalPoint(double x_px, double y_px, std::string* why) const;

 private:
  int image_width_ = 0;
  int image_height_ = 0;
  MirrorAnnulus annulus_;
};

}  // namespace oslam

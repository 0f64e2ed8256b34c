// Ray-casting renderer of omnidirectional frames. Every pixel of the mirror
// annulus is back-projected through the camera model (BackProjectPixel) and
// the ray is intersected analytically with the scene, so the image agrees with
// the camera model to the accuracy of one ray per pixel centre.
//
// Speed: the rays are fixed in the robot frame, so they are computed once.
// Pixels are grouped by bearing; per frame each primitive is entered in the
// bearing bins it can cover from the robot's position, and a pixel only tests
// the primitives of its bin (plus the floor and ceiling planes).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "core/bounding_slice.h"
#include "core/pose2.h"
#include "samples/scene.h"

namespace oslam {

// Per-frame conditions drawn by the simulator.
struct FrameConditions {
  double gain = 1.0;            // exposure: multiplies the radiance
  std::uint64_t noise_key = 0;  // seeds this frame's sensor noise
};

struct FrameRender {
  cv::Mat image;       // CV_8UC3, BGR
  cv::Mat object_ids;  // CV_32SC1, index into scene.objects of the visible surface, -1 if none
  std::vector<long> visible_pixels;  // per scene object
};

struct RendererOptions {
  // Test every primitive for every pixel (no bearing bins): slow, used to check
  // that binning never drops a surface.
  bool brute_force = false;
};

class Renderer {
 public:
  // `scene` must outlive the renderer.
  explicit Renderer(const Scene& scene, const RendererOptions& options = {});

  void Render(const Pose2& pose, const FrameConditions& conditions, FrameRender* out) const;

  // Annulus pixels whose ray hits `object` when nothing else is in the way:
  // the object's unoccluded image footprint, for the visible fraction.
  long FootprintPixels(const Pose2& pose, int object) const;

  // Bounding slice of each object's visible pixels in a rendered frame (a
  // zero slice for objects not seen): what an ideal pixel-exact detector
  // would report, as opposed to the cylinder model's slice.
  std::vector<BoundingSlice> VisibleSlices(const FrameRender& render) const;

  size_t num_annulus_pixels() const { return pixel_index_.size(); }

  // Rendering internals, public for the implementation's helpers.
  enum class Kind { kVertical, kCylinder, kBox, kSphere, kBoard };
  struct Primitive {
    Kind kind = Kind::kVertical;
    int object = -1;  // scene object, -1 for walls
    const Material* material = nullptr;
    Eigen::Vector2d from = Eigen::Vector2d::Zero();      // vertical rectangle start
    Eigen::Vector2d edge = Eigen::Vector2d::Zero();      // vertical rectangle direction * length
    Eigen::Vector3d center = Eigen::Vector3d::Zero();    // cylinder axis foot, sphere/box centre
    Eigen::Vector3d half = Eigen::Vector3d::Zero();      // box half extents
    double radius = 0.0;                                 // cylinder, sphere
    double z0 = 0.0, z1 = 0.0;                           // vertical extent
    double cos_yaw = 1.0, sin_yaw = 0.0;                 // box
    double bound_radius = 0.0;                           // footprint bounding circle
    Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // board: world from (u, v, normal)
  };
  struct Hit {
    double t = 0.0;
    int primitive = -1;  // -1 floor, -2 ceiling, -3 nothing
    int part = 0;        // which face was hit
  };

 private:
  struct BinLists {
    std::vector<int> start;  // size num_bins + 1
    std::vector<int> items;
  };
  BinLists BuildBins(const Eigen::Vector2d& robot_xy) const;
  // World bins [first, last] (may exceed the bin range; taken modulo) a
  // primitive can cover; false when it covers every bin.
  bool BinRange(const Primitive& primitive, const Eigen::Vector2d& robot_xy, long* first,
                long* last) const;
  Hit Trace(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, const int* candidates,
            int count) const;
  // `k` (annulus pixel) and the pose's (c, s) = (cos, sin) of theta are used to
  // anti-alias checkerboards; k < 0 samples the albedo at the hit only.
  Eigen::Vector3f Shade(const Hit& hit, const Eigen::Vector3d& origin,
                        const Eigen::Vector3d& direction, long k = -1, double c = 1.0,
                        double s = 0.0) const;
  Eigen::Vector3f BoardAlbedo(const Primitive& board, const Eigen::Vector3d& origin,
                              const Eigen::Vector3d& hit_direction, long k, double c,
                              double s) const;
  Eigen::Vector3d WorldDirection(size_t k, double c, double s) const;

  const Scene& scene_;
  RendererOptions options_;
  std::vector<Primitive> primitives_;
  Eigen::Vector3d origin_robot_ = Eigen::Vector3d::Zero();
  // Annulus pixels sorted by robot-frame bearing bin.
  std::vector<int> pixel_index_;            // y * width + x
  std::vector<Eigen::Vector3d> ray_robot_;  // unit directions, robot frame
  std::vector<double> bin_position_;        // (bearing + pi) / bin width, in [0, num_bins)
  std::vector<int> robot_bin_start_;        // CSR offsets into the pixel arrays
};

}  // namespace oslam

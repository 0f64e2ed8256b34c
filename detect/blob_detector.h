// Colour-blob detector (CMVision-style, docs/method.md §10.2): per-pixel class by YUV
// box, optional opening, connected components, minimum area, restricted to the
// mirror annulus; each blob becomes a bounding slice in polar image
// coordinates (docs/method.md §10.1: u_r = inner radius, u_phi = middle angle).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"
#include "core/bounding_slice.h"
#include "core/run_folder.h"
#include "detect/colour_classifier.h"
#include "detect/view_checks.h"

namespace oslam {

struct Detection {
  long frame = 0;
  int class_index = -1;
  std::string class_name;
  BoundingSlice slice;
  int area_px = 0;
  std::array<double, 3> mean_yuv{};
  // exp(-D²/2) of the blob's mean colour to the class box centre, with D the
  // distance in standard deviations under the detector's box shape
  // (ColourClassifier::SquaredDistance): 1 = the class's typical colour.
  double score = 0.0;
  // Bit c set when class c's colour box also holds at least half of this
  // blob's pixels: a look-alike colour (BlobDetectorOptions::separate_look_alikes).
  uint32_t look_alike_classes = 0;
  // How far the view is from what an object of its class would look like
  // where it stands (ViewSquaredDistance; 0 when the detector did not check).
  double view_distance2 = 0.0;
};

struct BlobDetectorOptions {
  int min_area_px = 40;            // smaller blobs are noise
  int opening_radius_px = 1;       // morphological opening per class mask; 0 = off
  bool annulus_only = true;        // ignore the blind disc and everything beyond the mirror rim
  ColourClassifierOptions colour;  // box shape (thesis YUV box or brightness-scaled)
  // Colour verification (docs/detection.md "Verification by the blob's mean colour"): drop a blob
  // whose mean colour lies further than this many standard deviations from its class's learnt blob
  // colour (ColourBox::blob_chroma; classes without one pass): the tail probability of ± that many
  // sigmas of a normal, as a chi-square of two degrees of freedom (3 → D² 11.8). inf = off.
  double max_blob_colour_distance = 3.0;
  // Where the blobs of two classes are the same pixels (look-alike colours,
  // e.g. an orange ball and an orange bucket), keep only the class whose colour
  // and image shape (ObjectClass::image_shape) fit the blob better. Classes
  // without an image shape model are always kept.
  bool separate_look_alikes = true;
  // ... when at least this share of a blob lies in the other class's blob's slice.
  double look_alike_coverage = 0.5;
  // Drop a detection whose slice's elongation lies more than this many
  // standard deviations (ShapeSquaredDistance) from its class's image shape
  // model: a thin pole or a door is no ball. inf = off.
  double max_shape_distance = std::numeric_limits<double>::infinity();
  // Verification (docs/method.md §10.5): drop a detection whose view
  // distance, image shape plus the size it would have standing on the floor
  // against its class's models (ViewSquaredDistance), exceeds this many
  // standard deviations; then, of a group of same-class blobs closer than
  // fragment_gap_px to each other in one frame, drop every member when the
  // group together fails the check (the pieces of a larger thing that an
  // occluder cut apart: a chair behind a person's legs is no set of
  // bottles). inf = off (the thesis' detector).
  double max_view_distance = 3.0;
  double fragment_gap_px = 15.0;
  // ... and when a group of fragments that each pass the check fits its
  // class better together than its best member does (and passes), report
  // it as one detection of the union slice: an object cut apart by its own
  // pattern (vertical stripes) or by a thin occluder in front of it (a
  // mirror support rod). docs/method.md §10.5.
  bool join_fragments = true;
  // Drop every member of a group that fails together (above). Two objects
  // of one class side by side also fail together, so this loses both in
  // the frames where they look close.
  bool drop_fragments = true;
  ViewCheckOptions view_checks;
  bool Validate(std::string* why) const;
};

// (elongation − mean)² / variance of a slice under a class's image shape
// model; the variance adds `radial_std_px` of error on the radial length and
// `arc_std_px` on the arc width (one pixel of quantisation when comparing two
// blobs of the same pixels; the detector's slice errors, ViewCheckOptions,
// when comparing with the model).
double ShapeSquaredDistance(const ImageShapeModel& model, const BoundingSlice& slice,
                            double radial_std_px = 1.0, double arc_std_px = 1.0);

// The D² of two degrees of freedom whose tail probability is that of a
// normal beyond ± `sigmas` (−2 log erfc(sigmas / √2)); inf for inf.
double TwoDofSquaredDistanceOfSigmas(double sigmas);

// The view distance of a detection's slice under its class: the shape
// distance (when the class has an image shape model; for a slice cut by the
// blind disc or the mirror rim, whose true elongation is larger, only when its
// elongation is above the class's mean) plus SupportedSizeSquaredDistance with
// the base on the floor. A chi-square of up to 3 degrees of freedom for an
// object of the class.
double ViewSquaredDistance(const CameraModel& camera, const ObjectClass& object_class,
                           const BoundingSlice& slice, const ViewCheckOptions& options);

class BlobDetector {
 public:
  // Keeps a copy of what it needs from the camera (polar coordinates of every
  // pixel, the annulus mask); throws oslam::Error on invalid options.
  // `static_mask` (CV_8U, image size, 0 = ignored; empty = none) removes the
  // rig's own pixels (detect/static_mask.h) from the annulus.
  BlobDetector(const CameraModel& camera, const std::vector<ObjectClass>& classes,
               const BlobDetectorOptions& options = {}, const cv::Mat& static_mask = cv::Mat());

  // Detections in a BGR frame of the camera's image size.
  std::vector<Detection> Detect(const cv::Mat& bgr, long frame) const;

  const cv::Mat& annulus_mask() const { return mask_; }

 private:
  // `labels` covers the image region starting at `offset`; `box` is in labels' coordinates.
  Detection DescribeBlob(const cv::Mat& labels, int label, const cv::Rect& box,
                         const cv::Point& offset, const cv::Mat& yuv, const cv::Mat& class_bits,
                         int class_index, long frame) const;
  // Drops each detection that a look-alike detection of another class covers
  // and explains better (lower colour plus shape distance).
  void SeparateLookAlikes(std::vector<Detection>* detections) const;
  // BlobDetectorOptions::max_view_distance: the check of each detection,
  // then of groups of fragments (dropped, joined or kept each).
  void VerifyViews(std::vector<Detection>* detections) const;
  // Adds a piece's pixels (area, mean colour, look-alike bits) to a joined
  // detection; the caller sets the union slice and the score.
  static void JoinInto(Detection* joined, const Detection& piece);

  std::vector<ObjectClass> classes_;
  BlobDetectorOptions options_;
  std::shared_ptr<const CameraModel> camera_;
  ColourClassifier classifier_;
  cv::Mat mask_;       // CV_8U, 255 inside the annulus
  cv::Mat radius_px_;  // CV_32F polar radius of each pixel centre
  cv::Mat angle_rad_;  // CV_32F polar angle of each pixel centre
};

// Writes detections as CSV (docs/formats.md), atomically.
void WriteDetections(const std::vector<Detection>& detections, const std::string& path);
// Reads them back; class names must be in `classes`.
std::vector<Detection> ReadDetections(const std::string& path,
                                      const std::vector<ObjectClass>& classes);

// The outline of a bounding slice (annular sector) in pixels: inner arc,
// then outer arc backwards; what DrawSlice draws.
std::vector<cv::Point> SliceOutline(const CameraModel& camera, const BoundingSlice& slice);

// Draws a bounding slice (annular sector outline) on an image.
void DrawSlice(cv::Mat* image, const CameraModel& camera, const BoundingSlice& slice,
               const cv::Scalar& colour, int thickness = 1);

}  // namespace oslam

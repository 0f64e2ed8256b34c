// The run folder ("video folder") a user points oslam at; format in
// docs/formats.md. Readers validate everything up front and throw
// oslam::Error naming the file, line (or key) and problem.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/bounding_slice.h"
#include "core/csv.h"
#include "core/motion_model.h"
#include "core/odometry_sync.h"
#include "core/pose2.h"

namespace oslam {

// ---- classes.yaml ----

// The mean colour of a class's whole colour blobs, learnt in training
// (docs/detection.md, "Verification by the blob's mean colour"): each blob's
// mean chroma (U − 128, V − 128) scaled to its box's brightness (times
// yuv_mean[0] / Y), so a dimmer or brighter view of the same paint lands on
// the same point; mean and standard deviation over the training views. A
// pixel's colour varies with shading across the object, a blob's mean far
// less: a pale carton whose pixels pass a yellow box's colour test still has
// a mean colour no yellow box's blob has.
struct BlobChroma {
  std::array<double, 2> mean{};
  std::array<double, 2> std{};
};

// CMVision-style colour box in YUV (OpenCV's YCrCb order is not used: Y, U, V).
struct ColourBox {
  std::array<double, 3> yuv_mean{};
  std::array<double, 3> yuv_std{};
  double k_sigma = 3.0;                   // box half-width in standard deviations (thesis: 3)
  std::optional<BlobChroma> blob_chroma;  // learnt with the detector's errors; optional
};

// How a class's whole, unoccluded views look in the image, learnt from
// examples: the elongation of its bounding slice (SliceElongation: radial
// length over arc width, about 1 for a ball and 1.35 for a bucket a bit taller
// than wide). Lets the detector tell apart look-alike colours of differently
// shaped classes.
struct ImageShapeModel {
  double elongation_mean = 1.0;
  double elongation_std = 0.1;
  // The detector's arc-width error for the class's whole views (68th
  // percentile of its size, about one standard deviation), in pixels,
  // measured in training (0: not measured; the view checks
  // then assume ViewCheckOptions::arc_std_px). A plain object's colour blob
  // is about 1 px wider than its silhouette; a striped one's edges can lose
  // several pixels.
  double arc_error_px = 0.0;
};

// The volume a class is drawn as in the exported files (docs/export.md). The
// method itself models every object as an upright cylinder (docs/method.md
// §2); the shape changes the drawing only.
enum class ObjectShape { kCylinder, kBox, kSphere, kPanel };

// "cylinder", "box", "sphere", "panel".
const char* ObjectShapeName(ObjectShape shape);
// The shape of that name; nullopt for any other text.
std::optional<ObjectShape> ParseObjectShape(const std::string& name);

struct ObjectClass {
  std::string name;
  std::array<int, 3> display_rgb{128, 128, 128};
  ObjectShape shape = ObjectShape::kCylinder;  // optional `shape:` in classes.yaml
  // Size prior (thesis Tables 6.1/6.2): mean and std of diameter and height.
  double diameter_mean_m = 0.0;
  double diameter_std_m = 0.0;
  double height_mean_m = 0.0;
  double height_std_m = 0.0;
  // Box footprint width / length (<= 1), for the silhouette of docs/method.md
  // §4.2; optional `footprint_aspect:`, default 1 (square).
  double footprint_aspect = 1.0;
  // Support prior (docs/method.md §5.1): the base point's height ~ N(base_height_m,
  // base_height_std_m^2). Default: on the floor within 3 cm. `base_height_std_m:
  // none` in classes.yaml: no support (floating, wall-mounted; the run's
  // location prior in z applies).
  double base_height_m = 0.0;
  double base_height_std_m = 0.03;
  bool supported = true;
  std::optional<ColourBox> colour;             // detector settings, once trained
  std::optional<ImageShapeModel> image_shape;  // likewise; optional
};

// P(detected class a | true class c) as matrix[c][a], rows in the order of
// the classes (docs/method.md §7.1); stored under `confusion:` in classes.yaml.
using ConfusionMatrix = std::vector<std::vector<double>>;

std::vector<ObjectClass> ReadClasses(const std::string& path);
// The optional confusion matrix of classes.yaml: N rows of N probabilities
// summing to 1 (checked), N = number of classes.
std::optional<ConfusionMatrix> ReadConfusion(const std::string& path);
void WriteClasses(const std::vector<ObjectClass>& classes, const std::string& path,
                  const std::optional<ConfusionMatrix>& confusion = std::nullopt);
// Index of `name`, or -1.
int FindClass(const std::vector<ObjectClass>& classes, const std::string& name);

// ---- odometry.csv ----

enum class OdometryKind { kPoses, kIncrements };

struct Odometry {
  OdometryKind kind = OdometryKind::kPoses;
  // One per frame; increments[0] is zero (nothing before the first frame),
  // increments[i] takes pose i-1 to pose i.
  std::vector<OdometryIncrement> increments;
  // The integrated odometry poses, starting from the first row (poses) or the
  // origin (increments).
  std::vector<Pose2> poses;
};

// Columns "frame,x_m,y_m,theta_rad" (integrated poses) or
// "frame,distance_m,turn_rad" (increments). Frames must be 0,1,2,... with no
// gap. When expected_rows >= 0 the row count must equal it.
Odometry ReadOdometry(const std::string& path, long expected_rows = -1);
void WriteOdometryPoses(const std::vector<Pose2>& poses, const std::string& path);

// Odometry by time: a `stamp_s` column and no `frame` column. Rows at the
// odometry's own rate, stamps strictly increasing, with x_m,y_m,theta_rad
// (poses) or distance_m,turn_rad (increments, integrated from the origin;
// row 0's ignored). docs/formats.md, "Odometry by time".
bool IsTimedOdometry(const std::string& path);
TimedOdometry ReadTimedOdometry(const std::string& path);

// ---- frames ----

// Decoded image frames may be kept in memory, process-wide, up to `bytes`
// (0, the default: none kept; lowering the limit drops the kept frames).
// `oslam run` sets it so the export stage's overlays reuse the frames the
// detect stage decoded. Frames are kept by file path for the life of the
// process: callers must not modify a frame Read returns (clone it first).
void SetFrameCacheLimit(size_t bytes);

// Frames of a run: the images in RUN/frames/ sorted by name (png, jpg, jpeg,
// bmp, tif, tiff), or else a video read by OpenCV: the file given instead of
// the run folder, or RUN/video.*.
//
// A video is decoded once, in order: reading frame i continues the decoder
// from where the last read stopped (frames decoded on the way and not yet
// asked for wait in a short queue, so threads asking in nearly increasing
// order share one pass); only a read behind the decoder or far ahead of it
// seeks.
class FrameSource {
 public:
  // `run_or_video`: a run folder, or a video file whose folder is the run folder.
  explicit FrameSource(const std::string& run_or_video);
  ~FrameSource();
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  size_t size() const { return count_; }
  // Colour (BGR 8-bit) frame i; throws naming the file when it cannot be read.
  // Safe to call from several threads at once.
  cv::Mat Read(size_t index) const;
  // File name of frame i (the video file for videos).
  std::string Name(size_t index) const;
  bool is_video() const { return !video_path_.empty(); }
  // Each frame's time in seconds: RUN/frame_times.csv (columns frame,stamp_s,
  // one row per frame, increasing) when present; else, for a video, the
  // container's frame rate (frame i at i / fps); else empty.
  const std::vector<double>& times() const { return times_; }
  // Where the times came from: "frame_times.csv", "video frame rate" or "".
  const std::string& times_source() const { return times_source_; }

 private:
  struct Decoder;
  cv::Mat Decode(size_t index) const;

  std::vector<std::string> image_paths_;
  std::string video_path_;
  size_t count_ = 0;
  std::vector<double> times_;
  std::string times_source_;
  std::unique_ptr<Decoder> decoder_;
};

// ---- ground_truth/ (written by the simulator) ----

struct GroundTruthObject {
  int id = 0;
  std::string class_name;  // empty for distractors of no class
  std::string shape;       // cylinder | box | sphere | panel
  Eigen::Vector3d base_world = Eigen::Vector3d::Zero();
  double diameter_m = 0.0;  // O-Map cylinder equivalent (boxes: sqrt(L^2 + W^2))
  double height_m = 0.0;
  double length_m = 0.0;  // box/panel extents along its own x / y, 0 otherwise
  double width_m = 0.0;
  double yaw_rad = 0.0;
};

struct GroundTruthSighting {
  long frame = 0;
  int object_id = 0;
  double u_r_px = 0, u_phi_rad = 0, s_r_px = 0, s_phi_rad = 0;
  double visible_fraction = 1.0;  // unoccluded share of the object's image footprint
};

struct GroundTruth {
  std::vector<Pose2> trajectory;  // one per frame
  std::vector<GroundTruthObject> objects;
  std::vector<GroundTruthSighting> sightings;
};

// Reads RUN/ground_truth/{trajectory,objects,sightings}.csv; nullopt when the
// folder is absent.
std::optional<GroundTruth> ReadGroundTruth(const std::string& run_dir);
void WriteGroundTruth(const GroundTruth& truth, const std::string& run_dir);

// ---- bounding slices in CSV files ----

// The slice in columns u_r_px, u_phi_rad, s_r_px, s_phi_rad of `row`, each
// within its bound (docs/formats.md, Bounds): radii in [0, 2 x the largest
// image side], widths in [0, 2 pi]. Throws "FILE:LINE: ..." otherwise.
BoundingSlice SliceAtRow(const CsvTable& table, size_t row);

// ---- the whole folder ----

// The files of a run. `run_or_video` is the run folder, or a video file in
// it (then `video` is that file and `dir` its folder).
struct RunFolderPaths {
  std::string dir, camera, classes, odometry, ground_truth, detections, video;
  std::string mask;  // RUN/mask.png: the static mask (docs/formats.md), optional
  static RunFolderPaths Of(const std::string& run_or_video);
};

}  // namespace oslam

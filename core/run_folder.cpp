#include "core/run_folder.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "core/atomic_file.h"
#include "core/bounds.h"
#include "core/csv.h"
#include "core/error.h"
#include "core/image_file.h"
#include "core/text.h"
#include "core/yaml.h"

namespace oslam {
namespace fs = std::filesystem;

// ---------------------------------------------------------------- classes

const char* ObjectShapeName(ObjectShape shape) {
  switch (shape) {
    case ObjectShape::kBox:
      return "box";
    case ObjectShape::kSphere:
      return "sphere";
    case ObjectShape::kPanel:
      return "panel";
    case ObjectShape::kCylinder:
      break;
  }
  return "cylinder";
}

std::optional<ObjectShape> ParseObjectShape(const std::string& name) {
  for (const ObjectShape shape :
       {ObjectShape::kCylinder, ObjectShape::kBox, ObjectShape::kSphere, ObjectShape::kPanel})
    if (name == ObjectShapeName(shape)) return shape;
  return std::nullopt;
}

namespace {

// A colour box wider than this many standard deviations holds every colour.
constexpr double kMaxSigmas = 100.0;
// Radial length over arc width of an object's image: far beyond any object.
constexpr double kMaxElongation = 1000.0;
constexpr double kMaxArcErrorPx = 1e4;  // pixels: beyond any image

const std::vector<std::string> kClassKeys = {
    "name",           "display_rgb",       "shape",        "diameter_mean_m",
    "diameter_std_m", "height_mean_m",     "height_std_m", "footprint_aspect",
    "base_height_m",  "base_height_std_m", "colour",       "image_shape"};

// The optional footprint aspect and support prior of a class.
void ParseClassGeometry(const YamlFile& file, const cv::FileNode& node, const std::string& key,
                        ObjectClass* object_class) {
  object_class->footprint_aspect = file.OptionalDouble(node, "footprint_aspect", 1.0, key);
  if (!(object_class->footprint_aspect > 0 && object_class->footprint_aspect <= 1))
    file.Fail(key + "footprint_aspect", "must be in (0, 1] (footprint width / length)");
  object_class->base_height_m = file.OptionalDouble(node, "base_height_m", 0.0, key);
  file.Within(object_class->base_height_m, key + "base_height_m", -bounds::kObjectSizeM,
              bounds::kObjectSizeM, "m");
  const cv::FileNode spread = node["base_height_std_m"];
  if (spread.isString() && static_cast<std::string>(spread) == "none") {
    object_class->supported = false;
  } else {
    object_class->base_height_std_m = file.OptionalDouble(node, "base_height_std_m", 0.03, key);
    if (!(object_class->base_height_std_m > 0))
      file.Fail(key + "base_height_std_m", "must be positive (or none: no support)");
    file.Within(object_class->base_height_std_m, key + "base_height_std_m", bounds::kMinStdM,
                bounds::kObjectSizeM, "m");
  }
}

ObjectClass ParseClass(const YamlFile& file, const cv::FileNode& node, const std::string& prefix) {
  if (!node.isMap()) file.Fail(prefix, "each class must be a mapping");
  file.RequireOnlyKeys(node, prefix + ".", kClassKeys);
  const std::string key = prefix + ".";
  ObjectClass object_class;
  object_class.name = file.String(node, "name", key);
  if (object_class.name.empty()) file.Fail(key + "name", "must not be empty");
  const std::vector<double> rgb = file.Doubles(node, "display_rgb", 3, key);
  for (int c = 0; c < 3; ++c) {
    if (rgb[c] < 0 || rgb[c] > 255) file.Fail(key + "display_rgb", "entries must be 0..255");
    object_class.display_rgb[c] = static_cast<int>(std::lround(rgb[c]));
  }
  if (!node["shape"].empty() && !node["shape"].isNone()) {
    const std::optional<ObjectShape> shape = ParseObjectShape(file.String(node, "shape", key));
    if (!shape) file.Fail(key + "shape", "must be one of cylinder, box, sphere, panel");
    object_class.shape = *shape;
  }
  object_class.diameter_mean_m = file.Double(node, "diameter_mean_m", key);
  object_class.diameter_std_m = file.Double(node, "diameter_std_m", key);
  object_class.height_mean_m = file.Double(node, "height_mean_m", key);
  object_class.height_std_m = file.Double(node, "height_std_m", key);
  for (const char* field : {"diameter_mean_m", "diameter_std_m", "height_mean_m", "height_std_m"}) {
    const double value = file.Double(node, field, key);
    if (!(value > 0)) file.Fail(key + field, "must be positive");
    const bool is_std = std::string(field).find("_std_") != std::string::npos;
    file.Within(value, key + field, is_std ? bounds::kMinStdM : 0, bounds::kObjectSizeM, "m");
  }
  ParseClassGeometry(file, node, key, &object_class);
  const cv::FileNode colour = node["colour"];
  if (!colour.empty() && !colour.isNone()) {
    const std::string colour_key = key + "colour.";
    if (!colour.isMap()) file.Fail(key + "colour", "must be a mapping");
    file.RequireOnlyKeys(colour, colour_key,
                         {"yuv_mean", "yuv_std", "k_sigma", "blob_chroma_mean", "blob_chroma_std"});
    ColourBox box;
    const std::vector<double> mean = file.Doubles(colour, "yuv_mean", 3, colour_key);
    const std::vector<double> stddev = file.Doubles(colour, "yuv_std", 3, colour_key);
    std::copy(mean.begin(), mean.end(), box.yuv_mean.begin());
    std::copy(stddev.begin(), stddev.end(), box.yuv_std.begin());
    for (double m : mean) file.Within(m, colour_key + "yuv_mean", 0, 255);
    for (double s : stddev)
      if (s < 0) file.Fail(colour_key + "yuv_std", "must be non-negative");
    for (double s : stddev) file.Within(s, colour_key + "yuv_std", 0, 255);
    box.k_sigma = file.OptionalDouble(colour, "k_sigma", 3.0, colour_key);
    if (!(box.k_sigma > 0)) file.Fail(colour_key + "k_sigma", "must be positive");
    file.Within(box.k_sigma, colour_key + "k_sigma", 0, kMaxSigmas);
    const bool has_blob_mean = !colour["blob_chroma_mean"].empty();
    if (has_blob_mean != !colour["blob_chroma_std"].empty())
      file.Fail(colour_key + (has_blob_mean ? "blob_chroma_std" : "blob_chroma_mean"),
                "missing: blob_chroma_mean and blob_chroma_std come together");
    if (has_blob_mean) {
      BlobChroma blob;
      const std::vector<double> blob_mean = file.Doubles(colour, "blob_chroma_mean", 2, colour_key);
      const std::vector<double> blob_std = file.Doubles(colour, "blob_chroma_std", 2, colour_key);
      for (int ch = 0; ch < 2; ++ch) {
        blob.mean[ch] = blob_mean[ch];
        blob.std[ch] = blob_std[ch];
        file.Within(blob.mean[ch], colour_key + "blob_chroma_mean", -255, 255);
        if (!(blob.std[ch] > 0)) file.Fail(colour_key + "blob_chroma_std", "must be positive");
        file.Within(blob.std[ch], colour_key + "blob_chroma_std", 0, 255);
      }
      box.blob_chroma = blob;
    }
    object_class.colour = box;
  }
  const cv::FileNode shape = node["image_shape"];
  if (!shape.empty() && !shape.isNone()) {
    const std::string shape_key = key + "image_shape.";
    if (!shape.isMap()) file.Fail(key + "image_shape", "must be a mapping");
    file.RequireOnlyKeys(shape, shape_key, {"elongation_mean", "elongation_std", "arc_error_px"});
    ImageShapeModel model;
    model.elongation_mean = file.Double(shape, "elongation_mean", shape_key);
    model.elongation_std = file.Double(shape, "elongation_std", shape_key);
    if (!(model.elongation_mean > 0)) file.Fail(shape_key + "elongation_mean", "must be positive");
    if (!(model.elongation_std > 0)) file.Fail(shape_key + "elongation_std", "must be positive");
    file.Within(model.elongation_mean, shape_key + "elongation_mean", 0, kMaxElongation);
    file.Within(model.elongation_std, shape_key + "elongation_std", 0, kMaxElongation);
    model.arc_error_px = file.OptionalDouble(shape, "arc_error_px", 0.0, shape_key);
    if (!(model.arc_error_px >= 0)) file.Fail(shape_key + "arc_error_px", "must be >= 0");
    file.Within(model.arc_error_px, shape_key + "arc_error_px", 0, kMaxArcErrorPx);
    object_class.image_shape = model;
  }
  return object_class;
}

}  // namespace

std::vector<ObjectClass> ReadClasses(const std::string& path) {
  YamlFile file(path);
  file.RequireOnlyKeys(file.root(), "", {"classes", "confusion"});
  const cv::FileNode list = file.Seq(file.root(), "classes");
  if (list.size() == 0) file.Fail("classes", "no classes listed");
  std::vector<ObjectClass> classes;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string prefix = "classes[" + std::to_string(i) + "]";
    ObjectClass object_class = ParseClass(file, list[static_cast<int>(i)], prefix);
    if (FindClass(classes, object_class.name) >= 0)
      file.Fail(prefix + ".name", "duplicate class '" + object_class.name + "'");
    classes.push_back(std::move(object_class));
  }
  return classes;
}

std::optional<ConfusionMatrix> ReadConfusion(const std::string& path) {
  const size_t num_classes = ReadClasses(path).size();
  YamlFile file(path);
  const cv::FileNode node = file.root()["confusion"];
  if (node.empty() || node.isNone()) return std::nullopt;
  if (!node.isSeq() || node.size() != num_classes)
    file.Fail("confusion",
              "must be a list of " + std::to_string(num_classes) + " rows, one per class");
  ConfusionMatrix matrix;
  for (size_t c = 0; c < num_classes; ++c) {
    const std::string key = "confusion[" + std::to_string(c) + "]";
    const cv::FileNode row = node[static_cast<int>(c)];
    if (!row.isSeq() || row.size() != num_classes)
      file.Fail(key, "must list " + std::to_string(num_classes) + " probabilities");
    std::vector<double> probabilities;
    double total = 0;
    for (size_t a = 0; a < num_classes; ++a) {
      const cv::FileNode value = row[static_cast<int>(a)];
      const double p = static_cast<double>(value);
      if ((!value.isReal() && !value.isInt()) || !(p >= 0.0 && p <= 1.0))
        file.Fail(key, "entries must be probabilities in [0, 1]");
      probabilities.push_back(p);
      total += p;
    }
    if (std::abs(total - 1.0) > 1e-6)
      file.Fail(key, "must sum to 1, sums to " + std::to_string(total));
    matrix.push_back(std::move(probabilities));
  }
  return matrix;
}

namespace {

// YAML double-quoted scalar ("green box", with \" and \\ escaped).
std::string QuotedYaml(const std::string& text) {
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') quoted += '\\';
    quoted += c;
  }
  return quoted + "\"";
}

// A YAML flow sequence of numbers, each in the shortest text that reads back
// as the same double ("[0.6, 12.5, 3]").
template <typename Range>
std::string NumberList(const Range& values) {
  std::string list = "[";
  for (const auto& value : values) list += (list.size() > 1 ? ", " : "") + Number(value);
  return list + "]";
}

}  // namespace

void WriteClasses(const std::vector<ObjectClass>& classes, const std::string& path,
                  const std::optional<ConfusionMatrix>& confusion) {
  std::ostringstream out;
  out << "%YAML:1.0\n---\n";  // cv::FileStorage needs the directive
  out << "classes:\n";
  for (const ObjectClass& c : classes) {
    out << "  - name: " << QuotedYaml(c.name) << "\n";
    out << "    display_rgb: " << NumberList(c.display_rgb) << "\n";
    if (c.shape != ObjectShape::kCylinder) out << "    shape: " << ObjectShapeName(c.shape) << "\n";
    out << "    diameter_mean_m: " << Number(c.diameter_mean_m) << "\n";
    out << "    diameter_std_m: " << Number(c.diameter_std_m) << "\n";
    out << "    height_mean_m: " << Number(c.height_mean_m) << "\n";
    out << "    height_std_m: " << Number(c.height_std_m) << "\n";
    if (c.footprint_aspect != 1.0)
      out << "    footprint_aspect: " << Number(c.footprint_aspect) << "\n";
    if (c.base_height_m != 0.0) out << "    base_height_m: " << Number(c.base_height_m) << "\n";
    if (!c.supported)
      out << "    base_height_std_m: none\n";
    else if (c.base_height_std_m != 0.03)
      out << "    base_height_std_m: " << Number(c.base_height_std_m) << "\n";
    if (c.colour) {
      out << "    colour:\n";
      out << "      yuv_mean: " << NumberList(c.colour->yuv_mean) << "\n";
      out << "      yuv_std: " << NumberList(c.colour->yuv_std) << "\n";
      out << "      k_sigma: " << Number(c.colour->k_sigma) << "\n";
      if (c.colour->blob_chroma) {
        out << "      blob_chroma_mean: " << NumberList(c.colour->blob_chroma->mean) << "\n";
        out << "      blob_chroma_std: " << NumberList(c.colour->blob_chroma->std) << "\n";
      }
    }
    if (c.image_shape) {
      out << "    image_shape:\n";
      out << "      elongation_mean: " << Number(c.image_shape->elongation_mean) << "\n";
      out << "      elongation_std: " << Number(c.image_shape->elongation_std) << "\n";
      if (c.image_shape->arc_error_px > 0)
        out << "      arc_error_px: " << Number(c.image_shape->arc_error_px) << "\n";
    }
  }
  if (confusion) {
    out << "confusion:\n";
    for (const std::vector<double>& row : *confusion) out << "  - " << NumberList(row) << "\n";
  }
  WriteTextFileAtomically(path, out.str());
}

int FindClass(const std::vector<ObjectClass>& classes, const std::string& name) {
  for (size_t i = 0; i < classes.size(); ++i)
    if (classes[i].name == name) return static_cast<int>(i);
  return -1;
}

// ---------------------------------------------------------------- odometry

namespace {

constexpr double kCoordinate = bounds::kCoordinateM, kAngle = bounds::kAngleRad;

void CheckFrameColumn(const CsvTable& table) {
  if (static_cast<long>(table.num_rows()) > bounds::kFrames)
    throw Error::InFile(table.path(), "more than " + std::to_string(bounds::kFrames) +
                                          " rows (docs/formats.md, Bounds)");
  const int frame_column = table.ColumnIndex("frame");
  for (size_t row = 0; row < table.num_rows(); ++row) {
    const long frame = table.Integer(row, frame_column);
    if (frame != static_cast<long>(row)) {
      throw Error::AtLine(table.path(), table.line_of_row(row),
                          "expected frame " + std::to_string(row) + ", found " +
                              std::to_string(frame) + " (rows must be frames 0,1,2,... in order)");
    }
  }
}

}  // namespace

Odometry ReadOdometry(const std::string& path, long expected_rows) {
  const CsvTable table = CsvTable::Read(path);
  if (table.HasColumn("stamp_s") && !table.HasColumn("frame"))
    throw Error::InFile(path,
                        "is odometry by time (stamp_s, no frame column): 'oslam run' matches it "
                        "to the frames (its OUT/run/ then has one row per frame)");
  if (table.num_rows() == 0) throw Error::InFile(path, "no odometry rows");
  CheckFrameColumn(table);
  if (expected_rows >= 0 && static_cast<long>(table.num_rows()) != expected_rows) {
    throw Error::InFile(path, "has " + std::to_string(table.num_rows()) + " rows but the run has " +
                                  std::to_string(expected_rows) + " frames");
  }
  Odometry odometry;
  if (table.HasColumn("x_m")) {
    odometry.kind = OdometryKind::kPoses;
    const int x = table.ColumnIndex("x_m"), y = table.ColumnIndex("y_m"),
              theta = table.ColumnIndex("theta_rad");
    for (size_t row = 0; row < table.num_rows(); ++row) {
      odometry.poses.push_back({table.Double(row, x, -kCoordinate, kCoordinate, "m"),
                                table.Double(row, y, -kCoordinate, kCoordinate, "m"),
                                WrapAngle(table.Double(row, theta, -kAngle, kAngle, "rad"))});
      odometry.increments.push_back(
          row == 0 ? OdometryIncrement{}
                   : IncrementBetween(odometry.poses[row - 1], odometry.poses[row]));
    }
  } else if (table.HasColumn("distance_m")) {
    odometry.kind = OdometryKind::kIncrements;
    const int distance = table.ColumnIndex("distance_m"), turn = table.ColumnIndex("turn_rad");
    Pose2 pose;
    for (size_t row = 0; row < table.num_rows(); ++row) {
      OdometryIncrement increment{table.Double(row, distance, -kCoordinate, kCoordinate, "m"),
                                  table.Double(row, turn, -kAngle, kAngle, "rad")};
      if (row == 0) increment = {};  // nothing happens before the first frame
      pose = ApplyIncrement(pose, increment);
      // Each increment is bounded, their sum need not be.
      if (!(std::abs(pose.x) <= kCoordinate && std::abs(pose.y) <= kCoordinate))
        throw Error::AtLine(path, table.line_of_row(row),
                            bounds::ReachMessage(pose.x, pose.y, "frame " + std::to_string(row)));
      odometry.increments.push_back(increment);
      odometry.poses.push_back(pose);
    }
  } else {
    throw Error::InFile(path,
                        "needs columns x_m,y_m,theta_rad (poses) or distance_m,turn_rad "
                        "(increments)");
  }
  return odometry;
}

bool IsTimedOdometry(const std::string& path) {
  const CsvTable table = CsvTable::Read(path);
  return table.HasColumn("stamp_s") && !table.HasColumn("frame");
}

TimedOdometry ReadTimedOdometry(const std::string& path) {
  const CsvTable table = CsvTable::Read(path);
  if (table.HasColumn("frame") || !table.HasColumn("stamp_s"))
    throw Error::InFile(path, "odometry by time needs a stamp_s column and no frame column");
  if (table.num_rows() < 2) throw Error::InFile(path, "odometry by time needs at least two rows");
  const int stamp = table.ColumnIndex("stamp_s");
  const bool poses = table.HasColumn("x_m");
  if (!poses && !table.HasColumn("distance_m"))
    throw Error::InFile(path,
                        "needs columns x_m,y_m,theta_rad (poses) or distance_m,turn_rad "
                        "(increments)");
  const int a = table.ColumnIndex(poses ? "x_m" : "distance_m");
  const int b = table.ColumnIndex(poses ? "y_m" : "turn_rad");
  const int c = poses ? table.ColumnIndex("theta_rad") : -1;
  TimedOdometry odometry;
  Pose2 pose;
  for (size_t row = 0; row < table.num_rows(); ++row) {
    const double t = table.Double(row, stamp);
    if (!std::isfinite(t) || (!odometry.stamps_s.empty() && !(t > odometry.stamps_s.back())))
      throw Error::AtLine(path, table.line_of_row(row),
                          "stamp_s must be finite and increase from row to row");
    if (poses) {
      pose = {table.Double(row, a, -kCoordinate, kCoordinate, "m"),
              table.Double(row, b, -kCoordinate, kCoordinate, "m"),
              WrapAngle(table.Double(row, c, -kAngle, kAngle, "rad"))};
    } else if (row > 0) {
      pose = ApplyIncrement(pose, {table.Double(row, a, -kCoordinate, kCoordinate, "m"),
                                   table.Double(row, b, -kAngle, kAngle, "rad")});
      if (!(std::abs(pose.x) <= kCoordinate && std::abs(pose.y) <= kCoordinate))
        throw Error::AtLine(path, table.line_of_row(row),
                            bounds::ReachMessage(pose.x, pose.y, "row " + std::to_string(row)));
    }
    odometry.stamps_s.push_back(t);
    odometry.poses.push_back(pose);
  }
  return odometry;
}

void WriteOdometryPoses(const std::vector<Pose2>& poses, const std::string& path) {
  std::ostringstream out;
  out << "frame,x_m,y_m,theta_rad\n";
  for (size_t i = 0; i < poses.size(); ++i)
    out << i << ',' << CsvNumber(poses[i].x) << ',' << CsvNumber(poses[i].y) << ','
        << CsvNumber(poses[i].theta) << '\n';
  WriteTextFileAtomically(path, out.str());
}

// ---------------------------------------------------------------- frames

namespace {

bool HasExtension(const fs::path& path, std::initializer_list<const char*> extensions) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), ::tolower);
  for (const char* known : extensions)
    if (extension == known) return true;
  return false;
}

bool IsImageFile(const fs::path& path) {
  return HasExtension(path, {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"});
}

// Frames decoded ahead of the one asked for and kept for the threads that
// ask for them next; and how far ahead a read may be before the decoder
// seeks instead of decoding the frames in between.
constexpr size_t kDecodedAheadFrames = 64;
constexpr size_t kMaxDecodeAhead = 256;

struct FrameCache {
  std::mutex mutex;
  size_t limit_bytes = 0, used_bytes = 0;
  std::map<std::string, cv::Mat> frames;
};

FrameCache& TheFrameCache() {
  static FrameCache cache;
  return cache;
}

// RUN/frame_times.csv: frame,stamp_s with one row per frame, times increasing.
std::vector<double> ReadFrameTimes(const std::string& path, size_t frames) {
  const CsvTable table = CsvTable::Read(path);
  CheckFrameColumn(table);
  if (table.num_rows() != frames)
    throw Error::InFile(path, "has " + std::to_string(table.num_rows()) + " rows but the run has " +
                                  std::to_string(frames) + " frames");
  const int stamp = table.ColumnIndex("stamp_s");
  std::vector<double> times;
  for (size_t row = 0; row < table.num_rows(); ++row) {
    const double t = table.Double(row, stamp);
    if (!std::isfinite(t) || (!times.empty() && !(t > times.back())))
      throw Error::AtLine(path, table.line_of_row(row),
                          "stamp_s must be finite and increase from row to row");
    times.push_back(t);
  }
  return times;
}

}  // namespace

struct FrameSource::Decoder {
  std::mutex mutex;
  cv::VideoCapture capture;
  size_t next = 0;                    // the frame capture.read() returns next
  std::map<size_t, cv::Mat> decoded;  // decoded ahead, not yet read
};

void SetFrameCacheLimit(size_t bytes) {
  FrameCache& cache = TheFrameCache();
  const std::lock_guard<std::mutex> lock(cache.mutex);
  cache.limit_bytes = bytes;
  if (cache.used_bytes > bytes) {
    cache.frames.clear();
    cache.used_bytes = 0;
  }
}

FrameSource::FrameSource(const std::string& run_or_video) {
  const RunFolderPaths paths = RunFolderPaths::Of(run_or_video);
  if (!paths.video.empty()) {
    video_path_ = paths.video;
  } else {
    const std::string& run_dir = paths.dir;
    if (!fs::is_directory(run_dir))
      throw Error::InFile(run_dir, "run folder (or video file) not found");
    const fs::path frames_dir = fs::path(run_dir) / "frames";
    if (fs::is_directory(frames_dir)) {
      for (const auto& entry : fs::directory_iterator(frames_dir))
        if (entry.is_regular_file() && IsImageFile(entry.path()))
          image_paths_.push_back(entry.path().string());
      std::sort(image_paths_.begin(), image_paths_.end());
      if (static_cast<long>(image_paths_.size()) > bounds::kFrames)
        throw Error::InFile(frames_dir.string(), "more than " + std::to_string(bounds::kFrames) +
                                                     " frames (docs/formats.md, Bounds)");
      if (image_paths_.empty())
        throw Error::InFile(frames_dir.string(), "no image files (png, jpg, bmp, tif)");
      count_ = image_paths_.size();
    } else {
      for (const auto& entry : fs::directory_iterator(run_dir))
        if (entry.is_regular_file() && entry.path().stem() == "video")
          video_path_ = entry.path().string();
      if (video_path_.empty())
        throw Error::InFile(run_dir, "no frames/ folder and no video.* file");
    }
  }
  double frame_rate = 0;
  if (!video_path_.empty()) {
    decoder_ = std::make_unique<Decoder>();
    // FFmpeg only (docs/formats.md, Video): with any backend allowed, OpenCV
    // hands a file FFmpeg refused on to its camera backends, and gphoto2's
    // probes every USB camera driver for a second, then unloads them.
    if (!decoder_->capture.open(video_path_, cv::CAP_FFMPEG))
      throw Error::InFile(video_path_, "OpenCV cannot open this video");
    const double frames = decoder_->capture.get(cv::CAP_PROP_FRAME_COUNT);
    if (!(frames > 0)) throw Error::InFile(video_path_, "video has no frames");
    if (frames > bounds::kFrames)
      throw Error::InFile(
          video_path_,
          "declares " + bounds::OutsideMessage(frames, 1, bounds::kFrames) + " frames");
    const double width = decoder_->capture.get(cv::CAP_PROP_FRAME_WIDTH),
                 height = decoder_->capture.get(cv::CAP_PROP_FRAME_HEIGHT);
    if (!(width <= bounds::kImageSidePx && height <= bounds::kImageSidePx &&
          width * height <= bounds::kImagePixels))
      throw Error::InFile(video_path_,
                          "declares frames of " + std::to_string(width) + "x" +
                              std::to_string(height) +
                              " pixels, beyond the image bounds (docs/formats.md, Bounds)");
    count_ = static_cast<size_t>(frames);
    frame_rate = decoder_->capture.get(cv::CAP_PROP_FPS);
  }
  const std::string times_path = (fs::path(paths.dir) / "frame_times.csv").string();
  if (fs::exists(times_path)) {
    times_ = ReadFrameTimes(times_path, count_);
    times_source_ = "frame_times.csv";
  } else if (std::isfinite(frame_rate) && frame_rate > 0) {
    for (size_t i = 0; i < count_; ++i) times_.push_back(static_cast<double>(i) / frame_rate);
    times_source_ = "video frame rate";
  }
}

FrameSource::~FrameSource() = default;

cv::Mat FrameSource::Decode(size_t index) const {
  Decoder& decoder = *decoder_;
  const std::lock_guard<std::mutex> lock(decoder.mutex);
  const auto ahead = decoder.decoded.find(index);
  if (ahead != decoder.decoded.end()) {
    cv::Mat frame = ahead->second;
    decoder.decoded.erase(ahead);
    return frame;
  }
  if (index < decoder.next || index > decoder.next + kMaxDecodeAhead) {
    if (!decoder.capture.set(cv::CAP_PROP_POS_FRAMES, static_cast<double>(index)))
      throw Error::InFile(video_path_, "cannot seek to frame " + std::to_string(index));
    decoder.next = index;
    decoder.decoded.clear();
  }
  cv::Mat frame;
  for (; decoder.next <= index; ++decoder.next) {
    cv::Mat decoded;
    if (!decoder.capture.read(decoded) || decoded.empty())
      throw Error::InFile(video_path_, "cannot decode frame " + std::to_string(decoder.next));
    if (decoder.next == index) {
      frame = decoded;
    } else {
      decoder.decoded.emplace(decoder.next, decoded);
      if (decoder.decoded.size() > kDecodedAheadFrames)
        decoder.decoded.erase(decoder.decoded.begin());
    }
  }
  return frame;
}

cv::Mat FrameSource::Read(size_t index) const {
  if (index >= count_) throw Error("frame index " + std::to_string(index) + " out of range");
  const std::string key =
      video_path_.empty() ? image_paths_[index] : video_path_ + "#" + std::to_string(index);
  FrameCache& cache = TheFrameCache();
  {
    const std::lock_guard<std::mutex> lock(cache.mutex);
    const auto it = cache.frames.find(key);
    if (it != cache.frames.end()) return it->second;
  }
  const cv::Mat image = video_path_.empty() ? ReadImage(key) : Decode(index);
  const size_t bytes = image.total() * image.elemSize();
  const std::lock_guard<std::mutex> lock(cache.mutex);
  if (cache.used_bytes + bytes <= cache.limit_bytes && cache.frames.emplace(key, image).second)
    cache.used_bytes += bytes;
  return image;
}

std::string FrameSource::Name(size_t index) const {
  return video_path_.empty() ? image_paths_.at(index) : video_path_;
}

// ---------------------------------------------------------------- ground truth

namespace {

std::vector<Pose2> ReadTrajectory(const std::string& path) {
  const CsvTable table = CsvTable::Read(path);
  CheckFrameColumn(table);
  const int x = table.ColumnIndex("x_m"), y = table.ColumnIndex("y_m"),
            theta = table.ColumnIndex("theta_rad");
  std::vector<Pose2> poses;
  for (size_t row = 0; row < table.num_rows(); ++row)
    poses.push_back({table.Double(row, x, -kCoordinate, kCoordinate, "m"),
                     table.Double(row, y, -kCoordinate, kCoordinate, "m"),
                     table.Double(row, theta, -kAngle, kAngle, "rad")});
  return poses;
}

std::vector<GroundTruthObject> ReadObjects(const std::string& path) {
  const CsvTable table = CsvTable::Read(path);
  const int id = table.ColumnIndex("id"), cls = table.ColumnIndex("class"),
            shape = table.ColumnIndex("shape"), x = table.ColumnIndex("x_m"),
            y = table.ColumnIndex("y_m"), z = table.ColumnIndex("z_m"),
            diameter = table.ColumnIndex("diameter_m"), height = table.ColumnIndex("height_m"),
            length = table.ColumnIndex("length_m"), width = table.ColumnIndex("width_m"),
            yaw = table.ColumnIndex("yaw_rad");
  std::vector<GroundTruthObject> objects;
  for (size_t row = 0; row < table.num_rows(); ++row) {
    GroundTruthObject object;
    object.id = static_cast<int>(table.Integer(row, id, -bounds::kId, bounds::kId));
    object.class_name = table.Text(row, cls);
    object.shape = table.Text(row, shape);
    object.base_world = {table.Double(row, x, -kCoordinate, kCoordinate, "m"),
                         table.Double(row, y, -kCoordinate, kCoordinate, "m"),
                         table.Double(row, z, -kCoordinate, kCoordinate, "m")};
    const double kSize = bounds::kObjectSizeM;
    object.diameter_m = table.Double(row, diameter, 0, kSize, "m");
    object.height_m = table.Double(row, height, 0, kSize, "m");
    object.length_m = table.Double(row, length, 0, kSize, "m");
    object.width_m = table.Double(row, width, 0, kSize, "m");
    object.yaw_rad = table.Double(row, yaw, -kAngle, kAngle, "rad");
    objects.push_back(object);
  }
  return objects;
}

std::vector<GroundTruthSighting> ReadSightings(const std::string& path) {
  const CsvTable table = CsvTable::Read(path);
  const int frame = table.ColumnIndex("frame"), object = table.ColumnIndex("object_id"),
            visible = table.ColumnIndex("visible_fraction");
  std::vector<GroundTruthSighting> sightings;
  for (size_t row = 0; row < table.num_rows(); ++row) {
    const BoundingSlice slice = SliceAtRow(table, row);
    sightings.push_back({table.Integer(row, frame, 0, bounds::kFrames - 1),
                         static_cast<int>(table.Integer(row, object, -bounds::kId, bounds::kId)),
                         slice.u_r_px, slice.u_phi_rad, slice.s_r_px, slice.s_phi_rad,
                         table.Double(row, visible, 0, 1)});
  }
  return sightings;
}

}  // namespace

std::optional<GroundTruth> ReadGroundTruth(const std::string& run_dir) {
  const fs::path dir = RunFolderPaths::Of(run_dir).ground_truth;
  if (!fs::is_directory(dir)) return std::nullopt;
  GroundTruth truth;
  truth.trajectory = ReadTrajectory((dir / "trajectory.csv").string());
  truth.objects = ReadObjects((dir / "objects.csv").string());
  truth.sightings = ReadSightings((dir / "sightings.csv").string());
  std::set<int> ids;
  for (const GroundTruthObject& object : truth.objects) ids.insert(object.id);
  for (const GroundTruthSighting& sighting : truth.sightings) {
    if (ids.count(sighting.object_id) == 0)
      throw Error::InFile((dir / "sightings.csv").string(),
                          "object_id " + std::to_string(sighting.object_id) + " not in " +
                              (dir / "objects.csv").string());
  }
  return truth;
}

void WriteGroundTruth(const GroundTruth& truth, const std::string& run_dir) {
  const fs::path dir = fs::path(run_dir) / "ground_truth";
  WriteOdometryPoses(truth.trajectory, (dir / "trajectory.csv").string());

  std::ostringstream objects;
  objects << "id,class,shape,x_m,y_m,z_m,diameter_m,height_m,length_m,width_m,yaw_rad\n";
  for (const GroundTruthObject& o : truth.objects) {
    objects << o.id << ',' << o.class_name << ',' << o.shape << ',' << CsvNumber(o.base_world.x())
            << ',' << CsvNumber(o.base_world.y()) << ',' << CsvNumber(o.base_world.z()) << ','
            << CsvNumber(o.diameter_m) << ',' << CsvNumber(o.height_m) << ','
            << CsvNumber(o.length_m) << ',' << CsvNumber(o.width_m) << ',' << CsvNumber(o.yaw_rad)
            << '\n';
  }
  WriteTextFileAtomically((dir / "objects.csv").string(), objects.str());

  std::ostringstream sightings;
  sightings << "frame,object_id,u_r_px,u_phi_rad,s_r_px,s_phi_rad,visible_fraction\n";
  for (const GroundTruthSighting& s : truth.sightings) {
    sightings << s.frame << ',' << s.object_id << ',' << CsvNumber(s.u_r_px) << ','
              << CsvNumber(s.u_phi_rad) << ',' << CsvNumber(s.s_r_px) << ','
              << CsvNumber(s.s_phi_rad) << ',' << CsvNumber(s.visible_fraction) << '\n';
  }
  WriteTextFileAtomically((dir / "sightings.csv").string(), sightings.str());
}

BoundingSlice SliceAtRow(const CsvTable& table, size_t row) {
  const double radius = bounds::kImageRadiusPx;
  return {table.Double(row, table.ColumnIndex("u_r_px"), 0, radius, "px"),
          table.Double(row, table.ColumnIndex("u_phi_rad"), -kAngle, kAngle, "rad"),
          table.Double(row, table.ColumnIndex("s_r_px"), 0, radius, "px"),
          table.Double(row, table.ColumnIndex("s_phi_rad"), 0, 2 * kPi, "rad")};
}

RunFolderPaths RunFolderPaths::Of(const std::string& run_or_video) {
  std::string run_dir = run_or_video, video;
  if (fs::is_regular_file(run_or_video)) {
    video = run_or_video;
    run_dir = fs::path(run_or_video).parent_path().string();
    if (run_dir.empty()) run_dir = ".";
  }
  const fs::path dir(run_dir);
  return {run_dir,
          (dir / "camera.yaml").string(),
          (dir / "classes.yaml").string(),
          (dir / "odometry.csv").string(),
          (dir / "ground_truth").string(),
          (dir / "detections.csv").string(),
          video,
          (dir / "mask.png").string()};
}

}  // namespace oslam

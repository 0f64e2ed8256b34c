#include "detect/blob_detector.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/bounds.h"
#include "core/csv.h"
#include "core/error.h"

namespace oslam {

bool BlobDetectorOptions::Validate(std::string* why) const {
  if (min_area_px < 1) {
    if (why) *why = "min_area_px must be at least 1";
    return false;
  }
  if (opening_radius_px < 0 || opening_radius_px > 10) {
    if (why) *why = "opening_radius_px must be in 0..10";
    return false;
  }
  if (!(max_shape_distance > 0)) {
    if (why) *why = "max_shape_distance must be positive (inf = off)";
    return false;
  }
  if (!(look_alike_coverage > 0 && look_alike_coverage <= 1)) {
    if (why) *why = "look_alike_coverage must be in (0, 1]";
    return false;
  }
  if (!(max_blob_colour_distance > 0)) {
    if (why) *why = "max_blob_colour_distance must be positive (inf = off)";
    return false;
  }
  if (!(max_view_distance > 0)) {
    if (why) *why = "max_view_distance must be positive (inf = off)";
    return false;
  }
  if (!(fragment_gap_px >= 0) || std::isinf(fragment_gap_px)) {
    if (why) *why = "fragment_gap_px must be >= 0";
    return false;
  }
  return colour.Validate(why) && view_checks.Validate(why);
}

BlobDetector::BlobDetector(const CameraModel& camera, const std::vector<ObjectClass>& classes,
                           const BlobDetectorOptions& options, const cv::Mat& static_mask)
    : classes_(classes),
      options_(options),
      camera_(camera.Clone()),
      classifier_(classes, options.colour) {
  std::string why;
  if (!options.Validate(&why)) throw Error("blob detector: " + why);
  const int width = camera.image_width(), height = camera.image_height();
  mask_.create(height, width, CV_8UC1);
  radius_px_.create(height, width, CV_32FC1);
  angle_rad_.create(height, width, CV_32FC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector2d pixel(x, y);
      const PolarPoint polar = camera.PixelToPolar(pixel);
      radius_px_.at<float>(y, x) = static_cast<float>(polar.radius_px);
      angle_rad_.at<float>(y, x) = static_cast<float>(polar.angle_rad);
      mask_.at<uint8_t>(y, x) = (!options.annulus_only || camera.IsInAnnulus(pixel)) ? 255 : 0;
    }
  }
  if (!static_mask.empty()) {
    if (static_mask.size() != mask_.size() || static_mask.type() != CV_8UC1)
      throw Error("blob detector: the static mask is not an 8-bit image of the camera's size");
    mask_.setTo(0, static_mask == 0);
  }
}

std::vector<Detection> BlobDetector::Detect(const cv::Mat& bgr, long frame) const {
  if (bgr.size() != mask_.size() || bgr.type() != CV_8UC3) {
    throw Error("frame " + std::to_string(frame) + " is " + std::to_string(bgr.cols) + "x" +
                std::to_string(bgr.rows) + ", but the camera expects " +
                std::to_string(mask_.cols) + "x" + std::to_string(mask_.rows) + " colour images");
  }
  cv::Mat yuv, class_bits;
  cv::cvtColor(bgr, yuv, cv::COLOR_BGR2YUV);
  std::vector<ColourClassifier::ClassExtent> extents;
  classifier_.Classify(yuv, mask_, &class_bits, &extents);

  std::vector<Detection> detections;
  const int radius = options_.opening_radius_px;
  const cv::Mat kernel =
      cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
  for (int c = 0; c < classifier_.num_classes(); ++c) {
    if (extents[c].count < options_.min_area_px) continue;
    // Work on the class's bounding box only (plus a margin for the opening).
    const cv::Rect roi =
        (extents[c].box + cv::Size(2 * radius, 2 * radius) - cv::Point(radius, radius)) &
        cv::Rect(0, 0, bgr.cols, bgr.rows);
    cv::Mat class_mask = (class_bits(roi) & cv::Scalar(static_cast<int>(1u << c))) != 0;
    if (radius > 0) cv::morphologyEx(class_mask, class_mask, cv::MORPH_OPEN, kernel);
    cv::Mat labels, stats, centroids;
    const int num_labels =
        cv::connectedComponentsWithStats(class_mask, labels, stats, centroids, 8, CV_32S);
    for (int label = 1; label < num_labels; ++label) {
      if (stats.at<int>(label, cv::CC_STAT_AREA) < options_.min_area_px) continue;
      const cv::Rect box(
          stats.at<int>(label, cv::CC_STAT_LEFT), stats.at<int>(label, cv::CC_STAT_TOP),
          stats.at<int>(label, cv::CC_STAT_WIDTH), stats.at<int>(label, cv::CC_STAT_HEIGHT));
      detections.push_back(DescribeBlob(labels, label, box, roi.tl(), yuv, class_bits, c, frame));
    }
  }
  if (std::isfinite(options_.max_blob_colour_distance)) {
    const double max2 = TwoDofSquaredDistanceOfSigmas(options_.max_blob_colour_distance);
    detections.erase(std::remove_if(detections.begin(), detections.end(),
                                    [&](const Detection& d) {
                                      const ColourBox& box = *classes_[d.class_index].colour;
                                      return box.blob_chroma &&
                                             BlobChromaSquaredDistance(box, d.mean_yuv) > max2;
                                    }),
                     detections.end());
  }
  if (options_.separate_look_alikes) SeparateLookAlikes(&detections);
  if (std::isfinite(options_.max_view_distance)) VerifyViews(&detections);
  if (std::isfinite(options_.max_shape_distance)) {
    const double max_squared = options_.max_shape_distance * options_.max_shape_distance;
    detections.erase(std::remove_if(detections.begin(), detections.end(),
                                    [&](const Detection& d) {
                                      const auto& shape = classes_[d.class_index].image_shape;
                                      return shape &&
                                             ShapeSquaredDistance(*shape, d.slice) > max_squared;
                                    }),
                     detections.end());
  }
  return detections;
}

double TwoDofSquaredDistanceOfSigmas(double sigmas) {
  if (std::isinf(sigmas)) return sigmas;
  return -2.0 * std::log(std::erfc(sigmas / std::sqrt(2.0)));
}

double ShapeSquaredDistance(const ImageShapeModel& model, const BoundingSlice& slice,
                            double radial_std_px, double arc_std_px) {
  const double elongation = SliceElongation(slice);
  const double arc_width_px = SliceArcWidth(slice);
  const double quantisation = elongation * std::hypot(radial_std_px / std::max(1.0, slice.s_r_px),
                                                      arc_std_px / std::max(1.0, arc_width_px));
  const double variance = model.elongation_std * model.elongation_std + quantisation * quantisation;
  const double error = elongation - model.elongation_mean;
  return error * error / variance;
}

double ViewSquaredDistance(const CameraModel& camera, const ObjectClass& object_class,
                           const BoundingSlice& slice, const ViewCheckOptions& options) {
  const bool cut = CutsOf(camera.annulus(), slice, options).any();
  double distance2 = SupportedSizeSquaredDistance(camera, object_class, slice, 0.0, options);
  if (!object_class.image_shape) return distance2;
  // A cut shortens the radial extent, and the elongation grows with it at a
  // fixed inner (rim cut) or outer (blind-disc cut) end: a cut slice's
  // elongation is a lower bound, evidence only when already above the mean
  // (as for a cut height, SupportedSizeSquaredDistance).
  if (!cut || SliceElongation(slice) > object_class.image_shape->elongation_mean)
    distance2 += ShapeSquaredDistance(*object_class.image_shape, slice, options.pixel_std_px,
                                      ArcStdPx(object_class, options));
  return distance2;
}

namespace {

// The smallest slice holding both: radial extents joined, and the shorter
// of the two arcs that span both angular extents.
BoundingSlice UnionSlice(const BoundingSlice& a, const BoundingSlice& b) {
  const double r_min = std::min(a.u_r_px, b.u_r_px);
  const double r_max = std::max(a.u_r_px + a.s_r_px, b.u_r_px + b.s_r_px);
  const double offset = WrapAngle(b.u_phi_rad - a.u_phi_rad);  // b's middle from a's
  const double begin = std::min(-0.5 * a.s_phi_rad, offset - 0.5 * b.s_phi_rad);
  const double end = std::max(0.5 * a.s_phi_rad, offset + 0.5 * b.s_phi_rad);
  return SliceFromExtents(r_min, r_max, a.u_phi_rad + begin, a.u_phi_rad + end);
}

// The gap in pixels between two slices: radially, and as arc length at the
// middle radius of the two; negative where they overlap.
bool WithinGap(const BoundingSlice& a, const BoundingSlice& b, double gap_px) {
  const double radial_gap =
      std::max(a.u_r_px, b.u_r_px) - std::min(a.u_r_px + a.s_r_px, b.u_r_px + b.s_r_px);
  const double middle = 0.5 * (a.u_r_px + 0.5 * a.s_r_px + b.u_r_px + 0.5 * b.s_r_px);
  const double angular_gap =
      std::abs(WrapAngle(a.u_phi_rad - b.u_phi_rad)) - 0.5 * (a.s_phi_rad + b.s_phi_rad);
  return radial_gap <= gap_px && angular_gap * middle <= gap_px;
}

}  // namespace

void BlobDetector::VerifyViews(std::vector<Detection>* detections) const {
  const double max2 = options_.max_view_distance * options_.max_view_distance;
  std::vector<Detection> kept;
  kept.reserve(detections->size());
  for (Detection& d : *detections) {
    d.view_distance2 =
        ViewSquaredDistance(*camera_, classes_[d.class_index], d.slice, options_.view_checks);
    if (d.view_distance2 <= max2) kept.push_back(d);
  }
  // Groups of same-class blobs within the gap of each other (transitively).
  const size_t n = kept.size();
  std::vector<size_t> root(n);
  for (size_t i = 0; i < n; ++i) root[i] = i;
  auto find = [&](size_t i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      if (kept[i].class_index == kept[j].class_index &&
          WithinGap(kept[i].slice, kept[j].slice, options_.fragment_gap_px))
        root[find(j)] = find(i);
  std::vector<BoundingSlice> group_slice(n);
  std::vector<double> worst_member(n, 0.0);
  std::vector<double> best_member(n, std::numeric_limits<double>::infinity());
  std::vector<int> members(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const size_t g = find(i);
    group_slice[g] = members[g] == 0 ? kept[i].slice : UnionSlice(group_slice[g], kept[i].slice);
    worst_member[g] = std::max(worst_member[g], kept[i].view_distance2);
    best_member[g] = std::min(best_member[g], kept[i].view_distance2);
    ++members[g];
  }
  enum class Verdict : char { kKeepEach, kDropAll, kJoin };
  std::vector<Verdict> verdict(n, Verdict::kKeepEach);
  std::vector<double> together(n, 0.0);
  for (size_t g = 0; g < n; ++g) {
    if (members[g] < 2) continue;
    together[g] = ViewSquaredDistance(*camera_, classes_[kept[g].class_index], group_slice[g],
                                      options_.view_checks);
    if (options_.drop_fragments && together[g] > max2 && together[g] > worst_member[g])
      verdict[g] = Verdict::kDropAll;
    else if (options_.join_fragments && together[g] <= max2 && together[g] < best_member[g])
      verdict[g] = Verdict::kJoin;
  }
  detections->clear();
  std::vector<int> joined_at(n, -1);  // a joined group's index in *detections
  for (size_t i = 0; i < n; ++i) {
    const size_t g = find(i);
    if (verdict[g] == Verdict::kDropAll) continue;
    if (verdict[g] == Verdict::kKeepEach) {
      detections->push_back(kept[i]);
    } else if (joined_at[g] < 0) {
      joined_at[g] = static_cast<int>(detections->size());
      detections->push_back(kept[i]);
    } else {
      JoinInto(&(*detections)[joined_at[g]], kept[i]);
    }
  }
  for (size_t g = 0; g < n; ++g) {
    if (joined_at[g] < 0) continue;
    Detection& joined = (*detections)[joined_at[g]];
    joined.slice = group_slice[g];
    joined.view_distance2 = together[g];
    joined.score = std::exp(
        -0.5 * classifier_.SquaredDistance(*classes_[joined.class_index].colour, joined.mean_yuv));
  }
}

void BlobDetector::JoinInto(Detection* joined, const Detection& piece) {
  const double total = joined->area_px + piece.area_px;
  for (int ch = 0; ch < 3; ++ch)
    joined->mean_yuv[ch] =
        (joined->mean_yuv[ch] * joined->area_px + piece.mean_yuv[ch] * piece.area_px) / total;
  joined->area_px += piece.area_px;
  joined->look_alike_classes |= piece.look_alike_classes;
}

void BlobDetector::SeparateLookAlikes(std::vector<Detection>* detections) const {
  std::vector<double> misfit(detections->size(), 0.0);
  for (size_t i = 0; i < detections->size(); ++i) {
    const Detection& d = (*detections)[i];
    const ObjectClass& object_class = classes_[d.class_index];
    if (!object_class.image_shape) continue;
    misfit[i] = -2.0 * std::log(std::max(d.score, 1e-300)) +
                ShapeSquaredDistance(*object_class.image_shape, d.slice);
  }
  std::vector<Detection> kept;
  kept.reserve(detections->size());
  for (size_t i = 0; i < detections->size(); ++i) {
    const Detection& d = (*detections)[i];
    bool explained_better = false;
    for (size_t j = 0; j < detections->size() && !explained_better; ++j) {
      const Detection& other = (*detections)[j];
      explained_better =
          other.class_index != d.class_index && classes_[d.class_index].image_shape &&
          classes_[other.class_index].image_shape &&
          ((d.look_alike_classes >> other.class_index) & 1u) && misfit[j] < misfit[i] &&
          SliceCoverage(d.slice, other.slice) >= options_.look_alike_coverage;
    }
    if (!explained_better) kept.push_back(d);
  }
  *detections = std::move(kept);
}

Detection BlobDetector::DescribeBlob(const cv::Mat& labels, int label, const cv::Rect& box,
                                     const cv::Point& offset, const cv::Mat& yuv,
                                     const cv::Mat& class_bits, int class_index, long frame) const {
  std::vector<double> radii, angles;
  std::array<double, 3> sum{};
  std::array<int, ColourClassifier::kMaxClasses> shared_pixels{};
  const uint32_t own_bit = 1u << class_index;
  for (int y = box.y; y < box.y + box.height; ++y) {
    const int* row = labels.ptr<int>(y);
    const float* radius_row = radius_px_.ptr<float>(y + offset.y);
    const float* angle_row = angle_rad_.ptr<float>(y + offset.y);
    const cv::Vec3b* colour_row = yuv.ptr<cv::Vec3b>(y + offset.y);
    const uint32_t* bits_row = class_bits.ptr<uint32_t>(y + offset.y);
    for (int x = box.x; x < box.x + box.width; ++x) {
      if (row[x] != label) continue;
      radii.push_back(radius_row[x + offset.x]);
      angles.push_back(angle_row[x + offset.x]);
      const cv::Vec3b& colour = colour_row[x + offset.x];
      for (int ch = 0; ch < 3; ++ch) sum[ch] += colour[ch];
      for (uint32_t others = bits_row[x + offset.x] & ~own_bit; others != 0; others &= others - 1)
        ++shared_pixels[__builtin_ctz(others)];
    }
  }
  Detection detection;
  detection.frame = frame;
  detection.class_index = class_index;
  detection.class_name = classes_[class_index].name;
  detection.area_px = static_cast<int>(radii.size());
  for (int c = 0; c < ColourClassifier::kMaxClasses; ++c)
    if (2 * shared_pixels[c] >= detection.area_px) detection.look_alike_classes |= 1u << c;
  detection.slice = SliceOfPixelCentres(radii, angles);
  for (int ch = 0; ch < 3; ++ch) detection.mean_yuv[ch] = sum[ch] / detection.area_px;
  detection.score = std::exp(
      -0.5 * classifier_.SquaredDistance(*classes_[class_index].colour, detection.mean_yuv));
  return detection;
}

void WriteDetections(const std::vector<Detection>& detections, const std::string& path) {
  std::ostringstream out;
  out << "frame,class,u_r_px,u_phi_rad,s_r_px,s_phi_rad,area_px,mean_y,mean_u,mean_v,score\n";
  for (const Detection& d : detections) {
    out << d.frame << ',' << d.class_name << ',' << CsvNumber(d.slice.u_r_px) << ','
        << CsvNumber(d.slice.u_phi_rad) << ',' << CsvNumber(d.slice.s_r_px) << ','
        << CsvNumber(d.slice.s_phi_rad) << ',' << d.area_px << ',' << CsvNumber(d.mean_yuv[0])
        << ',' << CsvNumber(d.mean_yuv[1]) << ',' << CsvNumber(d.mean_yuv[2]) << ','
        << CsvNumber(d.score) << '\n';
  }
  WriteTextFileAtomically(path, out.str());
}

std::vector<Detection> ReadDetections(const std::string& path,
                                      const std::vector<ObjectClass>& classes) {
  const CsvTable table = CsvTable::Read(path);
  const int frame = table.ColumnIndex("frame"), cls = table.ColumnIndex("class");
  for (const char* column : {"u_r_px", "u_phi_rad", "s_r_px", "s_phi_rad"})
    table.ColumnIndex(column);  // a missing column is an error even without rows
  std::vector<Detection> detections;
  for (size_t row = 0; row < table.num_rows(); ++row) {
    Detection d;
    d.frame = table.Integer(row, frame, 0, bounds::kFrames - 1);
    d.class_name = table.Text(row, cls);
    d.class_index = FindClass(classes, d.class_name);
    if (d.class_index < 0)
      throw Error::AtLine(path, table.line_of_row(row), "unknown class '" + d.class_name + "'");
    d.slice = SliceAtRow(table, row);
    if (table.HasColumn("area_px"))
      d.area_px = static_cast<int>(
          table.Integer(row, table.ColumnIndex("area_px"), 0, bounds::kImagePixels));
    if (table.HasColumn("score")) d.score = table.Double(row, table.ColumnIndex("score"), 0, 1);
    detections.push_back(d);
  }
  return detections;
}

std::vector<cv::Point> SliceOutline(const CameraModel& camera, const BoundingSlice& slice) {
  const int steps = std::max(2, static_cast<int>(std::ceil(slice.s_phi_rad / 0.02)));
  const double begin = slice.u_phi_rad - 0.5 * slice.s_phi_rad;
  std::vector<cv::Point> outline;
  auto add = [&](double radius, double angle) {
    const Eigen::Vector2d p = camera.PolarToPixel({radius, angle});
    outline.emplace_back(cvRound(p.x()), cvRound(p.y()));
  };
  for (int i = 0; i <= steps; ++i) add(slice.u_r_px, begin + slice.s_phi_rad * i / steps);
  for (int i = steps; i >= 0; --i)
    add(slice.u_r_px + slice.s_r_px, begin + slice.s_phi_rad * i / steps);
  return outline;
}

void DrawSlice(cv::Mat* image, const CameraModel& camera, const BoundingSlice& slice,
               const cv::Scalar& colour, int thickness) {
  cv::polylines(*image, SliceOutline(camera, slice), true, colour, thickness, cv::LINE_AA);
}

}  // namespace oslam

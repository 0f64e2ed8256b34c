#include "detect/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include "calib/observation_model.h"
#include "core/angles.h"
#include "core/csv.h"
#include "core/statistics.h"

namespace oslam {
namespace {

struct SightingInfo {
  const GroundTruthSighting* sighting;
  int class_index;  // -1 for objects of no class
  bool counts_for_recall;
};

// Overlap of two intervals, each given by its start and length.
double Overlap(double begin_a, double length_a, double begin_b, double length_b) {
  return std::min(begin_a + length_a, begin_b + length_b) - std::max(begin_a, begin_b);
}

// The detection's slice and the true slice overlap, radially and angularly
// (with `slack_px` of tolerance). The base points themselves may differ: a box
// close to the robot shows its near edge well inside the base centre's radius.
// Angular (as arc length at the sighting's radius) and radial overlap, px.
std::pair<double, double> SliceOverlap(const Detection& d, const GroundTruthSighting& s) {
  const double radius = std::max(1.0, s.u_r_px);
  const double angle_offset = WrapAngle(d.slice.u_phi_rad - s.u_phi_rad);
  const double angular = Overlap(-0.5 * s.s_phi_rad, s.s_phi_rad,
                                 angle_offset - 0.5 * d.slice.s_phi_rad, d.slice.s_phi_rad);
  const double radial = Overlap(s.u_r_px, s.s_r_px, d.slice.u_r_px, d.slice.s_r_px);
  return {angular * radius, radial};
}

bool Matches(const Detection& d, const GroundTruthSighting& s, double slack_px) {
  const auto [angular, radial] = SliceOverlap(d, s);
  return angular > -slack_px && radial > -slack_px;
}

// Overlap area of the two slices in the polar image (0 when they only touch
// within the slack): which of several objects a confused detection is on.
double OverlapArea(const Detection& d, const GroundTruthSighting& s) {
  const auto [angular, radial] = SliceOverlap(d, s);
  return std::max(0.0, angular) * std::max(0.0, radial);
}

}  // namespace

DetectionEvaluation EvaluateDetections(const std::vector<Detection>& detections,
                                       const GroundTruth& truth,
                                       const std::vector<ObjectClass>& classes,
                                       const DetectionEvaluationOptions& options) {
  DetectionEvaluation result;
  result.per_class.resize(classes.size());
  for (size_t c = 0; c < classes.size(); ++c) result.per_class[c].class_name = classes[c].name;
  result.total.class_name = "all";
  result.confusion_counts.assign(classes.size(), std::vector<int>(classes.size(), 0));

  std::map<int, const GroundTruthObject*> objects;
  for (const GroundTruthObject& o : truth.objects) objects[o.id] = &o;
  std::map<long, std::vector<SightingInfo>> sightings_by_frame;
  for (const GroundTruthSighting& s : truth.sightings) {
    const GroundTruthObject& object = *objects.at(s.object_id);
    const int class_index = object.class_name.empty() ? -1 : FindClass(classes, object.class_name);
    bool counts = false;
    if (class_index >= 0 && s.frame < static_cast<long>(truth.trajectory.size())) {
      const Pose2& pose = truth.trajectory[s.frame];
      const double range =
          std::hypot(object.base_world.x() - pose.x, object.base_world.y() - pose.y);
      counts = s.visible_fraction >= options.min_visible_fraction && range <= options.max_range_m;
    }
    sightings_by_frame[s.frame].push_back({&s, class_index, counts});
  }

  std::map<long, std::vector<const Detection*>> detections_by_frame;
  for (const Detection& d : detections) {
    detections_by_frame[d.frame].push_back(&d);
    ClassDetectionStats& stats = result.per_class[d.class_index];
    ++stats.detections;
    const auto& frame_sightings = sightings_by_frame[d.frame];
    bool same = false, other = false;
    int other_class = -1;
    double other_overlap = -1.0;
    for (const SightingInfo& info : frame_sightings) {
      if (info.class_index < 0 || !Matches(d, *info.sighting, options.slack_px)) continue;
      (info.class_index == d.class_index ? same : other) = true;
      const double overlap = OverlapArea(d, *info.sighting);
      if (info.class_index != d.class_index && overlap > other_overlap) {
        other_class = info.class_index;
        other_overlap = overlap;
      }
    }
    if (same) {
      ++stats.true_positives;
      ++result.confusion_counts[d.class_index][d.class_index];
    } else if (other) {
      ++stats.confused;
      ++result.confusion_counts[other_class][d.class_index];
    } else {
      ++stats.spurious;
    }
  }

  std::vector<double> u_r, u_phi, s_r, s_phi, position;
  for (const auto& [frame, infos] : sightings_by_frame) {
    for (const SightingInfo& info : infos) {
      if (!info.counts_for_recall) continue;
      ClassDetectionStats& stats = result.per_class[info.class_index];
      ++stats.sightings;
      const Detection* best = nullptr;
      for (const Detection* d : detections_by_frame[frame])
        if (d->class_index == info.class_index && Matches(*d, *info.sighting, options.slack_px) &&
            (!best || d->area_px > best->area_px))
          best = d;
      if (!best) continue;
      ++stats.sightings_found;
      const GroundTruthSighting& s = *info.sighting;
      const double dphi = WrapAngle(best->slice.u_phi_rad - s.u_phi_rad);
      u_r.push_back(std::abs(best->slice.u_r_px - s.u_r_px));
      u_phi.push_back(std::abs(dphi) * s.u_r_px);
      s_r.push_back(std::abs(best->slice.s_r_px - s.s_r_px));
      s_phi.push_back(std::abs(best->slice.s_phi_rad - s.s_phi_rad) * s.u_r_px);
      // Distance between the two base points in the image (law of cosines).
      const double a = best->slice.u_r_px, b = s.u_r_px;
      position.push_back(std::sqrt(std::max(0.0, a * a + b * b - 2 * a * b * std::cos(dphi))));
    }
  }
  for (const ClassDetectionStats& stats : result.per_class) {
    result.total.sightings += stats.sightings;
    result.total.sightings_found += stats.sightings_found;
    result.total.detections += stats.detections;
    result.total.true_positives += stats.true_positives;
    result.total.confused += stats.confused;
    result.total.spurious += stats.spurious;
  }
  result.median_u_r_error_px = UpperMedian(u_r);
  result.median_u_phi_error_px = UpperMedian(u_phi);
  result.median_s_r_error_px = UpperMedian(s_r);
  result.median_s_phi_error_px = UpperMedian(s_phi);
  result.median_position_error_px = UpperMedian(position);
  return result;
}

std::vector<VisibleSlice> ReadVisibleSlices(const std::string& run_dir) {
  const std::string path =
      (std::filesystem::path(run_dir) / "ground_truth" / "visible_slices.csv").string();
  std::vector<VisibleSlice> rows;
  if (!std::filesystem::exists(path)) return rows;
  const CsvTable table = CsvTable::Read(path);
  const int frame = table.ColumnIndex("frame"), object = table.ColumnIndex("object_id"),
            visible = table.ColumnIndex("visible_px"),
            footprint = table.ColumnIndex("footprint_px");
  for (size_t row = 0; row < table.num_rows(); ++row)
    rows.push_back({table.Integer(row, frame, 0, 1L << 40),
                    static_cast<int>(table.Integer(row, object, 0, 1L << 30)),
                    table.Integer(row, visible, 0, 1L << 40),
                    table.Integer(row, footprint, 0, 1L << 40), SliceAtRow(table, row)});
  return rows;
}

namespace {

// Running sums of signed errors for SignedSliceErrors.
struct ErrorSums {
  int count = 0;
  std::array<double, 4> sum{}, sum2{};
  void Add(const BoundingSlice& a, const BoundingSlice& b, double radius) {
    const std::array<double, 4> e = {a.u_r_px - b.u_r_px,
                                     WrapAngle(a.u_phi_rad - b.u_phi_rad) * radius,
                                     a.s_r_px - b.s_r_px, (a.s_phi_rad - b.s_phi_rad) * radius};
    ++count;
    for (int k = 0; k < 4; ++k) sum[k] += e[k], sum2[k] += e[k] * e[k];
  }
  SignedSliceErrors Result() const {
    SignedSliceErrors r;
    r.count = count;
    for (int k = 0; k < 4 && count > 0; ++k) {
      r.mean[k] = sum[k] / count;
      r.std[k] = std::sqrt(std::max(0.0, sum2[k] / count - r.mean[k] * r.mean[k]));
    }
    return r;
  }
};

ObjectShape ShapeOfTruth(const GroundTruthObject& object) {
  return ParseObjectShape(object.shape).value_or(ObjectShape::kCylinder);
}

}  // namespace

std::vector<ClassSliceErrors> SignedSliceErrorsPerClass(const std::vector<Detection>& detections,
                                                        const GroundTruth& truth,
                                                        const std::vector<VisibleSlice>& visible,
                                                        const std::vector<ObjectClass>& classes,
                                                        const CameraModel& camera,
                                                        const DetectionEvaluationOptions& options) {
  std::map<int, const GroundTruthObject*> objects;
  for (const GroundTruthObject& o : truth.objects) objects[o.id] = &o;
  std::map<long, std::vector<const Detection*>> detections_by_frame;
  for (const Detection& d : detections) detections_by_frame[d.frame].push_back(&d);
  std::vector<ErrorSums> detector(classes.size()), section(classes.size()),
      silhouette(classes.size());
  for (const VisibleSlice& view : visible) {
    const auto found = objects.find(view.object_id);
    if (found == objects.end() || found->second->class_name.empty()) continue;
    const GroundTruthObject& object = *found->second;
    const int class_index = FindClass(classes, object.class_name);
    if (class_index < 0 || view.frame >= static_cast<long>(truth.trajectory.size())) continue;
    if (view.visible_px < options.min_visible_fraction * view.footprint_px) continue;
    const Pose2& pose = truth.trajectory[view.frame];
    if (std::hypot(object.base_world.x() - pose.x, object.base_world.y() - pose.y) >
        options.max_range_m)
      continue;
    const CylinderGeometry geometry{object.base_world, object.diameter_m, object.height_m};
    BoundingSlice thesis, shaped;
    const double aspect =
        object.length_m > 0 && object.width_m > 0
            ? std::min(object.length_m, object.width_m) / std::max(object.length_m, object.width_m)
            : 1.0;
    if (!PredictSlice(camera, pose, geometry, &thesis) ||
        !PredictSlice(camera, pose, geometry, &shaped, nullptr,
                      SilhouetteOf(camera, ShapeOfTruth(object), aspect)))
      continue;
    const double radius = std::max(1.0, view.slice.u_r_px);
    section[class_index].Add(view.slice, thesis, radius);
    silhouette[class_index].Add(view.slice, shaped, radius);
    // The largest detection of the class overlapping the visible slice.
    GroundTruthSighting as_sighting;
    as_sighting.u_r_px = view.slice.u_r_px;
    as_sighting.u_phi_rad = view.slice.u_phi_rad;
    as_sighting.s_r_px = view.slice.s_r_px;
    as_sighting.s_phi_rad = view.slice.s_phi_rad;
    const Detection* best = nullptr;
    for (const Detection* d : detections_by_frame[view.frame])
      if (d->class_index == class_index && Matches(*d, as_sighting, options.slack_px) &&
          (!best || d->area_px > best->area_px))
        best = d;
    if (best) detector[class_index].Add(best->slice, view.slice, radius);
  }
  std::vector<ClassSliceErrors> result(classes.size());
  for (size_t c = 0; c < classes.size(); ++c)
    result[c] = {classes[c].name, detector[c].Result(), section[c].Result(),
                 silhouette[c].Result()};
  return result;
}

std::string SignedSliceErrorsTable(const std::vector<ClassSliceErrors>& errors) {
  std::ostringstream out;
  char line[240];
  out << "signed slice errors, px, mean (std) of u_r, u_phi, s_r, s_phi:\n";
  auto row = [&](const char* name, const char* what, const SignedSliceErrors& e) {
    std::snprintf(line, sizeof(line),
                  "%-16s %-10s %5d  %+6.2f (%5.2f) %+6.2f (%5.2f) %+6.2f (%5.2f) %+6.2f (%5.2f)\n",
                  name, what, e.count, e.mean[0], e.std[0], e.mean[1], e.std[1], e.mean[2],
                  e.std[2], e.mean[3], e.std[3]);
    out << line;
  };
  for (const ClassSliceErrors& c : errors) {
    row(c.class_name.c_str(), "detector", c.detector);
    row("", "section", c.section);
    row("", "silhouette", c.silhouette);
  }
  return out.str();
}

std::string SignedSliceErrorsJson(const std::vector<ClassSliceErrors>& errors) {
  std::ostringstream out;
  auto block = [&](const char* name, const SignedSliceErrors& e) {
    out << "\"" << name << "\": {\"count\": " << e.count << ", \"mean_px\": [" << e.mean[0] << ", "
        << e.mean[1] << ", " << e.mean[2] << ", " << e.mean[3] << "], \"std_px\": [" << e.std[0]
        << ", " << e.std[1] << ", " << e.std[2] << ", " << e.std[3] << "]}";
  };
  out << "[";
  for (size_t i = 0; i < errors.size(); ++i) {
    out << (i ? ",\n    " : "\n    ") << "{\"class\": \"" << errors[i].class_name << "\", ";
    block("detector", errors[i].detector);
    out << ", ";
    block("section", errors[i].section);
    out << ", ";
    block("silhouette", errors[i].silhouette);
    out << "}";
  }
  out << "\n  ]";
  return out.str();
}

std::vector<std::vector<double>> ConfusionFromCounts(const std::vector<std::vector<int>>& counts,
                                                     double floor) {
  const size_t n = counts.size();
  std::vector<std::vector<double>> confusion(n, std::vector<double>(n, 0.0));
  for (size_t c = 0; c < n; ++c) {
    double total = 0;
    for (int count : counts[c]) total += count;
    double floored_total = 0;
    for (size_t a = 0; a < n; ++a) {
      const double p = total > 0 ? counts[c][a] / total : (a == c ? 1.0 : 0.0);
      confusion[c][a] = std::max(p, floor);
      floored_total += confusion[c][a];
    }
    for (double& p : confusion[c]) p /= floored_total;
  }
  return confusion;
}

std::string DetectionEvaluation::Table() const {
  std::ostringstream out;
  char line[200];
  std::snprintf(line, sizeof(line), "%-16s %9s %7s %10s %9s %8s %8s %8s\n", "class", "sightings",
                "recall", "detections", "precision", "correct", "confused", "spurious");
  out << line;
  auto row = [&](const ClassDetectionStats& s) {
    std::snprintf(line, sizeof(line), "%-16s %9d %7.3f %10d %9.3f %8d %8d %8d\n",
                  s.class_name.c_str(), s.sightings, s.Recall(), s.detections, s.Precision(),
                  s.true_positives, s.confused, s.spurious);
    out << line;
  };
  for (const ClassDetectionStats& s : per_class) row(s);
  row(total);
  std::snprintf(
      line, sizeof(line),
      "median |error| px: base position %.2f (u_r %.2f, u_phi %.2f), s_r %.2f, s_phi %.2f\n",
      median_position_error_px, median_u_r_error_px, median_u_phi_error_px, median_s_r_error_px,
      median_s_phi_error_px);
  out << line;
  return out.str();
}

std::string DetectionEvaluation::Json() const {
  std::ostringstream out;
  auto stats = [&](const ClassDetectionStats& s) {
    out << "{\"class\": \"" << s.class_name << "\", \"sightings\": " << s.sightings
        << ", \"recall\": " << s.Recall() << ", \"detections\": " << s.detections
        << ", \"precision\": " << s.Precision() << ", \"correct\": " << s.true_positives
        << ", \"confused\": " << s.confused << ", \"spurious\": " << s.spurious << "}";
  };
  out << "{\n  \"per_class\": [";
  for (size_t i = 0; i < per_class.size(); ++i) {
    out << (i ? ",\n    " : "\n    ");
    stats(per_class[i]);
  }
  out << "\n  ],\n  \"total\": ";
  stats(total);
  out << ",\n  \"median_position_error_px\": " << median_position_error_px
      << ",\n  \"median_u_r_error_px\": " << median_u_r_error_px
      << ",\n  \"median_u_phi_error_px\": " << median_u_phi_error_px
      << ",\n  \"median_s_r_error_px\": " << median_s_r_error_px
      << ",\n  \"median_s_phi_error_px\": " << median_s_phi_error_px << "\n}\n";
  return out.str();
}

}  // namespace oslam

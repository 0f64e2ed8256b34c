#include "slam/slam_omap.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "core/angles.h"

namespace oslam {
namespace {

using Json = nlohmann::ordered_json;

// JSON has no NaN or infinity, so they become null.
Json Number(double value) {
  return std::isfinite(value) ? Json(value) : Json(nullptr);
}

// A solver message is not checked for UTF-8: replace bad bytes rather than fail.
std::string Text(const Json& json) {
  return json.dump(-1, ' ', false, Json::error_handler_t::replace);
}

OMapReport SolverReport(const SolverSummary& s, const KeyframeStartSummary* start) {
  Json report = {{"termination", TerminationName(s.termination)},
                 {"message", s.message},
                 {"iterations", s.iterations},
                 {"successful_steps", s.successful_steps},
                 {"initial_cost", Number(s.initial_cost)},
                 {"final_cost", Number(s.final_cost)},
                 {"num_factors", s.num_factors},
                 {"num_residuals", s.num_residuals},
                 {"num_parameters", s.num_parameters}};
  if (start && start->used)
    report["keyframe_start"] = {{"keyframes", start->num_keyframes},
                                {"stage_solves", start->stage_solves},
                                {"closures", start->closures},
                                {"stage_iterations", start->stage_iterations},
                                {"final_iterations", start->final_iterations}};
  return {"solver", Text(report)};
}

// The solver's run times (OMap::timing).
OMapReport SolverTiming(const SolverSummary& s, const KeyframeStartSummary* start) {
  Json timing = {{"total_time_s", Number(s.total_time_s)}};
  if (start && start->used) timing["keyframe_start"] = {{"time_s", Number(start->time_s)}};
  return {"solver", Text(timing)};
}

OMapReport EvidenceReport(const Evidence& e) {
  const Json report = {{"valid", e.valid},
                       {"log_evidence", e.valid ? Number(e.log_evidence) : Json(nullptr)},
                       {"squared_residual", Number(e.squared_residual)},
                       {"log_det_information", Number(e.log_det_information)},
                       {"log_det_noise", Number(e.log_det_noise)},
                       {"normaliser", Number(e.normaliser)},
                       {"num_rows", e.num_rows},
                       {"num_parameters", e.num_parameters}};
  return {"evidence", Text(report)};
}

}  // namespace

OMap ToOMap(const GeometricSlamResult& result, const std::vector<std::string>& class_names,
            const OMapSource& source) {
  OMap map;
  for (const MappedObject& mapped : result.objects) {
    OMapObject object;
    object.id = mapped.id;
    if (mapped.class_index >= 0 && mapped.class_index < static_cast<int>(class_names.size()))
      object.class_name = class_names[mapped.class_index];
    object.base_world = mapped.geometry.base_world;
    object.diameter_m = mapped.geometry.diameter_m;
    object.height_m = mapped.geometry.height_m;
    if (mapped.oriented) object.yaw_rad = 0.5 * WrapAngle(2.0 * mapped.geometry.yaw_rad);
    object.existence_probability = 1.0;
    object.covariance = mapped.covariance;
    object.num_detections = mapped.num_observations;
    map.objects.push_back(object);
  }
  map.trajectory = result.trajectory;
  map.source = source;
  map.reports = {SolverReport(result.summary, &result.keyframe_start),
                 EvidenceReport(result.evidence)};
  map.timing = {SolverTiming(result.summary, &result.keyframe_start)};
  return map;
}

OMap ToOMap(const LandmarkSlamResult& result, const std::string& class_name,
            const OMapSource& source) {
  OMap map;
  for (const MappedLandmark& landmark : result.landmarks) {
    OMapObject object;
    object.id = landmark.id;
    object.class_name = class_name;
    object.base_world = {landmark.position_m.x(), landmark.position_m.y(), 0.0};
    object.diameter_m = std::isfinite(landmark.diameter_m) ? landmark.diameter_m : 0.0;
    object.height_m = 0.0;
    object.existence_probability = 1.0;
    // (x, y, d) -> rows/columns (0, 1, 3) of (x, y, z, d, h).
    const int index[3] = {0, 1, 3};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) object.covariance(index[r], index[c]) = landmark.covariance(r, c);
    object.num_detections = landmark.num_sightings;
    map.objects.push_back(object);
  }
  map.trajectory = result.trajectory;
  map.source = source;
  map.reports = {SolverReport(result.summary, nullptr), EvidenceReport(result.evidence)};
  map.timing = {SolverTiming(result.summary, nullptr)};
  return map;
}

}  // namespace oslam

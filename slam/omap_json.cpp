#include "slam/omap_json.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"

namespace oslam {

namespace {

using Json = nlohmann::ordered_json;

// JSON has no NaN/Inf, so they become null.
Json Number(double value) { return std::isfinite(value) ? Json(value) : Json(nullptr); }

Json ObjectJson(const MappedObject& object, const std::vector<std::string>& class_names) {
  const std::string name =
      object.class_index >= 0 && object.class_index < static_cast<int>(class_names.size())
          ? class_names[object.class_index]
          : std::string();
  const Eigen::Vector3d& base = object.geometry.base_world;
  Json covariance = Json::array();
  for (int r = 0; r < 5; ++r) {
    Json row = Json::array();
    for (int c = 0; c < 5; ++c) row.push_back(Number(object.covariance(r, c)));
    covariance.push_back(row);
  }
  return {{"id", object.id},
          {"class", name},
          {"base_point_m", {Number(base.x()), Number(base.y()), Number(base.z())}},
          {"diameter_m", Number(object.geometry.diameter_m)},
          {"height_m", Number(object.geometry.height_m)},
          {"existence_probability", 1.0},
          {"num_detections", object.num_observations},
          {"covariance", covariance}};
}

}  // namespace

std::string OMapToJson(const GeometricSlamResult& result,
                       const std::vector<std::string>& class_names, const OMapSource& source) {
  Json root;
  root["format"] = "oslam-omap";
  root["version"] = 1;
  root["source"] = {{"run", source.run_dir},
                    {"association", source.association},
                    {"pixel_noise_px", Number(source.pixel_noise_px)},
                    {"seed", source.seed}};
  root["objects"] = Json::array();
  for (const MappedObject& object : result.objects)
    root["objects"].push_back(ObjectJson(object, class_names));
  root["trajectory"] = Json::array();
  for (size_t i = 0; i < result.trajectory.size(); ++i) {
    const Pose2& pose = result.trajectory[i];
    root["trajectory"].push_back({{"frame", i},
                                  {"x_m", Number(pose.x)},
                                  {"y_m", Number(pose.y)},
                                  {"theta_rad", Number(pose.theta)}});
  }
  const SolverSummary& s = result.summary;
  root["solver"] = {{"termination", TerminationName(s.termination)},
                    {"message", s.message},
                    {"iterations", s.iterations},
                    {"successful_steps", s.successful_steps},
                    {"initial_cost", Number(s.initial_cost)},
                    {"final_cost", Number(s.final_cost)},
                    {"num_factors", s.num_factors},
                    {"num_residuals", s.num_residuals},
                    {"num_parameters", s.num_parameters},
                    {"total_time_s", Number(s.total_time_s)}};
  const KeyframeStartSummary& start = result.keyframe_start;
  if (start.used)
    root["solver"]["keyframe_start"] = {{"keyframes", start.num_keyframes},
                                        {"stage_solves", start.stage_solves},
                                        {"closures", start.closures},
                                        {"stage_iterations", start.stage_iterations},
                                        {"final_iterations", start.final_iterations},
                                        {"time_s", Number(start.time_s)}};
  const Evidence& e = result.evidence;
  root["evidence"] = {{"valid", e.valid},
                      {"log_evidence", e.valid ? Number(e.log_evidence) : Json(nullptr)},
                      {"squared_residual", Number(e.squared_residual)},
                      {"log_det_information", Number(e.log_det_information)},
                      {"log_det_noise", Number(e.log_det_noise)},
                      {"normaliser", Number(e.normaliser)},
                      {"num_rows", e.num_rows},
                      {"num_parameters", e.num_parameters}};
  return root.dump(2) + "\n";
}

void WriteOMap(const std::string& path, const GeometricSlamResult& result,
               const std::vector<std::string>& class_names, const OMapSource& source) {
  WriteTextFileAtomically(path, OMapToJson(result, class_names, source));
}

}  // namespace oslam

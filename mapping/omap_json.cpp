#include "mapping/omap_json.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/atomic_file.h"

namespace oslam {

namespace {

// Round-trip precision; JSON has no NaN/Inf, so they become null.
std::string Number(double value) {
  if (!std::isfinite(value)) return "null";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  return buffer;
}

std::string Quoted(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof(buffer), "\\u%04x", c);
          out += buffer;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

}  // namespace

std::string OMapToJson(const GeometricSlamResult& result,
                       const std::vector<std::string>& class_names, const OMapSource& source) {
  std::ostringstream out;
  out << "{\n  \"format\": \"oslam-omap\",\n  \"version\": 1,\n";
  out << "  \"source\": {\"run\": " << Quoted(source.run_dir)
      << ", \"association\": " << Quoted(source.association)
      << ", \"pixel_noise_px\": " << Number(source.pixel_noise_px) << ", \"seed\": " << source.seed
      << "},\n";
  out << "  \"objects\": [";
  for (size_t j = 0; j < result.objects.size(); ++j) {
    const MappedObject& object = result.objects[j];
    const std::string name =
        object.class_index >= 0 && object.class_index < static_cast<int>(class_names.size())
            ? class_names[object.class_index]
            : std::string();
    const Eigen::Vector3d& base = object.geometry.base_world;
    out << (j ? ",\n" : "\n") << "    {\"id\": " << object.id << ", \"class\": " << Quoted(name)
        << ", \"base_point_m\": [" << Number(base.x()) << ", " << Number(base.y()) << ", "
        << Number(base.z()) << "], \"diameter_m\": " << Number(object.geometry.diameter_m)
        << ", \"height_m\": " << Number(object.geometry.height_m)
        << ", \"existence_probability\": 1.0, \"num_detections\": " << object.num_observations
        << ",\n     \"covariance\": [";
    for (int r = 0; r < 5; ++r) {
      out << (r ? ", [" : "[");
      for (int c = 0; c < 5; ++c) out << (c ? ", " : "") << Number(object.covariance(r, c));
      out << "]";
    }
    out << "]}";
  }
  out << (result.objects.empty() ? "],\n" : "\n  ],\n");
  out << "  \"trajectory\": [";
  for (size_t i = 0; i < result.trajectory.size(); ++i) {
    const Pose2& pose = result.trajectory[i];
    out << (i ? ",\n" : "\n") << "    {\"frame\": " << i << ", \"x_m\": " << Number(pose.x)
        << ", \"y_m\": " << Number(pose.y) << ", \"theta_rad\": " << Number(pose.theta) << "}";
  }
  out << (result.trajectory.empty() ? "],\n" : "\n  ],\n");
  const SolverSummary& s = result.summary;
  out << "  \"solver\": {\"termination\": " << Quoted(TerminationName(s.termination))
      << ", \"message\": " << Quoted(s.message) << ", \"iterations\": " << s.iterations
      << ", \"successful_steps\": " << s.successful_steps
      << ", \"initial_cost\": " << Number(s.initial_cost)
      << ", \"final_cost\": " << Number(s.final_cost) << ", \"num_factors\": " << s.num_factors
      << ", \"num_residuals\": " << s.num_residuals << ", \"num_parameters\": " << s.num_parameters
      << ", \"total_time_s\": " << Number(s.total_time_s) << "},\n";
  const Evidence& e = result.evidence;
  out << "  \"evidence\": {\"valid\": " << (e.valid ? "true" : "false")
      << ", \"log_evidence\": " << Number(e.valid ? e.log_evidence : NAN)
      << ", \"squared_residual\": " << Number(e.squared_residual)
      << ", \"log_det_information\": " << Number(e.log_det_information)
      << ", \"log_det_noise\": " << Number(e.log_det_noise)
      << ", \"normaliser\": " << Number(e.normaliser) << ", \"num_rows\": " << e.num_rows
      << ", \"num_parameters\": " << e.num_parameters << "}\n}\n";
  return out.str();
}

void WriteOMap(const std::string& path, const GeometricSlamResult& result,
               const std::vector<std::string>& class_names, const OMapSource& source) {
  WriteTextFileAtomically(path, OMapToJson(result, class_names, source));
}

}  // namespace oslam

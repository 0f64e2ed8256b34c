#include "association/sampled_omap_json.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"

namespace oslam {
namespace {

using Json = nlohmann::json;

Json Number(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

Json MoveJson(const std::array<MoveStatistics, 3>& stats) {
  Json moves = Json::object();
  for (int m = 0; m < 3; ++m) {
    const MoveStatistics& s = stats[m];
    moves[MoveName(static_cast<MoveType>(m))] = {
        {"proposed", s.proposed},
        {"accepted", s.accepted},
        {"self_transitions", s.self_transitions},
        {"cache_hits", s.cache_hits},
        {"screened_out", s.screened_out},
        {"acceptance_rate", Number(s.proposed ? double(s.accepted) / s.proposed : NAN)},
        {"evaluation_time_s", s.time_s},
        {"solves", s.solves()},
        // per proposal other than a self-transition (screened, cached or solved)
        {"time_per_proposal_s", Number(s.evaluated() > 0 ? s.time_s / s.evaluated() : NAN)}};
  }
  return moves;
}

// The sample identities combined into the object (item 6a).
Json MembersJson(const FusedIdentity& identity) {
  Json members = Json::array();
  for (size_t m = 0; m < identity.members.size(); ++m)
    members.push_back(
        {{"tracks", identity.members[m]},
         {"num_samples",
          m < identity.member_samples.size() ? identity.member_samples[m] : identity.num_samples}});
  return members;
}

Json SummaryJson(const SamplerSummary& s) {
  Json trace = Json::array(), hill_trace = Json::array();
  for (double v : s.cold_trace) trace.push_back(Number(v));
  for (double v : s.hill_climb_trace) hill_trace.push_back(Number(v));
  long proposals = 0;
  for (const auto* phase : {&s.hill_climb, &s.sampling})
    for (const MoveStatistics& m : *phase) proposals += m.proposed;
  const double seconds = s.hill_climb_time_s + s.sampling_time_s;
  return {{"hill_climb_moves", MoveJson(s.hill_climb)},
          {"sampling_moves", MoveJson(s.sampling)},
          {"swaps_proposed", s.swaps_proposed},
          {"swaps_accepted", s.swaps_accepted},
          {"initial_log_target", Number(s.initial_log_target)},
          {"hill_climbed_log_target", Number(s.hill_climbed_log_target)},
          {"effective_sample_size", Number(s.effective_sample_size)},
          {"num_solves", s.num_solves},
          {"num_cache_hits", s.num_cache_hits},
          {"speculative_solves_undone", s.speculative_solves_undone},
          {"hill_climb_steps", s.hill_climb_steps},
          {"hill_climb_time_s", s.hill_climb_time_s},
          {"sampling_time_s", s.sampling_time_s},
          {"cold_chain_proposals_per_second", Number(seconds > 0 ? proposals / seconds : NAN)},
          {"hill_climb_log_target", hill_trace},
          {"cold_chain_log_target", trace}};
}

}  // namespace

std::string SampledOMapToJson(const FusionResult& fused, const SampledOMapSource& source,
                              const SamplerSummary* summary) {
  Json root = {{"format", "oslam-omap"}, {"version", 1}};
  root["source"] = {{"run", source.run_dir},
                    {"detections", source.detections},
                    {"association", source.association},
                    {"seed", source.seed}};
  Json objects = Json::array();
  for (size_t i = 0; i < fused.map.objects.size(); ++i) {
    const OMapObject& o = fused.map.objects[i];
    Json covariance = Json::array();
    for (int r = 0; r < 5; ++r) {
      Json row = Json::array();
      for (int c = 0; c < 5; ++c) row.push_back(Number(o.covariance(r, c)));
      covariance.push_back(row);
    }
    Json histogram = Json::object();
    for (const auto& [name, p] : o.class_histogram) histogram[name] = p;
    objects.push_back(
        {{"id", o.id},
         {"class", o.class_name},
         {"base_point_m",
          {Number(o.base_world.x()), Number(o.base_world.y()), Number(o.base_world.z())}},
         {"diameter_m", Number(o.diameter_m)},
         {"height_m", Number(o.height_m)},
         {"existence_probability", o.existence_probability},
         {"num_detections", o.num_detections},
         {"covariance", covariance},
         {"class_histogram", histogram},
         {"tracks", fused.identities[i].tracks},
         {"num_samples", fused.identities[i].num_samples},
         {"identities", MembersJson(fused.identities[i])}});
  }
  root["objects"] = objects;
  Json trajectory = Json::array();
  for (size_t i = 0; i < fused.map.trajectory.size(); ++i) {
    const Pose2& p = fused.map.trajectory[i];
    trajectory.push_back(
        {{"frame", i}, {"x_m", Number(p.x)}, {"y_m", Number(p.y)}, {"theta_rad", Number(p.theta)}});
  }
  root["trajectory"] = trajectory;
  if (summary) root["sampler"] = SummaryJson(*summary);
  return root.dump(1);
}

void WriteSampledOMap(const std::string& path, const FusionResult& fused,
                      const SampledOMapSource& source, const SamplerSummary* summary) {
  WriteTextFileAtomically(path, SampledOMapToJson(fused, source, summary));
}

}  // namespace oslam

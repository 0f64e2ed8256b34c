#include "association/sampled_omap.h"

#include <cmath>

#include <nlohmann/json.hpp>

namespace oslam {
namespace {

using Json = nlohmann::ordered_json;

// JSON has no NaN or infinity, so they become null.
Json Number(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

// Per move type: `timing` picks the run-time members (evaluation time, time
// per proposal) or all the others.
Json MoveJson(const std::array<MoveStatistics, kNumMoveTypes>& stats, bool timing) {
  Json moves = Json::object();
  for (int m = 0; m < kNumMoveTypes; ++m) {
    const MoveStatistics& s = stats[m];
    const std::string name = MoveName(static_cast<MoveType>(m));
    if (timing) {
      moves[name] = {
          {"evaluation_time_s", Number(s.time_s)},
          // per proposal other than a self-transition (screened, cached or solved)
          {"time_per_proposal_s", Number(s.evaluated() > 0 ? s.time_s / s.evaluated() : NAN)}};
      continue;
    }
    moves[name] = {{"proposed", s.proposed},
                   {"accepted", s.accepted},
                   {"self_transitions", s.self_transitions},
                   {"cache_hits", s.cache_hits},
                   {"screened_out", s.screened_out},
                   {"acceptance_rate", Number(s.proposed ? double(s.accepted) / s.proposed : NAN)},
                   {"solves", s.solves()}};
  }
  return moves;
}

OMapReport SamplerReport(const SamplerSummary& s) {
  Json trace = Json::array(), hill_trace = Json::array();
  for (double v : s.cold_trace) trace.push_back(Number(v));
  for (double v : s.hill_climb_trace) hill_trace.push_back(Number(v));
  const Json report = {{"hill_climb_moves", MoveJson(s.hill_climb, false)},
                       {"sampling_moves", MoveJson(s.sampling, false)},
                       {"swaps_proposed", s.swaps_proposed},
                       {"swaps_accepted", s.swaps_accepted},
                       {"initial_log_target", Number(s.initial_log_target)},
                       {"hill_climbed_log_target", Number(s.hill_climbed_log_target)},
                       {"effective_sample_size", Number(s.effective_sample_size)},
                       {"num_solves", s.num_solves},
                       {"num_cache_hits", s.num_cache_hits},
                       {"hill_climb_steps", s.hill_climb_steps},
                       {"sweeps", s.sweeps},
                       {"sweep_changes", s.sweep_changes},
                       {"track_scan_tracks", s.scan_tracks},
                       {"track_scan_updates", s.track_scan.proposed},
                       {"track_scan_moves", s.track_scan.accepted},
                       {"hill_climb_log_target", hill_trace},
                       {"cold_chain_log_target", trace}};
  return {"sampler", report.dump()};
}

// The sampler's run times, and the speculative solves its parallel chains
// undid (which depend on the thread scheduling).
OMapReport SamplerTiming(const SamplerSummary& s) {
  long proposals = 0;
  for (const auto* phase : {&s.hill_climb, &s.sampling})
    for (const MoveStatistics& m : *phase) proposals += m.proposed;
  const double seconds = s.hill_climb_time_s + s.sampling_time_s;
  const Json timing = {
      {"hill_climb_time_s", Number(s.hill_climb_time_s)},
      {"sampling_time_s", Number(s.sampling_time_s)},
      {"cold_chain_proposals_per_second", Number(seconds > 0 ? proposals / seconds : NAN)},
      {"speculative_solves_undone", s.speculative_solves_undone},
      {"hill_climb_moves", MoveJson(s.hill_climb, true)},
      {"sampling_moves", MoveJson(s.sampling, true)}};
  return {"sampler", timing.dump()};
}

}  // namespace

OMap ToOMap(const FusionResult& fused, const OMapSource& source, const SamplerSummary* summary) {
  OMap map = fused.map;
  for (size_t i = 0; i < map.objects.size() && i < fused.identities.size(); ++i) {
    const FusedIdentity& fused_identity = fused.identities[i];
    OMapObject& object = map.objects[i];
    object.identity = OMapIdentity{fused_identity.tracks, fused_identity.num_samples};
    object.identities.clear();
    for (size_t m = 0; m < fused_identity.members.size(); ++m)
      object.identities.push_back(
          {fused_identity.members[m], m < fused_identity.member_samples.size()
                                          ? fused_identity.member_samples[m]
                                          : fused_identity.num_samples});
  }
  map.source = source;
  map.reports.clear();
  map.timing.clear();
  if (summary) {
    map.reports.push_back(SamplerReport(*summary));
    map.timing.push_back(SamplerTiming(*summary));
  }
  return map;
}

}  // namespace oslam

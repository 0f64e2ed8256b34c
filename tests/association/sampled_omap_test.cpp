// O-SLAM's fused samples as an O-Map: the identities of every object and
// the sampler's report.
#include "association/sampled_omap.h"

#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace oslam {
namespace {

FusionResult Fused() {
  FusionResult fused;
  fused.map.trajectory = {{0, 0, 0}, {0.3, 0, 0}};
  OMapObject box;
  box.id = 0;
  box.class_name = "green box";
  box.existence_probability = 0.9;
  box.num_detections = 30;
  box.class_histogram = {{"green box", 0.8}, {"yellow box", 0.2}};
  OMapObject ball = box;
  ball.id = 1;
  ball.class_name = "pink ball";
  ball.existence_probability = 0.4;
  fused.map.objects = {box, ball};
  FusedIdentity merged;  // two sample identities combined
  merged.tracks = {0, 1, 3};
  merged.num_samples = 10;
  merged.members = {{0, 1}, {0, 3}};
  merged.member_samples = {7};  // the second member's count is missing: the identity's is used
  FusedIdentity single;
  single.tracks = {2};
  single.num_samples = 4;
  single.members = {{2}};
  single.member_samples = {4};
  fused.identities = {merged, single};
  return fused;
}

TEST(SampledOMap, ObjectsCarryTheirIdentities) {
  const OMapSource source{"runs/lab", "o-slam (MC3)", std::string("d.csv"), std::nullopt, 5};
  const OMap map = ToOMap(Fused(), source, nullptr);
  ASSERT_EQ(map.objects.size(), 2u);
  const OMapObject& box = map.objects[0];
  EXPECT_EQ(box.class_name, "green box");
  EXPECT_EQ(box.existence_probability, 0.9);
  EXPECT_EQ(box.class_histogram.size(), 2u);
  ASSERT_TRUE(box.identity);
  EXPECT_EQ(box.identity->tracks, (std::vector<int>{0, 1, 3}));
  EXPECT_EQ(box.identity->num_samples, 10);
  ASSERT_EQ(box.identities.size(), 2u);
  EXPECT_EQ(box.identities[0].tracks, (std::vector<int>{0, 1}));
  EXPECT_EQ(box.identities[0].num_samples, 7);
  EXPECT_EQ(box.identities[1].tracks, (std::vector<int>{0, 3}));
  EXPECT_EQ(box.identities[1].num_samples, 10);
  ASSERT_TRUE(map.objects[1].identity);
  EXPECT_EQ(map.objects[1].identity->tracks, (std::vector<int>{2}));
  EXPECT_EQ(map.objects[1].identities.size(), 1u);
  EXPECT_EQ(map.trajectory.size(), 2u);
  EXPECT_EQ(map.source->detections, std::optional<std::string>("d.csv"));
  EXPECT_EQ(map.source->association, "o-slam (MC3)");
  EXPECT_TRUE(map.reports.empty());  // the baseline has no sampler
}

TEST(SampledOMap, SamplerReport) {
  SamplerSummary summary;
  summary.hill_climb[0].proposed = 4;  // merge
  summary.hill_climb[0].accepted = 1;
  summary.hill_climb[0].self_transitions = 1;
  summary.hill_climb[0].cache_hits = 1;
  summary.hill_climb[0].time_s = 0.3;
  summary.swaps_proposed = 6;
  summary.swaps_accepted = 2;
  summary.hill_climb_steps = 2;
  summary.hill_climb_trace = {-10, -8};
  summary.cold_trace = {-8, NAN, -7.5};
  summary.initial_log_target = -10;
  summary.hill_climbed_log_target = -8;
  summary.effective_sample_size = 2.5;
  summary.num_solves = 3;
  summary.hill_climb_time_s = 0.5;
  summary.sampling_time_s = 1.5;
  const OMap map = ToOMap(Fused(), {}, &summary);
  ASSERT_EQ(map.reports.size(), 1u);
  EXPECT_EQ(map.reports[0].name, "sampler");
  const nlohmann::json report = nlohmann::json::parse(map.reports[0].json);
  const nlohmann::json& merge = report["hill_climb_moves"]["merge"];
  EXPECT_EQ(merge["proposed"], 4);
  EXPECT_EQ(merge["accepted"], 1);
  EXPECT_EQ(merge["solves"], 2);  // 4 - 1 self-transition - 1 cache hit
  EXPECT_EQ(merge["acceptance_rate"], 0.25);
  EXPECT_TRUE(report["sampling_moves"]["split"]["acceptance_rate"].is_null());  // none proposed
  EXPECT_EQ(report["swaps_accepted"], 2);
  EXPECT_EQ(report["hill_climb_steps"], 2);
  EXPECT_EQ(report["effective_sample_size"], 2.5);
  EXPECT_EQ(report["num_solves"], 3);
  EXPECT_EQ(report["hill_climb_log_target"], (nlohmann::json{-10.0, -8.0}));
  ASSERT_EQ(report["cold_chain_log_target"].size(), 3u);
  EXPECT_TRUE(report["cold_chain_log_target"][1].is_null());
  for (const char* key :
       {"initial_log_target", "hill_climbed_log_target", "num_cache_hits", "swaps_proposed"})
    EXPECT_TRUE(report.contains(key)) << key;
  // What depends on the machine is in the timing, not in the report.
  for (const char* key : {"speculative_solves_undone", "hill_climb_time_s", "sampling_time_s",
                          "cold_chain_proposals_per_second"})
    EXPECT_FALSE(report.contains(key)) << key;
  EXPECT_FALSE(merge.contains("time_per_proposal_s"));
  ASSERT_EQ(map.timing.size(), 1u);
  EXPECT_EQ(map.timing[0].name, "sampler");
  const nlohmann::json timing = nlohmann::json::parse(map.timing[0].json);
  EXPECT_EQ(timing["hill_climb_time_s"], 0.5);
  EXPECT_EQ(timing["sampling_time_s"], 1.5);
  EXPECT_EQ(timing["cold_chain_proposals_per_second"], 2.0);  // 4 proposals in 2 s
  EXPECT_TRUE(timing.contains("speculative_solves_undone"));
  // 0.3 s / 3 evaluated
  EXPECT_DOUBLE_EQ(timing["hill_climb_moves"]["merge"]["time_per_proposal_s"].get<double>(), 0.1);
}

}  // namespace
}  // namespace oslam

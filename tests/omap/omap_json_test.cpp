// The O-Map file: what WriteOMap writes ReadOMap reads back, field for
// field; hand-made files with only the required members read; malformed
// files give an error naming the file and the field.
#include "omap/omap_json.h"

#include <cmath>
#include <fstream>
#include <limits>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

const char* kMap = R"({
  "format": "oslam-omap", "version": 1,
  "objects": [
    {"id": 3, "class": "green box", "base_point_m": [1.5, -0.5, 0.0], "diameter_m": 0.68,
     "height_m": 0.57, "existence_probability": 0.8, "num_detections": 12,
     "covariance": [[0.01,0,0,0,0],[0,0.01,0,0,0],[0,0,0.001,0,0],[0,0,0,0.02,0],[0,0,0,0,0.02]],
     "class_histogram": {"orange door": 0.1, "green box": 0.9},
     "tracks": [0, 4], "num_samples": 90,
     "identities": [{"tracks": [0], "num_samples": 80}, {"tracks": [0, 4], "num_samples": 10}]}
  ],
  "trajectory": [{"frame": 0, "x_m": 0, "y_m": 0, "theta_rad": 0},
                 {"frame": 1, "x_m": 0.2, "y_m": 0.01, "theta_rad": 0.1}]
})";

std::string ErrorFor(const std::string& text) {
  testing::TempDir dir;
  std::ofstream(dir.Path("omap.json")) << text;
  try {
    ReadOMap(dir.Path("omap.json"));
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(dir.Path("omap.json") + ": ", 0), 0u) << message;
    return message.substr(dir.Path("omap.json").size() + 2);
  }
  return "(no error)";
}

// kMap with its first occurrence of `from` replaced by `to`.
std::string Edited(const std::string& from, const std::string& to) {
  std::string text = kMap;
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

OMap WrittenAndRead(const OMap& map) {
  testing::TempDir dir;
  WriteOMap(dir.Path("omap.json"), map);
  return ReadOMap(dir.Path("omap.json"));
}

// Every field set, with values that only survive an exact round trip.
OMap FullMap() {
  OMap map;
  OMapObject sampled;
  sampled.id = 7;
  sampled.class_name = "pink ball";
  sampled.base_world = {0.1 + 0.2, -1.0 / 3.0, 1e-300};
  sampled.diameter_m = 0.21;
  sampled.height_m = 0.19999999999999998;
  sampled.existence_probability = 0.875;
  for (int r = 0; r < 5; ++r)
    for (int c = 0; c < 5; ++c) sampled.covariance(r, c) = 1e-3 * (r + 1) + 1e-5 * c + 1e-17;
  sampled.num_detections = 41;
  sampled.class_histogram = {{"pink ball", 0.75}, {"orange door", 0.25}};
  sampled.identity = OMapIdentity{{2, 5, 9}, 120};
  sampled.identities = {{{2, 5}, 100}, {{9}, 30}};
  OMapObject known;  // as geometric SLAM makes them: no O-SLAM fields
  known.id = -2;
  known.class_name = "green box";
  known.base_world = {4, 5, 0};
  known.diameter_m = 0.68;
  known.height_m = 0.57;
  map.objects = {sampled, known};
  map.trajectory = {{0, 0, 0}, {0.2, 1e-9, -3.0}, {1.0 / 7.0, -2.5, 3.14159}};
  map.source = OMapSource{"runs/lab", "o-slam (MC3)", std::string("runs/lab/detections.csv"), 30.0,
                          18446744073709551615ul};
  map.reports = {{"sampler", R"({"swaps_proposed":12,"cold_chain_log_target":[-1.5,null,2]})"},
                 {"solver", R"({"termination":"converged","keyframe_start":{"keyframes":4}})"},
                 {"evidence", R"({"valid":false,"log_evidence":null})"}};
  return map;
}

void ExpectSameObject(const OMapObject& a, const OMapObject& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.class_name, b.class_name);
  EXPECT_EQ(a.base_world, b.base_world);  // exact: numbers are written to read back exactly
  EXPECT_EQ(a.diameter_m, b.diameter_m);
  EXPECT_EQ(a.height_m, b.height_m);
  EXPECT_EQ(a.existence_probability, b.existence_probability);
  EXPECT_EQ(a.covariance, b.covariance);
  EXPECT_EQ(a.num_detections, b.num_detections);
  EXPECT_EQ(a.class_histogram, b.class_histogram);
  ASSERT_EQ(a.identity.has_value(), b.identity.has_value());
  if (a.identity) {
    EXPECT_EQ(a.identity->tracks, b.identity->tracks);
    EXPECT_EQ(a.identity->num_samples, b.identity->num_samples);
  }
  ASSERT_EQ(a.identities.size(), b.identities.size());
  for (size_t i = 0; i < a.identities.size(); ++i) {
    EXPECT_EQ(a.identities[i].tracks, b.identities[i].tracks);
    EXPECT_EQ(a.identities[i].num_samples, b.identities[i].num_samples);
  }
}

TEST(OMapJson, RoundTripKeepsEveryField) {
  const OMap map = FullMap();
  const OMap read = WrittenAndRead(map);
  ASSERT_EQ(read.objects.size(), 2u);
  for (size_t i = 0; i < 2; ++i) ExpectSameObject(map.objects[i], read.objects[i]);
  ASSERT_EQ(read.trajectory.size(), map.trajectory.size());
  for (size_t i = 0; i < map.trajectory.size(); ++i) {
    EXPECT_EQ(read.trajectory[i].x, map.trajectory[i].x);
    EXPECT_EQ(read.trajectory[i].y, map.trajectory[i].y);
    EXPECT_EQ(read.trajectory[i].theta, map.trajectory[i].theta);
  }
  ASSERT_TRUE(read.source);
  EXPECT_EQ(read.source->run, "runs/lab");
  EXPECT_EQ(read.source->association, "o-slam (MC3)");
  EXPECT_EQ(read.source->detections, std::optional<std::string>("runs/lab/detections.csv"));
  EXPECT_EQ(read.source->pixel_noise_px, std::optional<double>(30.0));
  EXPECT_EQ(read.source->seed, 18446744073709551615ul);
  // The reports come back as they were given, in their order.
  ASSERT_EQ(read.reports.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(read.reports[i].name, map.reports[i].name);
    EXPECT_EQ(read.reports[i].json, map.reports[i].json);
  }
  // And the file written from what was read is the same file.
  EXPECT_EQ(OMapToJson(read), OMapToJson(map));
}

TEST(OMapJson, OptionalMembersAreLeftOutAndReadBackAbsent) {
  OMap map = FullMap();
  map.objects.resize(1);
  map.objects[0].class_histogram.clear();
  map.objects[0].identity.reset();
  map.objects[0].identities.clear();
  map.source->detections.reset();
  map.source->pixel_noise_px.reset();
  map.reports.clear();
  const nlohmann::json json = nlohmann::json::parse(OMapToJson(map));
  for (const char* key : {"class_histogram", "tracks", "num_samples", "identities"})
    EXPECT_FALSE(json["objects"][0].contains(key)) << key;
  EXPECT_FALSE(json["source"].contains("detections"));
  EXPECT_FALSE(json["source"].contains("pixel_noise_px"));
  EXPECT_EQ(json.size(), 5u);  // format, version, source, objects, trajectory
  const OMap read = WrittenAndRead(map);
  ExpectSameObject(map.objects[0], read.objects[0]);
  EXPECT_FALSE(read.source->detections);
  EXPECT_FALSE(read.source->pixel_noise_px);
  EXPECT_TRUE(read.reports.empty());

  map.source.reset();
  EXPECT_FALSE(nlohmann::json::parse(OMapToJson(map)).contains("source"));
  EXPECT_FALSE(WrittenAndRead(map).source);
}

TEST(OMapJson, ReportsAreTopLevelMembers) {
  const OMap map = FullMap();
  const nlohmann::json json = nlohmann::json::parse(OMapToJson(map));
  EXPECT_EQ(json["solver"]["keyframe_start"]["keyframes"], 4);
  EXPECT_TRUE(json["sampler"]["cold_chain_log_target"][1].is_null());
  EXPECT_EQ(json["format"], "oslam-omap");
  EXPECT_EQ(json["version"], 1);
  EXPECT_EQ(json["trajectory"][2]["frame"], 2);
  ASSERT_NE(FindReport(map, "solver"), nullptr);
  EXPECT_EQ(FindReport(map, "solver")->name, "solver");
  EXPECT_EQ(FindReport(map, "nothing"), nullptr);
}

TEST(OMapJson, BadReportsAreRefusedBeforeWriting) {
  testing::TempDir dir;
  for (const OMapReport& bad : {OMapReport{"objects", "{}"}, OMapReport{"", "{}"},
                                OMapReport{"solver", "{}"},  // taken by the map's own
                                OMapReport{"sampler", "{not json"}}) {
    OMap map = FullMap();
    if (bad.name == "sampler") map.reports.erase(map.reports.begin());
    map.reports.push_back(bad);
    EXPECT_THROW(WriteOMap(dir.Path("omap.json"), map), Error) << bad.name;
    EXPECT_FALSE(std::ifstream(dir.Path("omap.json")).good()) << bad.name;
  }
}

TEST(OMapJson, NonFiniteNumbersAreWrittenAsNull) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  OMap map = FullMap();
  map.objects[0].covariance(0, 1) = nan;
  map.objects[0].covariance(4, 4) = -inf;
  map.source->pixel_noise_px = nan;  // does not apply (landmark data sets)
  const nlohmann::json json = nlohmann::json::parse(OMapToJson(map));
  EXPECT_TRUE(json["objects"][0]["covariance"][0][1].is_null());
  EXPECT_TRUE(json["objects"][0]["covariance"][4][4].is_null());
  EXPECT_TRUE(json["source"]["pixel_noise_px"].is_null());
  // Unknown entries of the covariance and the noise read back as NaN.
  const OMap read = WrittenAndRead(map);
  EXPECT_TRUE(std::isnan(read.objects[0].covariance(0, 1)));
  EXPECT_TRUE(std::isnan(read.objects[0].covariance(4, 4)));
  EXPECT_EQ(read.objects[0].covariance(1, 0), map.objects[0].covariance(1, 0));
  ASSERT_TRUE(read.source->pixel_noise_px);
  EXPECT_TRUE(std::isnan(*read.source->pixel_noise_px));

  // A map without a finite position is written (null), but is no map to read.
  testing::TempDir dir;
  map.objects[1].base_world.y() = nan;
  WriteOMap(dir.Path("omap.json"), map);
  try {
    ReadOMap(dir.Path("omap.json"));
    ADD_FAILURE() << "read a null base point";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), dir.Path("omap.json") +
                                         ": objects[1].base_point_m[1]: is null (it had no "
                                         "finite value)");
  }
  map.objects[1].base_world.y() = 5;
  map.trajectory[1].theta = inf;
  WriteOMap(dir.Path("omap.json"), map);
  EXPECT_THROW(ReadOMap(dir.Path("omap.json")), Error);
  EXPECT_NE(ErrorFor(ReadTextFile(dir.Path("omap.json"))).find("trajectory[1].theta_rad: is null"),
            std::string::npos);
}

TEST(OMapJson, ReadsAHandMadeMap) {
  testing::TempDir dir;
  std::ofstream(dir.Path("omap.json")) << kMap;
  const OMap map = ReadOMap(dir.Path("omap.json"));
  ASSERT_EQ(map.objects.size(), 1u);
  const OMapObject& box = map.objects[0];
  EXPECT_EQ(box.id, 3);
  EXPECT_EQ(box.class_name, "green box");
  EXPECT_EQ(box.base_world, Eigen::Vector3d(1.5, -0.5, 0.0));
  EXPECT_DOUBLE_EQ(box.diameter_m, 0.68);
  EXPECT_DOUBLE_EQ(box.existence_probability, 0.8);
  EXPECT_DOUBLE_EQ(box.covariance(3, 3), 0.02);
  EXPECT_EQ(box.num_detections, 12);
  ASSERT_EQ(box.class_histogram.size(), 2u);
  EXPECT_EQ(box.class_histogram[0].first, "green box");  // most probable first
  ASSERT_TRUE(box.identity);
  EXPECT_EQ(box.identity->tracks, (std::vector<int>{0, 4}));
  EXPECT_EQ(box.identity->num_samples, 90);
  ASSERT_EQ(box.identities.size(), 2u);
  EXPECT_EQ(box.identities[1].tracks, (std::vector<int>{0, 4}));
  EXPECT_EQ(box.identities[1].num_samples, 10);
  ASSERT_EQ(map.trajectory.size(), 2u);
  EXPECT_DOUBLE_EQ(map.trajectory[1].theta, 0.1);
  EXPECT_FALSE(map.source);
  EXPECT_TRUE(map.reports.empty());

  // The bare minimum: no covariance, detections, trajectory.
  std::ofstream(dir.Path("bare.json")) << R"({"format": "oslam-omap", "objects": [{"id": 0,
      "class": "", "base_point_m": [0, 0, 0], "diameter_m": 0.2, "height_m": 0.3,
      "existence_probability": 1}]})";
  const OMap bare = ReadOMap(dir.Path("bare.json"));
  ASSERT_EQ(bare.objects.size(), 1u);
  EXPECT_EQ(bare.objects[0].covariance, (Eigen::Matrix<double, 5, 5>::Zero()));
  EXPECT_FALSE(bare.objects[0].identity);
  EXPECT_TRUE(bare.trajectory.empty());
}

TEST(OMapJson, MalformedFilesNameTheField) {
  EXPECT_NE(ErrorFor("{ not json").find("not valid JSON"), std::string::npos);
  const std::string not_omap = "format: not an oslam O-Map (expected \"format\": \"oslam-omap\")";
  EXPECT_EQ(ErrorFor("{}"), not_omap);
  EXPECT_EQ(ErrorFor("[1, 2]"), not_omap);
  EXPECT_EQ(ErrorFor(R"({"format": 3})"), not_omap);
  EXPECT_EQ(ErrorFor(Edited("\"version\": 1", "\"version\": \"one\"")),
            "version: must be a number");
  EXPECT_EQ(ErrorFor(Edited("\"existence_probability\": 0.8", "\"existence_probability\": 1.8")),
            "objects[0].existence_probability: must be in [0, 1]");
  EXPECT_EQ(ErrorFor(Edited("\"height_m\": 0.57,", "")), "objects[0].height_m: missing");
  EXPECT_EQ(ErrorFor(Edited("\"diameter_m\": 0.68", "\"diameter_m\": \"wide\"")),
            "objects[0].diameter_m: must be a number");
  EXPECT_EQ(ErrorFor(Edited("[1.5, -0.5, 0.0]", "[1.5, -0.5]")),
            "objects[0].base_point_m: must be [x, y, z]");
  EXPECT_EQ(ErrorFor(Edited("[1.5, -0.5, 0.0]", "[1.5, \"a\", 0.0]")),
            "objects[0].base_point_m[1]: must be a number");
  EXPECT_EQ(ErrorFor(Edited("\"id\": 3", "\"id\": 3.5")), "objects[0].id: must be a whole number");
  EXPECT_EQ(ErrorFor(Edited("\"id\": 3", "\"id\": 1e12")),
            "objects[0].id: 1e+12 is outside [-1e+09, 1e+09] (docs/formats.md, Bounds)");
  EXPECT_EQ(ErrorFor(Edited("\"class\": \"green box\"", "\"class\": 2")),
            "objects[0].class: must be a string");
  EXPECT_EQ(ErrorFor(Edited("\"num_detections\": 12", "\"num_detections\": \"x\"")),
            "objects[0].num_detections: must be a number");
  EXPECT_EQ(ErrorFor(Edited("\"num_detections\": 12", "\"num_detections\": -1")),
            "objects[0].num_detections: -1 is outside [0, 1e+09] (docs/formats.md, Bounds)");
  EXPECT_EQ(ErrorFor(Edited("[0,0,0,0,0.02]]", "[0,0,0,0,\"x\"]]")),
            "objects[0].covariance: must be a 5x5 matrix of numbers");
  EXPECT_EQ(ErrorFor(Edited("\"orange door\": 0.1", "\"orange door\": 2")),
            "objects[0].class_histogram.orange door: must be in [0, 1]");
  EXPECT_EQ(ErrorFor(Edited("{\"orange door\": 0.1, \"green box\": 0.9}", "[0.1, 0.9]")),
            "objects[0].class_histogram: must map class names to probabilities");
  EXPECT_EQ(ErrorFor(Edited("\"tracks\": [0, 4]", "\"tracks\": 4")),
            "objects[0].tracks: must be a list");
  EXPECT_EQ(ErrorFor(Edited("\"tracks\": [0, 4]", "\"tracks\": [0, -4]")),
            "objects[0].tracks[1]: -4 is outside [0, 1e+09] (docs/formats.md, Bounds)");
  EXPECT_EQ(ErrorFor(Edited("\"num_samples\": 90", "\"samples\": 90")),
            "objects[0].num_samples: missing");
  EXPECT_EQ(ErrorFor(Edited("{\"tracks\": [0], \"num_samples\": 80}", "{\"tracks\": [0]}")),
            "objects[0].identities[0].num_samples: missing");
  EXPECT_EQ(ErrorFor(Edited("\"objects\": [", "\"objects\": [3, ")),
            "objects[0]: must be an object");
  EXPECT_EQ(ErrorFor(Edited("\"x_m\": 0.2", "\"x_m\": null")),
            "trajectory[1].x_m: is null (it had no finite value)");
  EXPECT_EQ(ErrorFor(Edited("\"trajectory\": [", "\"trajectory\": 5, \"rest\": [")),
            "trajectory: must be a list");
  EXPECT_EQ(ErrorFor(Edited("\"version\": 1", "\"version\": 1, \"source\": 3")),
            "source: must be an object");
  EXPECT_EQ(
      ErrorFor(Edited("\"version\": 1", "\"version\": 1, \"source\": {\"association\": \"x\"}")),
      "source.run: missing");
  EXPECT_EQ(ErrorFor(Edited("\"version\": 1",
                            "\"version\": 1, \"source\": {\"run\": \"r\", \"association\": \"x\", "
                            "\"seed\": -1}")),
            "source.seed: -1 is outside [0, 9.0072e+15] (docs/formats.md, Bounds)");
  // Physical bounds: finite but absurd values drive the figures and meshes.
  const std::string bound = " (docs/formats.md, Bounds)";
  EXPECT_EQ(ErrorFor(Edited("[1.5, -0.5, 0.0]", "[1e300, -0.5, 0.0]")),
            "objects[0].base_point_m[0]: 1e+300 is outside [-100000, 100000] m" + bound);
  EXPECT_EQ(ErrorFor(Edited("\"diameter_m\": 0.68", "\"diameter_m\": -0.68")),
            "objects[0].diameter_m: -0.68 is outside [0, 100] m" + bound);
  EXPECT_EQ(ErrorFor(Edited("\"height_m\": 0.57", "\"height_m\": 1e9")),
            "objects[0].height_m: 1e+09 is outside [0, 100] m" + bound);
  EXPECT_EQ(ErrorFor(Edited("\"x_m\": 0.2", "\"x_m\": -1e308")),
            "trajectory[1].x_m: -1e+308 is outside [-100000, 100000] m" + bound);
  EXPECT_EQ(ErrorFor(Edited("[0,0,0,0,0.02]]", "[0,0,0,0,1e11]]")),
            "objects[0].covariance[4][4]: 1e+11 is outside [-1e+10, 1e+10]" + bound);
}

TEST(OMapJson, TimingIsWrittenOnlyWhenAskedAndReadBack) {
  OMap map;
  map.reports.push_back({"solver", R"({"iterations": 3})"});
  map.timing.push_back({"solver", R"({"total_time_s": 0.5})"});
  EXPECT_EQ(OMapToJson(map).find("timing"), std::string::npos);
  EXPECT_EQ(OMapToJson(map).find("total_time_s"), std::string::npos);
  const std::string with = OMapToJson(map, OMapTiming::kInclude);
  EXPECT_NE(with.find("\"timing\": {\n  \"solver\": {\n   \"total_time_s\": 0.5"),
            std::string::npos)
      << with;
  testing::TempDir dir;
  WriteOMap(dir.Path("omap.json"), map, OMapTiming::kInclude);
  const OMap read = ReadOMap(dir.Path("omap.json"));
  ASSERT_EQ(read.reports.size(), 1u);  // "timing" is no report
  ASSERT_EQ(read.timing.size(), 1u);
  EXPECT_EQ(read.timing[0].name, "solver");
  EXPECT_EQ(OMapToJson(read, OMapTiming::kInclude), with);
}

}  // namespace
}  // namespace oslam

#include "omap/omap_json.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/bounds.h"
#include "core/error.h"

namespace oslam {
namespace {

// Ordered, so that the members keep the order they are written in and the
// reports come back in the order the file has them.
using Json = nlohmann::ordered_json;

constexpr double kCoordinate = bounds::kCoordinateM;
// A covariance entry: variances up to the square of the coordinate bound.
constexpr double kMaxCovariance = bounds::kCoordinateM * bounds::kCoordinateM;

// The members every O-Map has; any other top-level member is a report.
const char* const kCoreMembers[] = {"format",  "version",    "source",
                                    "objects", "trajectory", "timing"};

bool IsCoreMember(const std::string& name) {
  return std::find(std::begin(kCoreMembers), std::end(kCoreMembers), name) !=
         std::end(kCoreMembers);
}

// JSON has no NaN or infinity, so they become null.
Json Number(double value) {
  return std::isfinite(value) ? Json(value) : Json(nullptr);
}

Json ObjectToJson(const OMapObject& o) {
  Json covariance = Json::array();
  for (int r = 0; r < 5; ++r) {
    Json row = Json::array();
    for (int c = 0; c < 5; ++c) row.push_back(Number(o.covariance(r, c)));
    covariance.push_back(row);
  }
  Json object = {{"id", o.id},
                 {"class", o.class_name},
                 {"base_point_m",
                  {Number(o.base_world.x()), Number(o.base_world.y()), Number(o.base_world.z())}},
                 {"diameter_m", Number(o.diameter_m)},
                 {"height_m", Number(o.height_m)},
                 {"existence_probability", Number(o.existence_probability)},
                 {"num_detections", o.num_detections},
                 {"covariance", covariance}};
  if (o.yaw_rad) object["yaw_rad"] = Number(*o.yaw_rad);
  if (!o.class_histogram.empty()) {
    Json histogram = Json::object();
    for (const auto& [name, probability] : o.class_histogram) histogram[name] = Number(probability);
    object["class_histogram"] = histogram;
  }
  if (o.identity) {
    object["tracks"] = o.identity->tracks;
    object["num_samples"] = o.identity->num_samples;
  }
  if (o.identity || !o.identities.empty()) {
    Json identities = Json::array();
    for (const OMapIdentity& identity : o.identities)
      identities.push_back({{"tracks", identity.tracks}, {"num_samples", identity.num_samples}});
    object["identities"] = identities;
  }
  return object;
}

Json SourceToJson(const OMapSource& source) {
  Json json = {{"run", source.run}};
  if (source.detections) json["detections"] = *source.detections;
  json["association"] = source.association;
  if (source.pixel_noise_px) json["pixel_noise_px"] = Number(*source.pixel_noise_px);
  json["seed"] = source.seed;
  return json;
}

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void Fail(std::string where, const std::string& what) const {
    // `where` may hold a class name from the file: keep the message one line.
    for (char& c : where)
      if (static_cast<unsigned char>(c) < 0x20) c = '?';
    throw Error::InFile(path_, where + ": " + what);
  }
  const Json& Field(const Json& node, const std::string& key, const std::string& where) const {
    if (!node.is_object() || !node.contains(key)) Fail(where + key, "missing");
    return node.at(key);
  }
  double Value(const Json& value, const std::string& where) const {
    if (value.is_null()) Fail(where, "is null (it had no finite value)");
    if (!value.is_number()) Fail(where, "must be a number");
    const double number = value.get<double>();
    if (!std::isfinite(number)) Fail(where, "is not finite");
    return number;
  }
  double Number(const Json& node, const std::string& key, const std::string& where) const {
    return Value(Field(node, key, where), where + key);
  }
  // A number within [low, high] (core/bounds.h).
  double Within(const Json& value, const std::string& where, double low, double high,
                const std::string& unit) const {
    const double number = Value(value, where);
    if (!bounds::Within(number, low, high))
      Fail(where, bounds::OutsideMessage(number, low, high, unit));
    return number;
  }
  double Coordinate(const Json& node, const std::string& key, const std::string& where) const {
    return Within(Field(node, key, where), where + key, -kCoordinate, kCoordinate, "m");
  }
  // A number with an integral value in [low, high].
  double IntegralValue(const Json& value, const std::string& where, double low, double high) const {
    const double number = Value(value, where);
    if (number != std::floor(number)) Fail(where, "must be a whole number");
    if (number < low || number > high) Fail(where, bounds::OutsideMessage(number, low, high));
    return number;
  }
  int Int(const Json& value, const std::string& where, int low = -bounds::kId) const {
    return static_cast<int>(IntegralValue(value, where, low, bounds::kId));
  }
  const Json& List(const Json& node, const std::string& key, const std::string& where) const {
    const Json& value = Field(node, key, where);
    if (!value.is_array()) Fail(where + key, "must be a list");
    return value;
  }
  std::string String(const Json& node, const std::string& key, const std::string& where) const {
    const Json& value = Field(node, key, where);
    if (!value.is_string()) Fail(where + key, "must be a string");
    return value.get<std::string>();
  }
  std::vector<int> Tracks(const Json& node, const std::string& where) const {
    const Json& list = List(node, "tracks", where);
    std::vector<int> tracks;
    for (size_t i = 0; i < list.size(); ++i)
      tracks.push_back(Int(list[i], where + "tracks[" + std::to_string(i) + "]", 0));
    return tracks;
  }

 private:
  std::string path_;
};

OMapSource ReadSource(const Reader& reader, const Json& node) {
  if (!node.is_object()) reader.Fail("source", "must be an object");
  OMapSource source;
  source.run = reader.String(node, "run", "source.");
  source.association = reader.String(node, "association", "source.");
  if (node.contains("detections")) source.detections = reader.String(node, "detections", "source.");
  if (node.contains("pixel_noise_px")) {
    const Json& noise = node["pixel_noise_px"];
    source.pixel_noise_px = noise.is_null() ? std::numeric_limits<double>::quiet_NaN()
                                            : reader.Value(noise, "source.pixel_noise_px");
  }
  if (node.contains("seed")) {
    const Json& seed = node["seed"];
    if (seed.is_number_unsigned())
      source.seed = seed.get<unsigned long>();
    else
      source.seed = static_cast<unsigned long>(
          reader.IntegralValue(seed, "source.seed", 0, 9007199254740992.0));  // 2^53
  }
  return source;
}

OMapObject ReadObject(const Reader& reader, const Json& node, const std::string& where) {
  if (!node.is_object()) reader.Fail(where.substr(0, where.size() - 1), "must be an object");
  OMapObject object;
  object.id = reader.Int(reader.Field(node, "id", where), where + "id");
  object.class_name = reader.String(node, "class", where);
  const Json& base = reader.Field(node, "base_point_m", where);
  if (!base.is_array() || base.size() != 3)
    reader.Fail(where + "base_point_m", "must be [x, y, z]");
  for (int k = 0; k < 3; ++k)
    object.base_world[k] = reader.Within(base[k], where + "base_point_m[" + std::to_string(k) + "]",
                                         -kCoordinate, kCoordinate, "m");
  const double size = bounds::kObjectSizeM;
  object.diameter_m =
      reader.Within(reader.Field(node, "diameter_m", where), where + "diameter_m", 0, size, "m");
  object.height_m =
      reader.Within(reader.Field(node, "height_m", where), where + "height_m", 0, size, "m");
  object.existence_probability = reader.Number(node, "existence_probability", where);
  if (!(object.existence_probability >= 0.0 && object.existence_probability <= 1.0))
    reader.Fail(where + "existence_probability", "must be in [0, 1]");
  if (node.contains("yaw_rad"))
    object.yaw_rad = reader.Within(node["yaw_rad"], where + "yaw_rad", -10.0, 10.0, "rad");
  if (node.contains("num_detections"))
    object.num_detections = reader.Int(node["num_detections"], where + "num_detections", 0);
  if (node.contains("covariance")) {
    const Json& covariance = node["covariance"];
    auto bad = [&] { reader.Fail(where + "covariance", "must be a 5x5 matrix of numbers"); };
    if (!covariance.is_array() || covariance.size() != 5) bad();
    for (int r = 0; r < 5; ++r) {
      if (!covariance[r].is_array() || covariance[r].size() != 5) bad();
      for (int c = 0; c < 5; ++c) {
        const Json& entry = covariance[r][c];
        if (entry.is_null())  // written for a non-finite entry
          object.covariance(r, c) = std::numeric_limits<double>::quiet_NaN();
        else if (entry.is_number())
          object.covariance(r, c) = reader.Within(
              entry, where + "covariance[" + std::to_string(r) + "][" + std::to_string(c) + "]",
              -kMaxCovariance, kMaxCovariance, "");
        else
          bad();
      }
    }
  }
  if (node.contains("class_histogram")) {
    const Json& histogram = node["class_histogram"];
    if (!histogram.is_object())
      reader.Fail(where + "class_histogram", "must map class names to probabilities");
    for (const auto& [class_name, probability] : histogram.items()) {
      const std::string at = where + "class_histogram." + class_name;
      const double p = reader.Value(probability, at);
      if (!(p >= 0.0 && p <= 1.0)) reader.Fail(at, "must be in [0, 1]");
      object.class_histogram.emplace_back(class_name, p);
    }
    std::stable_sort(object.class_histogram.begin(), object.class_histogram.end(),
                     [](const auto& a, const auto& b) { return a.second > b.second; });
  }
  if (node.contains("tracks")) {
    OMapIdentity identity;
    identity.tracks = reader.Tracks(node, where);
    identity.num_samples =
        reader.Int(reader.Field(node, "num_samples", where), where + "num_samples", 0);
    object.identity = identity;
  }
  if (node.contains("identities")) {
    const Json& identities = reader.List(node, "identities", where);
    for (size_t i = 0; i < identities.size(); ++i) {
      const std::string at = where + "identities[" + std::to_string(i) + "].";
      OMapIdentity identity;
      identity.tracks = reader.Tracks(identities[i], at);
      identity.num_samples =
          reader.Int(reader.Field(identities[i], "num_samples", at), at + "num_samples", 0);
      object.identities.push_back(identity);
    }
  }
  return object;
}

OMap ReadRoot(const Reader& reader, const Json& root) {
  if (!root.is_object() || !root.contains("format") || root["format"] != "oslam-omap")
    reader.Fail("format", "not an oslam O-Map (expected \"format\": \"oslam-omap\")");
  if (root.contains("version")) reader.Int(root["version"], "version", 1);
  OMap map;
  if (root.contains("source")) map.source = ReadSource(reader, root["source"]);
  const Json& objects = reader.List(root, "objects", "");
  for (size_t i = 0; i < objects.size(); ++i)
    map.objects.push_back(ReadObject(reader, objects[i], "objects[" + std::to_string(i) + "]."));
  if (root.contains("trajectory")) {
    const Json& trajectory = reader.List(root, "trajectory", "");
    for (size_t i = 0; i < trajectory.size(); ++i) {
      const std::string where = "trajectory[" + std::to_string(i) + "].";
      const double angle = bounds::kAngleRad;
      map.trajectory.push_back({reader.Coordinate(trajectory[i], "x_m", where),
                                reader.Coordinate(trajectory[i], "y_m", where),
                                reader.Within(reader.Field(trajectory[i], "theta_rad", where),
                                              where + "theta_rad", -angle, angle, "rad")});
    }
  }
  for (const auto& [name, value] : root.items())
    if (!IsCoreMember(name)) map.reports.push_back({name, value.dump()});
  if (root.contains("timing")) {
    const Json& timing = root["timing"];
    if (!timing.is_object()) reader.Fail("timing", "must be an object");
    for (const auto& [name, value] : timing.items()) map.timing.push_back({name, value.dump()});
  }
  return map;
}

}  // namespace

std::string OMapToJson(const OMap& map, OMapTiming timing) {
  Json root = {{"format", "oslam-omap"}, {"version", 1}};
  if (map.source) root["source"] = SourceToJson(*map.source);
  Json objects = Json::array();
  for (const OMapObject& object : map.objects) objects.push_back(ObjectToJson(object));
  root["objects"] = objects;
  Json trajectory = Json::array();
  for (size_t i = 0; i < map.trajectory.size(); ++i) {
    const Pose2& p = map.trajectory[i];
    trajectory.push_back(
        {{"frame", i}, {"x_m", Number(p.x)}, {"y_m", Number(p.y)}, {"theta_rad", Number(p.theta)}});
  }
  root["trajectory"] = trajectory;
  for (const OMapReport& report : map.reports) {
    if (report.name.empty() || IsCoreMember(report.name) || root.contains(report.name))
      throw Error("O-Map report '" + report.name + "': the name is empty or taken");
    try {
      root[report.name] = Json::parse(report.json);
    } catch (const Json::exception& e) {
      throw Error("O-Map report '" + report.name + "': not valid JSON (" + e.what() + ")");
    }
  }
  if (timing == OMapTiming::kInclude && !map.timing.empty()) {
    Json members = Json::object();
    for (const OMapReport& report : map.timing) {
      try {
        members[report.name] = Json::parse(report.json);
      } catch (const Json::exception& e) {
        throw Error("O-Map timing '" + report.name + "': not valid JSON (" + e.what() + ")");
      }
    }
    root["timing"] = members;
  }
  // Names and paths are not checked for UTF-8 elsewhere: replace bad bytes
  // rather than fail after the map was made.
  return root.dump(1, ' ', false, Json::error_handler_t::replace) + "\n";
}

void WriteOMap(const std::string& path, const OMap& map, OMapTiming timing) {
  WriteTextFileAtomically(path, OMapToJson(map, timing));
}

OMap ReadOMap(const std::string& path) {
  Json root;
  try {
    root = Json::parse(ReadTextFile(path));
  } catch (const Json::exception& e) {
    throw Error::InFile(path, std::string("not valid JSON: ") + e.what());
  }
  return ReadRoot(Reader(path), root);
}

}  // namespace oslam

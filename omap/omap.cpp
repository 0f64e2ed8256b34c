#include "omap/omap.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"

namespace oslam {
namespace {

using Json = nlohmann::json;

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void Fail(const std::string& where, const std::string& what) const {
    throw Error::InFile(path_, where + ": " + what);
  }
  const Json& Field(const Json& node, const std::string& key, const std::string& where) const {
    if (!node.is_object() || !node.contains(key)) Fail(where + key, "missing");
    return node.at(key);
  }
  double Number(const Json& node, const std::string& key, const std::string& where) const {
    const Json& value = Field(node, key, where);
    if (!value.is_number()) Fail(where + key, "must be a number");
    const double number = value.get<double>();
    if (!std::isfinite(number)) Fail(where + key, "is not finite");
    return number;
  }

 private:
  std::string path_;
};

}  // namespace

OMap ReadOMap(const std::string& path) {
  Json root;
  try {
    root = Json::parse(ReadTextFile(path));
  } catch (const Json::parse_error& e) {
    throw Error::InFile(path, std::string("not valid JSON: ") + e.what());
  }
  const Reader reader(path);
  if (!root.is_object() || root.value("format", "") != "oslam-omap")
    reader.Fail("format", "not an oslam O-Map (expected \"format\": \"oslam-omap\")");
  OMap map;
  const Json& objects = reader.Field(root, "objects", "");
  if (!objects.is_array()) reader.Fail("objects", "must be a list");
  for (size_t i = 0; i < objects.size(); ++i) {
    const Json& node = objects[i];
    const std::string where = "objects[" + std::to_string(i) + "].";
    OMapObject object;
    object.id = static_cast<int>(reader.Number(node, "id", where));
    const Json& name = reader.Field(node, "class", where);
    if (!name.is_string()) reader.Fail(where + "class", "must be a string");
    object.class_name = name.get<std::string>();
    const Json& base = reader.Field(node, "base_point_m", where);
    if (!base.is_array() || base.size() != 3) reader.Fail(where + "base_point_m", "must be [x, y, z]");
    for (int k = 0; k < 3; ++k) {
      if (!base[k].is_number()) reader.Fail(where + "base_point_m", "must hold numbers");
      object.base_world[k] = base[k].get<double>();
    }
    object.diameter_m = reader.Number(node, "diameter_m", where);
    object.height_m = reader.Number(node, "height_m", where);
    object.existence_probability = reader.Number(node, "existence_probability", where);
    if (!(object.existence_probability >= 0.0 && object.existence_probability <= 1.0))
      reader.Fail(where + "existence_probability", "must be in [0, 1]");
    if (node.contains("num_detections")) object.num_detections = node["num_detections"].get<int>();
    if (node.contains("covariance")) {
      const Json& covariance = node["covariance"];
      if (!covariance.is_array() || covariance.size() != 5)
        reader.Fail(where + "covariance", "must be a 5x5 matrix");
      for (int r = 0; r < 5; ++r) {
        if (!covariance[r].is_array() || covariance[r].size() != 5)
          reader.Fail(where + "covariance", "must be a 5x5 matrix");
        for (int c = 0; c < 5; ++c)
          object.covariance(r, c) = covariance[r][c].is_number() ? covariance[r][c].get<double>() : NAN;
      }
    }
    if (node.contains("class_histogram")) {
      for (const auto& [class_name, probability] : node["class_histogram"].items())
        object.class_histogram.emplace_back(class_name, probability.get<double>());
      std::sort(object.class_histogram.begin(), object.class_histogram.end(),
                [](const auto& a, const auto& b) { return a.second > b.second; });
    }
    map.objects.push_back(object);
  }
  if (root.contains("trajectory")) {
    const Json& trajectory = root["trajectory"];
    if (!trajectory.is_array()) reader.Fail("trajectory", "must be a list");
    for (size_t i = 0; i < trajectory.size(); ++i) {
      const std::string where = "trajectory[" + std::to_string(i) + "].";
      map.trajectory.push_back({reader.Number(trajectory[i], "x_m", where),
                                reader.Number(trajectory[i], "y_m", where),
                                reader.Number(trajectory[i], "theta_rad", where)});
    }
  }
  return map;
}

}  // namespace oslam

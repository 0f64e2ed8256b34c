#include "core/yaml.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/bounds.h"
#include "core/error.h"

namespace oslam {

namespace {

// OpenCV reports YAML syntax errors as func = "(LINE): what"; turn that into
// "line N: what", counting lines of the user's file.
std::string DescribeSyntaxError(const cv::Exception& e, int lines_added) {
  const std::string& func = e.func;
  const size_t open = func.find('('), close = func.find("): ");
  if (open == 0 && close != std::string::npos) {
    const int line = std::atoi(func.substr(1, close - 1).c_str()) - lines_added;
    return "YAML syntax error at line " + std::to_string(line) + ": " + func.substr(close + 3);
  }
  return "not valid YAML (" + (e.err.empty() ? std::string("parse error") : e.err) + ")";
}

}  // namespace

YamlFile::YamlFile(const std::string& path) : path_(path) {
  if (!std::filesystem::is_regular_file(path)) throw Error::InFile(path, "file not found");
  std::string text = ReadTextFile(path);
  // OpenCV insists on the %YAML directive; hand-written files rarely have it.
  int lines_added = 0;
  if (text.rfind("%YAML", 0) != 0) {
    text = "%YAML:1.0\n---\n" + text;
    lines_added = 2;
  }
  try {
    storage_.open(text,
                  cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw Error::InFile(path, DescribeSyntaxError(e, lines_added));
  } catch (const std::exception& e) {
    // OpenCV's parser fails on some malformed input (e.g. an empty key) with a
    // standard exception instead of a parse error (found by corruption_test).
    throw Error::InFile(path, std::string("not valid YAML (") + e.what() + ")");
  }
  if (!storage_.isOpened()) throw Error::InFile(path, "cannot be read as YAML");
  if (!storage_.root().isMap()) throw Error::InFile(path, "expected a YAML mapping at top level");
}

void YamlFile::Fail(const std::string& key_path, const std::string& what) const {
  throw Error::InFile(path_, key_path + ": " + what);
}

double YamlFile::Within(double value, const std::string& key_path, double low, double high,
                        const std::string& unit) const {
  if (!bounds::Within(value, low, high))
    Fail(key_path, bounds::OutsideMessage(value, low, high, unit));
  return value;
}

double YamlFile::NumberOf(const cv::FileNode& value, const std::string& key_path) const {
  if (!value.isReal() && !value.isInt()) Fail(key_path, "must be a number");
  const double number = static_cast<double>(value);
  if (!std::isfinite(number)) Fail(key_path, "is NaN or infinite");
  return number;
}

double YamlFile::Double(const cv::FileNode& node, const std::string& key,
                        const std::string& prefix) const {
  const cv::FileNode value = node[key];
  if (value.empty() || value.isNone()) Fail(prefix + key, "missing");
  return NumberOf(value, prefix + key);
}

double YamlFile::OptionalDouble(const cv::FileNode& node, const std::string& key, double fallback,
                                const std::string& prefix) const {
  const cv::FileNode value = node[key];
  if (value.empty() || value.isNone()) return fallback;
  return NumberOf(value, prefix + key);
}

int YamlFile::Int(const cv::FileNode& node, const std::string& key,
                  const std::string& prefix) const {
  const cv::FileNode value = node[key];
  if (value.empty() || value.isNone()) Fail(prefix + key, "missing");
  if (!value.isInt()) Fail(prefix + key, "must be an integer");
  return static_cast<int>(value);
}

int YamlFile::OptionalInt(const cv::FileNode& node, const std::string& key, int fallback,
                          const std::string& prefix) const {
  const cv::FileNode value = node[key];
  if (value.empty() || value.isNone()) return fallback;
  return Int(node, key, prefix);
}

std::string YamlFile::String(const cv::FileNode& node, const std::string& key,
                             const std::string& prefix) const {
  const cv::FileNode value = node[key];
  if (value.empty() || value.isNone()) Fail(prefix + key, "missing");
  if (!value.isString()) Fail(prefix + key, "must be a string");
  return static_cast<std::string>(value);
}

std::string YamlFile::OptionalString(const cv::FileNode& node, const std::string& key,
                                     const std::string& fallback, const std::string& prefix) const {
  const cv::FileNode value = node[key];
  if (value.empty() || value.isNone()) return fallback;
  return String(node, key, prefix);
}

std::vector<double> YamlFile::Doubles(const cv::FileNode& node, const std::string& key, int size,
                                      const std::string& prefix) const {
  const cv::FileNode value = Seq(node, key, prefix);
  if (size >= 0 && static_cast<int>(value.size()) != size) {
    Fail(prefix + key,
         "expected " + std::to_string(size) + " numbers, found " + std::to_string(value.size()));
  }
  std::vector<double> numbers;
  for (size_t i = 0; i < value.size(); ++i)
    numbers.push_back(
        NumberOf(value[static_cast<int>(i)], prefix + key + "[" + std::to_string(i) + "]"));
  return numbers;
}

cv::FileNode YamlFile::Map(const cv::FileNode& node, const std::string& key,
                           const std::string& prefix) const {
  const cv::FileNode value = node[key];
  if (value.empty() || value.isNone()) Fail(prefix + key, "missing");
  if (!value.isMap()) Fail(prefix + key, "must be a mapping of key: value");
  return value;
}

cv::FileNode YamlFile::Seq(const cv::FileNode& node, const std::string& key,
                           const std::string& prefix) const {
  const cv::FileNode value = node[key];
  if (value.empty() || value.isNone()) Fail(prefix + key, "missing");
  if (!value.isSeq()) Fail(prefix + key, "must be a list");
  return value;
}

void YamlFile::RequireOnlyKeys(const cv::FileNode& node, const std::string& prefix,
                               const std::vector<std::string>& allowed) const {
  for (const std::string& key : node.keys()) {
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      std::string known;
      for (const auto& name : allowed) known += (known.empty() ? "" : ", ") + name;
      Fail(prefix + key, "unknown key (allowed: " + known + ")");
    }
  }
}

}  // namespace oslam

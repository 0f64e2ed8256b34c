// Checked access to YAML files read with cv::FileStorage: every error names
// the file and the key ("classes.yaml: classes[2].height_std_m: must be a number").
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace oslam {

class YamlFile {
 public:
  // Opens and parses `path`; throws oslam::Error on a missing file or a syntax
  // error (with OpenCV's line number when it gives one).
  explicit YamlFile(const std::string& path);

  const std::string& path() const { return path_; }
  cv::FileNode root() const { return storage_.root(); }

  // `prefix` is the key path of `node` for messages, e.g. "classes[2]."
  double Double(const cv::FileNode& node, const std::string& key,
                const std::string& prefix = "") const;
  double OptionalDouble(const cv::FileNode& node, const std::string& key, double fallback,
                        const std::string& prefix = "") const;
  int Int(const cv::FileNode& node, const std::string& key, const std::string& prefix = "") const;
  int OptionalInt(const cv::FileNode& node, const std::string& key, int fallback,
                  const std::string& prefix = "") const;
  std::string String(const cv::FileNode& node, const std::string& key,
                     const std::string& prefix = "") const;
  std::string OptionalString(const cv::FileNode& node, const std::string& key,
                             const std::string& fallback, const std::string& prefix = "") const;
  // A sequence of exactly `size` numbers (any size when size < 0).
  std::vector<double> Doubles(const cv::FileNode& node, const std::string& key, int size,
                              const std::string& prefix = "") const;
  cv::FileNode Map(const cv::FileNode& node, const std::string& key,
                   const std::string& prefix = "") const;
  cv::FileNode Seq(const cv::FileNode& node, const std::string& key,
                   const std::string& prefix = "") const;
  // Unknown keys are errors: a typo must not silently fall back to a default.
  void RequireOnlyKeys(const cv::FileNode& node, const std::string& prefix,
                       const std::vector<std::string>& allowed) const;

  // `value` when it lies in [low, high] (core/bounds.h); fails naming
  // key_path otherwise.
  double Within(double value, const std::string& key_path, double low, double high,
                const std::string& unit = "") const;

  [[noreturn]] void Fail(const std::string& key_path, const std::string& what) const;

 private:
  double NumberOf(const cv::FileNode& value, const std::string& key_path) const;

  std::string path_;
  cv::FileStorage storage_;
};

}  // namespace oslam

#include "detect/colour_training.h"

#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "core/yaml.h"
#include "detect/colour_classifier.h"

namespace oslam {
namespace fs = std::filesystem;

std::vector<ColourExample> ReadColourExamples(const std::string& path,
                                              const std::vector<ObjectClass>& classes) {
  YamlFile file(path);
  file.RequireOnlyKeys(file.root(), "", {"examples"});
  const cv::FileNode list = file.Seq(file.root(), "examples");
  if (list.size() == 0) file.Fail("examples", "no examples listed");
  const fs::path base = fs::path(path).parent_path();
  std::vector<ColourExample> examples;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string key = "examples[" + std::to_string(i) + "]";
    const cv::FileNode node = list[static_cast<int>(i)];
    if (!node.isMap()) file.Fail(key, "must be a mapping");
    file.RequireOnlyKeys(node, key + ".", {"image", "class", "roi", "mask"});
    ColourExample example;
    example.image_path = (base / file.String(node, "image", key + ".")).string();
    example.class_name = file.String(node, "class", key + ".");
    if (FindClass(classes, example.class_name) < 0)
      file.Fail(key + ".class", "unknown class '" + example.class_name + "' (not in classes.yaml)");
    if (!fs::is_regular_file(example.image_path))
      file.Fail(key + ".image", "file not found: " + example.image_path);
    const bool has_roi = !node["roi"].empty(), has_mask = !node["mask"].empty();
    if (has_roi == has_mask) file.Fail(key, "give exactly one of roi and mask");
    if (has_roi) {
      const std::vector<double> roi = file.Doubles(node, "roi", 4, key + ".");
      example.roi = cv::Rect(static_cast<int>(roi[0]), static_cast<int>(roi[1]),
                             static_cast<int>(roi[2]), static_cast<int>(roi[3]));
      if (example.roi.width <= 0 || example.roi.height <= 0)
        file.Fail(key + ".roi", "width and height must be positive");
    } else {
      example.mask_path = (base / file.String(node, "mask", key + ".")).string();
      if (!fs::is_regular_file(example.mask_path))
        file.Fail(key + ".mask", "file not found: " + example.mask_path);
    }
    examples.push_back(example);
  }
  return examples;
}

std::vector<ObjectClass> TrainColourModels(const std::vector<ObjectClass>& classes,
                                           const std::vector<ColourExample>& examples,
                                           double k_sigma) {
  std::vector<ObjectClass> trained = classes;
  for (size_t c = 0; c < classes.size(); ++c) {
    std::vector<cv::Mat> images, masks;
    for (const ColourExample& example : examples) {
      if (example.class_name != classes[c].name) continue;
      cv::Mat image = cv::imread(example.image_path, cv::IMREAD_COLOR);
      if (image.empty()) throw Error::InFile(example.image_path, "cannot read image");
      cv::Mat mask;
      if (example.mask_path.empty()) {
        if ((example.roi & cv::Rect(0, 0, image.cols, image.rows)) != example.roi)
          throw Error::InFile(example.image_path, "ROI lies outside the image");
        mask = cv::Mat::zeros(image.size(), CV_8UC1);
        mask(example.roi).setTo(255);
      } else {
        mask = cv::imread(example.mask_path, cv::IMREAD_GRAYSCALE);
        if (mask.empty()) throw Error::InFile(example.mask_path, "cannot read mask image");
        if (mask.size() != image.size())
          throw Error::InFile(example.mask_path, "mask size differs from its image");
      }
      images.push_back(image);
      masks.push_back(mask);
    }
    if (images.empty()) continue;
    try {
      trained[c].colour = LearnColourBox(images, masks, k_sigma);
    } catch (const Error& e) {
      throw Error("class '" + classes[c].name + "': " + e.what());
    }
  }
  return trained;
}

}  // namespace oslam

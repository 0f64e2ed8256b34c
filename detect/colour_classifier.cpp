#include "detect/colour_classifier.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace oslam {

bool ColourClassifierOptions::Validate(std::string* why) const {
  if (!(brightness_range >= 1.0 && brightness_range <= 16.0)) {
    if (why) *why = "brightness_range must be in 1..16";
    return false;
  }
  if (min_y < 0 || min_y > 255) {
    if (why) *why = "min_y must be in 0..255";
    return false;
  }
  return true;
}

bool ParseColourBoxShape(const std::string& text, ColourBoxShape* shape) {
  if (text == "yuv") {
    *shape = ColourBoxShape::kYuv;
  } else if (text == "scaled") {
    *shape = ColourBoxShape::kBrightnessScaled;
  } else {
    return false;
  }
  return true;
}

namespace {

// Sets `bit` in table[y * 256 + v] for every integer v in [low, high].
void SetRange(std::vector<uint32_t>* table, int y, double low, double high, uint32_t bit) {
  const int first = std::max(0, static_cast<int>(std::ceil(low)));
  const int last = std::min(255, static_cast<int>(std::floor(high)));
  for (int v = first; v <= last; ++v) (*table)[y * 256 + v] |= bit;
}

}  // namespace

ColourClassifier::ColourClassifier(const std::vector<ObjectClass>& classes,
                                   const ColourClassifierOptions& options)
    : num_classes_(static_cast<int>(classes.size())),
      options_(options),
      y_u_(256 * 256, 0u),
      y_v_(256 * 256, 0u) {
  if (num_classes_ > kMaxClasses)
    throw Error("the colour detector handles at most 32 classes, got " +
                std::to_string(num_classes_));
  std::string why;
  if (!options.Validate(&why)) throw Error("colour classifier: " + why);
  for (int c = 0; c < num_classes_; ++c) {
    if (!classes[c].colour) continue;
    const ColourBox& box = *classes[c].colour;
    const uint32_t bit = 1u << c;
    const double k = box.k_sigma;
    const double y_low = box.yuv_mean[0] - k * box.yuv_std[0];
    const double y_high = box.yuv_mean[0] + k * box.yuv_std[0];
    for (int y = 0; y < 256; ++y) {
      if (options.shape == ColourBoxShape::kYuv) {
        if (y < y_low || y > y_high) continue;
        for (int ch = 1; ch < 3; ++ch)
          SetRange(ch == 1 ? &y_u_ : &y_v_, y, box.yuv_mean[ch] - k * box.yuv_std[ch],
                   box.yuv_mean[ch] + k * box.yuv_std[ch], bit);
      } else {
        if (y < options.min_y || y < y_low / options.brightness_range || y > y_high) continue;
        const double scale = y / std::max(1.0, box.yuv_mean[0]);
        for (int ch = 1; ch < 3; ++ch) {
          const double centre = 128.0 + scale * (box.yuv_mean[ch] - 128.0);
          const double half_width = k * box.yuv_std[ch] * scale;
          SetRange(ch == 1 ? &y_u_ : &y_v_, y, centre - half_width, centre + half_width, bit);
        }
      }
    }
  }
}

void ColourClassifier::Classify(const cv::Mat& yuv, const cv::Mat& mask, cv::Mat* class_bits,
                                std::vector<ClassExtent>* extents) const {
  CV_Assert(yuv.type() == CV_8UC3);
  CV_Assert(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == yuv.size()));
  class_bits->create(yuv.size(), CV_32SC1);
  std::vector<int> count(num_classes_, 0);
  std::vector<int> min_x(num_classes_, yuv.cols), min_y(num_classes_, yuv.rows);
  std::vector<int> max_x(num_classes_, -1), max_y(num_classes_, -1);
  const uint32_t* y_u = y_u_.data();
  const uint32_t* y_v = y_v_.data();
  for (int y = 0; y < yuv.rows; ++y) {
    const cv::Vec3b* in = yuv.ptr<cv::Vec3b>(y);
    const uint8_t* use = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    uint32_t* out = reinterpret_cast<uint32_t*>(class_bits->ptr<int32_t>(y));
    for (int x = 0; x < yuv.cols; ++x) {
      const int row = in[x][0] << 8;
      uint32_t bits = y_u[row | in[x][1]] & y_v[row | in[x][2]];
      if (use && !use[x]) bits = 0;
      out[x] = bits;
      // Most pixels belong to no class, so this loop rarely runs.
      for (uint32_t rest = bits; rest; rest &= rest - 1) {
        const int c = __builtin_ctz(rest);
        ++count[c];
        min_x[c] = std::min(min_x[c], x);
        max_x[c] = std::max(max_x[c], x);
        min_y[c] = std::min(min_y[c], y);
        max_y[c] = std::max(max_y[c], y);
      }
    }
  }
  extents->assign(num_classes_, ClassExtent{});
  for (int c = 0; c < num_classes_; ++c) {
    if (count[c] == 0) continue;
    (*extents)[c] = {
        count[c], cv::Rect(min_x[c], min_y[c], max_x[c] - min_x[c] + 1, max_y[c] - min_y[c] + 1)};
  }
}

bool ColourClassifier::InBox(int class_index, const cv::Vec3b& yuv) const {
  const uint32_t bit = 1u << class_index;
  const int row = yuv[0] << 8;
  return (y_u_[row | yuv[1]] & y_v_[row | yuv[2]] & bit) != 0;
}

double ColourClassifier::SquaredDistance(const ColourBox& box,
                                         const std::array<double, 3>& yuv) const {
  double d2 = 0;
  if (options_.shape == ColourBoxShape::kYuv) {
    for (int ch = 0; ch < 3; ++ch)
      d2 += std::pow((yuv[ch] - box.yuv_mean[ch]) / std::max(1.0, box.yuv_std[ch]), 2);
    return d2;
  }
  const double scale = yuv[0] / std::max(1.0, box.yuv_mean[0]);
  for (int ch = 1; ch < 3; ++ch) {
    const double expected = scale * (box.yuv_mean[ch] - 128.0);
    const double sigma = std::max(1.0, box.yuv_std[ch]) * std::max(0.1, scale);
    d2 += std::pow((yuv[ch] - 128.0 - expected) / sigma, 2);
  }
  return d2;
}

std::array<double, 2> ChromaAtBrightness(const std::array<double, 3>& yuv, double reference_y) {
  const double scale = reference_y / std::max(1.0, yuv[0]);
  return {scale * (yuv[1] - 128.0), scale * (yuv[2] - 128.0)};
}

double BlobChromaSquaredDistance(const ColourBox& box, const std::array<double, 3>& mean_yuv) {
  const std::array<double, 2> chroma = ChromaAtBrightness(mean_yuv, box.yuv_mean[0]);
  double d2 = 0;
  for (int ch = 0; ch < 2; ++ch)
    d2 += std::pow((chroma[ch] - box.blob_chroma->mean[ch]) / box.blob_chroma->std[ch], 2);
  return d2;
}

ColourBox LearnColourBox(const std::vector<cv::Mat>& bgr_images, const std::vector<cv::Mat>& masks,
                         double k_sigma) {
  std::array<double, 3> sum{}, sum_sq{};
  double n = 0;
  for (size_t i = 0; i < bgr_images.size(); ++i) {
    cv::Mat yuv;
    cv::cvtColor(bgr_images[i], yuv, cv::COLOR_BGR2YUV);
    for (int y = 0; y < yuv.rows; ++y) {
      const cv::Vec3b* row = yuv.ptr<cv::Vec3b>(y);
      const uint8_t* use = masks[i].ptr<uint8_t>(y);
      for (int x = 0; x < yuv.cols; ++x) {
        if (!use[x]) continue;
        for (int ch = 0; ch < 3; ++ch) {
          sum[ch] += row[x][ch];
          sum_sq[ch] += double(row[x][ch]) * row[x][ch];
        }
        n += 1;
      }
    }
  }
  if (n < 2)
    throw Error("colour model needs at least 2 example pixels, got " + std::to_string(int(n)));
  ColourBox box;
  box.k_sigma = k_sigma;
  for (int ch = 0; ch < 3; ++ch) {
    box.yuv_mean[ch] = sum[ch] / n;
    const double variance = (sum_sq[ch] - n * box.yuv_mean[ch] * box.yuv_mean[ch]) / (n - 1);
    box.yuv_std[ch] = std::sqrt(std::max(0.0, variance));
  }
  return box;
}

std::vector<std::vector<double>> ColourConfusion(const std::vector<ObjectClass>& classes,
                                                 double floor) {
  const size_t n = classes.size();
  std::vector<std::vector<double>> confusion(n, std::vector<double>(n, 0.0));
  for (size_t c = 0; c < n; ++c) {
    if (!classes[c].colour) {
      confusion[c][c] = 1.0;
      continue;
    }
    const ColourBox& truth = *classes[c].colour;
    std::vector<double> log_weight(n, -INFINITY);
    double best = -INFINITY;
    for (size_t a = 0; a < n; ++a) {
      if (!classes[a].colour) continue;
      double d2 = 0;
      for (int ch = 0; ch < 3; ++ch) {
        // A channel with zero spread would make every other class infinitely
        // far; one grey level keeps the distance finite.
        const double sigma = std::max(truth.yuv_std[ch], 1.0);
        const double diff = classes[a].colour->yuv_mean[ch] - truth.yuv_mean[ch];
        d2 += diff * diff / (sigma * sigma);
      }
      log_weight[a] = -0.5 * d2;
      best = std::max(best, log_weight[a]);
    }
    double total = 0;
    for (size_t a = 0; a < n; ++a) {
      confusion[c][a] = std::isfinite(log_weight[a]) ? std::exp(log_weight[a] - best) : 0.0;
      total += confusion[c][a];
    }
    double floored_total = 0;
    for (size_t a = 0; a < n; ++a) {
      confusion[c][a] = std::max(confusion[c][a] / total, floor);
      floored_total += confusion[c][a];
    }
    for (size_t a = 0; a < n; ++a) confusion[c][a] /= floored_total;
  }
  return confusion;
}

}  // namespace oslam

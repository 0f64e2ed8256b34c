#include "detect/colour_classifier.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace oslam {

ColourClassifier::ColourClassifier(const std::vector<ObjectClass>& classes)
    : num_classes_(static_cast<int>(classes.size())) {
  if (num_classes_ > kMaxClasses)
    throw Error("the colour detector handles at most 32 classes, got " +
                std::to_string(num_classes_));
  for (int c = 0; c < num_classes_; ++c) {
    if (!classes[c].colour) continue;
    const ColourBox& box = *classes[c].colour;
    for (int channel = 0; channel < 3; ++channel) {
      const double half_width = box.k_sigma * box.yuv_std[channel];
      const int low = static_cast<int>(std::ceil(box.yuv_mean[channel] - half_width));
      const int high = static_cast<int>(std::floor(box.yuv_mean[channel] + half_width));
      for (int value = std::max(0, low); value <= std::min(255, high); ++value)
        tables_[channel][value] |= (1u << c);
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
  for (int y = 0; y < yuv.rows; ++y) {
    const cv::Vec3b* in = yuv.ptr<cv::Vec3b>(y);
    const uint8_t* use = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    uint32_t* out = reinterpret_cast<uint32_t*>(class_bits->ptr<int32_t>(y));
    for (int x = 0; x < yuv.cols; ++x) {
      uint32_t bits = tables_[0][in[x][0]] & tables_[1][in[x][1]] & tables_[2][in[x][2]];
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
    (*extents)[c] = {count[c], cv::Rect(min_x[c], min_y[c], max_x[c] - min_x[c] + 1,
                                        max_y[c] - min_y[c] + 1)};
  }
}

bool ColourClassifier::InBox(int class_index, const cv::Vec3b& yuv) const {
  const uint32_t bit = 1u << class_index;
  return (tables_[0][yuv[0]] & tables_[1][yuv[1]] & tables_[2][yuv[2]] & bit) != 0;
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
  if (n < 2) throw Error("colour model needs at least 2 example pixels, got " + std::to_string(int(n)));
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

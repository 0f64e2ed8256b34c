#include "export/label_layout.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace oslam {
namespace {

// Overlaps thinner than this (rounding where two rectangles touch) count as
// none.
constexpr double kTouching = 1e-9;

double OverlapArea(const cv::Rect2d& a, const cv::Rect2d& b) {
  const double w = std::min(a.x + a.width, b.x + b.width) - std::max(a.x, b.x);
  const double h = std::min(a.y + a.height, b.y + b.height) - std::max(a.y, b.y);
  return w > kTouching && h > kTouching ? w * h : 0.0;
}

cv::Rect2d Grown(const cv::Rect2d& r, double by) {
  return {r.x - by, r.y - by, r.width + 2 * by, r.height + 2 * by};
}

// Area of `box` outside `canvas`.
double OutsideArea(const cv::Rect2d& box, const cv::Rect2d& canvas) {
  const double outside = box.area() - OverlapArea(box, canvas);
  return outside > kTouching * box.area() ? outside : 0.0;
}

}  // namespace

cv::Point2d NearestPointOnBox(const cv::Rect2d& box, const cv::Point2d& point) {
  return {std::clamp(point.x, box.x, box.x + box.width),
          std::clamp(point.y, box.y, box.y + box.height)};
}

std::vector<PlacedLabel> PlaceLabels(const std::vector<LabelRequest>& labels,
                                     const cv::Rect2d& canvas,
                                     const std::vector<cv::Rect2d>& obstacles, double gap) {
  // What is drawn at every anchor is kept clear (at least a small square), so
  // no label hides what another label names.
  std::vector<cv::Rect2d> taken = obstacles;
  for (const LabelRequest& label : labels) {
    const double cx = std::max(label.clearance.width, gap),
                 cy = std::max(label.clearance.height, gap);
    taken.push_back({label.anchor.x - cx, label.anchor.y - cy, 2 * cx, 2 * cy});
  }
  const size_t fixed = taken.size();

  // Directions of the candidate spots, in order of preference: right of the
  // anchor first (reads naturally), then the diagonals, above, below, left.
  const std::vector<cv::Point2d> directions = {{1, 0}, {1, -1},  {1, 1},  {0, -1},
                                               {0, 1}, {-1, -1}, {-1, 1}, {-1, 0}};
  constexpr int kRings = 6;

  std::vector<PlacedLabel> placed;
  for (size_t i = 0; i < labels.size(); ++i) {
    const LabelRequest& label = labels[i];
    const double w = label.size.width, h = label.size.height;
    double best_cost = std::numeric_limits<double>::infinity();
    PlacedLabel best;
    for (int ring = 0; ring < kRings && best_cost > 0; ++ring) {
      const double step = gap * (1 + 2 * ring);
      const cv::Point2d reach(label.clearance.width + step, label.clearance.height + step);
      for (const cv::Point2d& d : directions) {
        // The label's corner or edge middle nearest the anchor sits just
        // beyond the clearance along the direction.
        const double x = label.anchor.x + d.x * reach.x - (d.x < 0 ? w : d.x == 0 ? w / 2 : 0);
        const double y = label.anchor.y + d.y * reach.y - (d.y < 0 ? h : d.y == 0 ? h / 2 : 0);
        const cv::Rect2d box(x, y, w, h);
        double cost = 1e3 * OutsideArea(box, canvas);
        for (size_t k = 0; k < taken.size(); ++k) {
          if (k >= obstacles.size() && k < fixed && k - obstacles.size() == i)
            continue;  // own anchor
          cost += OverlapArea(Grown(box, 0.5 * gap), taken[k]);
        }
        // Among equally free spots the nearest wins (the loop order).
        if (cost < best_cost) {
          best_cost = cost;
          best.box = box;
          best.needs_leader = ring > 0;
        }
        if (best_cost == 0) break;
      }
    }
    taken.push_back(best.box);
    placed.push_back(best);
  }
  return placed;
}

}  // namespace oslam

// Places text labels next to their anchors so they overlap neither each
// other, nor what is drawn at any anchor, nor given obstacles (a legend),
// and stay on the canvas: the overlays, the figures and the 3D views use it.
// Greedy, in the given order: each label takes the first free spot of a ring
// of candidates around its anchor (right, above right, above, ... ), rings
// further out when the near ones are taken; when none is free, the spot that
// overlaps least. Deterministic. Any 2D frame with y down (pixels) or up
// (millimetres on a plot): only overlaps and distances matter.
#pragma once

#include <vector>

#include <opencv2/core/types.hpp>

namespace oslam {

struct LabelRequest {
  cv::Point2d anchor;  // the point the label belongs to
  cv::Size2d size;     // the label's extent
  // Half the width and height of what is drawn at the anchor (a disc, a
  // footprint): no label covers it, its own label starts just beyond it.
  cv::Size2d clearance;
};

struct PlacedLabel {
  cv::Rect2d box;             // where the label goes
  bool needs_leader = false;  // moved away from its anchor: draw a line to it
};

// `gap`: space between a label and what it avoids, and the step between
// candidate rings.
std::vector<PlacedLabel> PlaceLabels(const std::vector<LabelRequest>& labels,
                                     const cv::Rect2d& canvas,
                                     const std::vector<cv::Rect2d>& obstacles, double gap);

// The point of `box` closest to `point`: where a leader line meets a label.
cv::Point2d NearestPointOnBox(const cv::Rect2d& box, const cv::Point2d& point);

}  // namespace oslam

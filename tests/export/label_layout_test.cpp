// Label placement: crowded anchors get labels that overlap neither each
// other nor any anchor nor an obstacle, inside the canvas; a free label sits
// right beside its anchor without a leader line.
#include "export/label_layout.h"

#include <gtest/gtest.h>

namespace oslam {
namespace {

bool Overlap(const cv::Rect2d& a, const cv::Rect2d& b) {
  return (a & b).area() > 1e-9;
}

TEST(LabelLayout, CrowdedLabelsDoNotOverlap) {
  std::vector<LabelRequest> labels;
  for (int i = 0; i < 8; ++i)  // eight anchors 6 px apart, labels 60 x 12
    labels.push_back({{200.0 + 6 * i, 150.0 + 3 * (i % 2)}, {60, 12}, {3.0, 3.0}});
  const cv::Rect2d canvas(0, 0, 400, 300);
  const std::vector<cv::Rect2d> obstacles = {{0, 0, 120, 80}};
  const std::vector<PlacedLabel> placed = PlaceLabels(labels, canvas, obstacles, 3.0);
  ASSERT_EQ(placed.size(), labels.size());
  for (size_t i = 0; i < placed.size(); ++i) {
    const cv::Rect2d& box = placed[i].box;
    EXPECT_EQ((box & canvas).area(), box.area()) << i;
    EXPECT_FALSE(Overlap(box, obstacles[0])) << i;
    for (size_t j = 0; j < placed.size(); ++j) {
      if (j != i) {
        EXPECT_FALSE(Overlap(box, placed[j].box)) << i << " and " << j;
      }
      EXPECT_FALSE(box.contains(labels[j].anchor)) << "label " << i << " covers anchor " << j;
    }
  }
}

TEST(LabelLayout, FreeLabelSitsBesideItsAnchor) {
  const std::vector<PlacedLabel> placed =
      PlaceLabels({{{100, 100}, {40, 10}, {5.0, 5.0}}}, cv::Rect2d(0, 0, 300, 200), {}, 2.0);
  ASSERT_EQ(placed.size(), 1u);
  EXPECT_FALSE(placed[0].needs_leader);
  EXPECT_NEAR(placed[0].box.x, 107.0, 1e-9);        // clearance 5 + gap 2, to the right
  EXPECT_NEAR(placed[0].box.y + 5.0, 100.0, 1e-9);  // vertically centred
  // Near the right edge the label goes to the left instead.
  const std::vector<PlacedLabel> edge =
      PlaceLabels({{{290, 100}, {40, 10}, {5.0, 5.0}}}, cv::Rect2d(0, 0, 300, 200), {}, 2.0);
  EXPECT_LE(edge[0].box.x + edge[0].box.width, 300.0);
}

}  // namespace
}  // namespace oslam

// Learning class colour boxes from example regions (thesis §6.1.2: mean and
// 3 standard deviations of each YUV channel over a hand-selected ROI).
//
// examples.yaml:
//   examples:
//     - image: frames/000012.png   # relative to examples.yaml's folder
//       class: green box
//       roi: [x, y, width, height]  # pixels; or
//       mask: masks/000012_green.png  # non-zero pixels are examples
//       outline: 1                    # optional, with mask: the mask is the
//                                     # object's whole unoccluded silhouette
//                                     # (teaches its image shape too)
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"
#include "core/run_folder.h"

namespace oslam {

struct ColourExample {
  std::string image_path;
  cv::Mat image;  // in-memory image (a video's frame); overrides image_path, which names it
  std::string class_name;
  cv::Rect roi;  // used when mask_path is empty
  std::string mask_path;
  cv::Mat mask;          // in-memory mask (8-bit, non-zero = example); overrides roi and mask_path
  bool outline = false;  // the mask covers the whole, unoccluded object (image shape example)
};

// Throws oslam::Error naming the file and key (unknown class, missing image, ROI
// outside the image, ...). `classes` are the known classes.
std::vector<ColourExample> ReadColourExamples(const std::string& path,
                                              const std::vector<ObjectClass>& classes);

// Examples for a simulated run: per class, the central part of the largest
// fully visible ground-truth slice in each of `per_class` stretches of the run:
// the middle half of the slice radially and angularly (angularly at least 3 px
// of arc, 1 px inside the true edges, so a thin object still gets pixels;
// slices under 4 px wide are skipped), inside the annulus. For
// the simulator's convex shapes that region lies on the object. Only pixels
// whose hue is near the class's display colour's are kept, so a striped
// object is learnt by its main colour.
std::vector<ColourExample> ExamplesFromGroundTruth(const std::string& run_dir,
                                                   const std::vector<ObjectClass>& classes,
                                                   int per_class = 8);

// Returns `classes` with an image shape model (ObjectClass::image_shape) for
// every class with at least `min_views` usable views in a simulated run's
// ground_truth/visible_slices.csv (the pixel extent of each sighting, what an
// ideal detector reports): at least 95 % visible, 8 px long and 8 px wide;
// mean and standard deviation of their SliceElongation. Other classes keep
// theirs. Throws oslam::Error naming the file when it is missing or malformed.
std::vector<ObjectClass> LearnImageShapes(const std::vector<ObjectClass>& classes,
                                          const std::string& run_dir, int min_views = 5);

// The blob colour's standard deviation is at least this share of the colour
// box's pixel standard deviation (docs/detection.md "Verification by the blob's mean colour").
constexpr double kDefaultBlobChromaFloor = 0.25;

// Returns `classes` with what the colour detector alone (with `classes`'
// colour models) measures on the whole views (as LearnImageShapes takes them)
// of a simulated run, each matched to the class's largest blob lying mostly
// on it:
// * ImageShapeModel::arc_error_px, for every class that has an image shape
//   model and at least `min_views` matched views: the 68th percentile of
//   |blob arc width − visible arc width| (one standard deviation of a normal
//   error, robust to the few views whose blob loses a whole edge), in pixels
//   at the view's middle radius, floored at 0.5 px. The view checks then
//   know how well the detector measures the class's width.
// * ColourBox::blob_chroma, for every class with a colour box and at least
//   `min_views` matched views: mean and standard deviation of the blobs'
//   brightness-scaled mean chroma, the deviation at least
//   `blob_chroma_floor` times the box's per channel.
// Throws oslam::Error naming the file when the run is missing or malformed.
std::vector<ObjectClass> MeasureDetectorErrors(const std::vector<ObjectClass>& classes,
                                               const std::string& run_dir, int min_views = 5,
                                               double blob_chroma_floor = kDefaultBlobChromaFloor);

// The same from outline examples (ColourExample::outline, as
// LearnImageShapesFromExamples takes them): the colour detector runs on each
// example's image, and its blob is compared with the outline's slice.
std::vector<ObjectClass> MeasureDetectorErrorsFromExamples(
    const std::vector<ObjectClass>& classes, const std::vector<ColourExample>& examples,
    const CameraModel& camera, int min_views = 3,
    double blob_chroma_floor = kDefaultBlobChromaFloor);

// Returns `classes` with an image shape model for every class with at least
// `min_views` outline examples (ColourExample::outline): mean and standard
// deviation (floored at 0.05, as a few views say little about the spread) of
// the SliceElongation of each outline's pixels, as the detector measures a
// blob. Other classes keep theirs. Throws oslam::Error naming an unreadable
// mask or one of the wrong size for `camera`.
std::vector<ObjectClass> LearnImageShapesFromExamples(const std::vector<ObjectClass>& classes,
                                                      const std::vector<ColourExample>& examples,
                                                      const CameraModel& camera, int min_views = 3);

// Returns `classes` with the colour box of every class that has examples
// replaced by the learnt one (classes without examples keep theirs).
std::vector<ObjectClass> TrainColourModels(const std::vector<ObjectClass>& classes,
                                           const std::vector<ColourExample>& examples,
                                           double k_sigma);

}  // namespace oslam

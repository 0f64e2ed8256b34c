#include "detect/colour_training.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/camera_io.h"
#include "core/angles.h"
#include "core/bounding_slice.h"
#include "core/bounds.h"
#include "core/csv.h"
#include "core/error.h"
#include "core/image_file.h"
#include "core/yaml.h"
#include "detect/blob_detector.h"
#include "detect/colour_classifier.h"
#include "detect/static_mask.h"

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
    file.RequireOnlyKeys(node, key + ".", {"image", "class", "roi", "mask", "outline"});
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
      for (double value : roi) file.Within(value, key + ".roi", 0, bounds::kImageSidePx, "px");
      example.roi = cv::Rect(static_cast<int>(roi[0]), static_cast<int>(roi[1]),
                             static_cast<int>(roi[2]), static_cast<int>(roi[3]));
      if (example.roi.width <= 0 || example.roi.height <= 0)
        file.Fail(key + ".roi", "width and height must be positive");
    } else {
      example.mask_path = (base / file.String(node, "mask", key + ".")).string();
      if (!fs::is_regular_file(example.mask_path))
        file.Fail(key + ".mask", "file not found: " + example.mask_path);
    }
    if (!node["outline"].empty()) {
      const int outline = file.Int(node, "outline", key + ".");
      if (outline != 0 && outline != 1) file.Fail(key + ".outline", "must be 0 or 1");
      if (outline == 1 && has_roi)
        file.Fail(key + ".outline", "needs a mask (an ROI is no object outline)");
      example.outline = outline == 1;
    }
    examples.push_back(example);
  }
  return examples;
}

namespace {

// Keeps the mask pixels whose hue (direction of (U, V) around grey) is within
// `max_hue_difference_rad` of the class's display colour: a textured object
// (stripes, patches of a second colour) is learnt by its main colour, as a
// person picking an ROI would. Hue, not chroma distance, because a dimly lit
// object keeps its hue while its chroma shrinks towards grey.
void KeepPixelsNearDisplayHue(const cv::Mat& bgr, const ObjectClass& object_class,
                              double max_hue_difference_rad, cv::Mat* mask) {
  const auto& rgb = object_class.display_rgb;
  cv::Mat reference(1, 1, CV_8UC3, cv::Scalar(rgb[2], rgb[1], rgb[0])), reference_yuv, yuv;
  cv::cvtColor(reference, reference_yuv, cv::COLOR_BGR2YUV);
  cv::cvtColor(bgr, yuv, cv::COLOR_BGR2YUV);
  const cv::Vec3b target = reference_yuv.at<cv::Vec3b>(0, 0);
  const double target_hue = std::atan2(target[2] - 128.0, target[1] - 128.0);
  const double target_chroma = std::hypot(target[2] - 128.0, target[1] - 128.0);
  for (int y = 0; y < mask->rows; ++y)
    for (int x = 0; x < mask->cols; ++x) {
      if (!mask->at<uint8_t>(y, x)) continue;
      const cv::Vec3b& p = yuv.at<cv::Vec3b>(y, x);
      const double chroma = std::hypot(p[2] - 128.0, p[1] - 128.0);
      const double hue = std::atan2(p[2] - 128.0, p[1] - 128.0);
      // Grey pixels have no hue; a colourless class is matched by chroma alone.
      const bool keep = target_chroma < 8.0
                            ? chroma < 8.0
                            : chroma >= std::max(6.0, 0.4 * target_chroma) &&
                                  std::abs(WrapAngle(hue - target_hue)) <= max_hue_difference_rad;
      if (!keep) mask->at<uint8_t>(y, x) = 0;
    }
}

// Thinner true slices give too few example pixels, or none off the edges.
constexpr double kMinSliceWidthPx = 4.0;

cv::Mat CentralSliceMask(const CameraModel& camera, const GroundTruthSighting& s) {
  cv::Mat mask = cv::Mat::zeros(camera.image_height(), camera.image_width(), CV_8UC1);
  const double r_low = s.u_r_px + 0.25 * s.s_r_px, r_high = s.u_r_px + 0.75 * s.s_r_px;
  // The middle half angularly, but for thin objects (an 8 cm bottle is ~5 px
  // wide at 2 m) at least 3 px of arc, keeping 1 px off each true edge, so
  // they still get example pixels.
  const double radius = std::max(1.0, s.u_r_px);
  const double half_angle =
      std::max(0.25 * s.s_phi_rad, std::min(0.5 * s.s_phi_rad - 1.0 / radius, 1.5 / radius));
  for (int y = 0; y < mask.rows; ++y)
    for (int x = 0; x < mask.cols; ++x) {
      const Eigen::Vector2d pixel(x, y);
      const PolarPoint p = camera.PixelToPolar(pixel);
      if (p.radius_px >= r_low && p.radius_px <= r_high &&
          std::abs(WrapAngle(p.angle_rad - s.u_phi_rad)) <= half_angle && camera.IsInAnnulus(pixel))
        mask.at<uint8_t>(y, x) = 255;
    }
  return mask;
}

// `classes` with an image shape model (mean, standard deviation floored at
// `min_std`) for every class with at least `min_views` elongations.
std::vector<ObjectClass> WithShapeModels(const std::vector<ObjectClass>& classes,
                                         const std::vector<std::vector<double>>& elongations,
                                         int min_views, double min_std) {
  std::vector<ObjectClass> learnt = classes;
  for (size_t c = 0; c < classes.size(); ++c) {
    const std::vector<double>& values = elongations[c];
    if (static_cast<int>(values.size()) < std::max(2, min_views)) continue;
    double sum = 0, sum_squares = 0;
    for (double e : values) sum += e;
    const double mean = sum / values.size();
    for (double e : values) sum_squares += (e - mean) * (e - mean);
    ImageShapeModel model;
    model.elongation_mean = mean;
    model.elongation_std = std::max(min_std, std::sqrt(sum_squares / (values.size() - 1)));
    learnt[c].image_shape = model;
  }
  return learnt;
}

}  // namespace

std::vector<ColourExample> ExamplesFromGroundTruth(const std::string& run_dir,
                                                   const std::vector<ObjectClass>& classes,
                                                   int per_class) {
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  const std::optional<GroundTruth> truth = ReadGroundTruth(run_dir);
  if (!truth) throw Error::InFile(run_dir, "no ground_truth/ folder to learn colours from");
  const std::unique_ptr<CameraModel> camera = LoadCamera(paths.camera);
  const FrameSource frames(run_dir);
  // The rig's pixels (RUN/mask.png, detect/static_mask.h) are no object's.
  cv::Mat rig_mask;
  if (std::filesystem::exists(paths.mask))
    rig_mask = ReadStaticMask(paths.mask, camera->image_width(), camera->image_height());
  std::vector<ColourExample> examples;
  for (const ObjectClass& object_class : classes) {
    std::vector<const GroundTruthSighting*> candidates;
    for (const GroundTruthSighting& s : truth->sightings) {
      const auto object = std::find_if(truth->objects.begin(), truth->objects.end(),
                                       [&](const auto& o) { return o.id == s.object_id; });
      if (object->class_name != object_class.name || s.visible_fraction < 0.95) continue;
      if (s.s_r_px < 8 || s.s_phi_rad * s.u_r_px < kMinSliceWidthPx ||
          s.frame >= static_cast<long>(frames.size()))
        continue;
      candidates.push_back(&s);
    }
    // One example from each of `per_class` stretches of the run, the largest
    // usable view in each: the lighting along the path (a dark corridor, a
    // bright window) then shows in the learnt spread, as it would when a person
    // picks examples across a whole recording.
    std::sort(candidates.begin(), candidates.end(),
              [](const auto* a, const auto* b) { return a->frame < b->frame; });
    const size_t segments = std::min<size_t>(per_class, candidates.size());
    for (size_t segment = 0; segment < segments; ++segment) {
      std::vector<const GroundTruthSighting*> stretch(
          candidates.begin() + segment * candidates.size() / segments,
          candidates.begin() + (segment + 1) * candidates.size() / segments);
      std::sort(stretch.begin(), stretch.end(), [](const auto* a, const auto* b) {
        return a->s_r_px * a->s_phi_rad * a->u_r_px > b->s_r_px * b->s_phi_rad * b->u_r_px;
      });
      for (const GroundTruthSighting* s : stretch) {
        cv::Mat mask = CentralSliceMask(*camera, *s);
        const cv::Mat frame = frames.Read(static_cast<size_t>(s->frame));
        KeepPixelsNearDisplayHue(frame, object_class, DegToRad(25.0), &mask);
        if (!rig_mask.empty()) mask.setTo(0, rig_mask == 0);
        if (cv::countNonZero(mask) < 8) continue;  // mostly beyond the rim or another colour
        ColourExample example;
        example.image_path = frames.Name(static_cast<size_t>(s->frame));
        if (frames.is_video()) example.image = frame;
        example.class_name = object_class.name;
        example.mask = mask;
        examples.push_back(example);
        break;
      }
    }
  }
  return examples;
}

namespace {

// A whole view of an object of a trained class in a simulated run.
struct TrueView {
  long frame = 0;
  int class_index = 0;
  BoundingSlice slice;
};

// Whole views this long and wide (px) teach an image shape and the arc
// error; narrower ones still teach a blob's colour.
constexpr double kMinShapeViewPx = 8.0;
constexpr double kMinColourViewPx = 3.0;

bool ShapeSized(const BoundingSlice& slice) {
  return slice.s_r_px >= kMinShapeViewPx && SliceArcWidth(slice) >= kMinShapeViewPx;
}

// The views of ground_truth/visible_slices.csv that show an object of one of
// `classes` whole: at least 95 % visible, `min_extent_px` long and wide.
std::vector<TrueView> WholeTrueViews(const std::vector<ObjectClass>& classes,
                                     const std::string& run_dir,
                                     double min_extent_px = kMinShapeViewPx) {
  const std::optional<GroundTruth> truth = ReadGroundTruth(run_dir);
  if (!truth) throw Error::InFile(run_dir, "no ground_truth/ folder to learn image shapes from");
  const CsvTable views = CsvTable::Read(
      (std::filesystem::path(run_dir) / "ground_truth" / "visible_slices.csv").string());
  const int frame_column = views.ColumnIndex("frame"),
            object_column = views.ColumnIndex("object_id"),
            visible_column = views.ColumnIndex("visible_px"),
            footprint_column = views.ColumnIndex("footprint_px"),
            u_r_column = views.ColumnIndex("u_r_px"), u_phi_column = views.ColumnIndex("u_phi_rad"),
            s_r_column = views.ColumnIndex("s_r_px"), s_phi_column = views.ColumnIndex("s_phi_rad");
  std::vector<TrueView> whole;
  for (size_t row = 0; row < views.num_rows(); ++row) {
    const long object_id = views.Integer(row, object_column);
    const auto object = std::find_if(truth->objects.begin(), truth->objects.end(),
                                     [&](const auto& o) { return o.id == object_id; });
    if (object == truth->objects.end())
      throw Error::AtLine(views.path(), views.line_of_row(row),
                          "object " + std::to_string(object_id) + " is not in objects.csv");
    const int class_index = FindClass(classes, object->class_name);
    if (class_index < 0) continue;  // a distractor or a class not being trained
    if (views.Double(row, visible_column) < 0.95 * views.Double(row, footprint_column)) continue;
    const BoundingSlice slice{views.Double(row, u_r_column), views.Double(row, u_phi_column),
                              views.Double(row, s_r_column), views.Double(row, s_phi_column)};
    if (slice.s_r_px < min_extent_px || SliceArcWidth(slice) < min_extent_px) continue;
    whole.push_back({views.Integer(row, frame_column), class_index, slice});
  }
  return whole;
}

}  // namespace

std::vector<ObjectClass> LearnImageShapes(const std::vector<ObjectClass>& classes,
                                          const std::string& run_dir, int min_views) {
  std::vector<std::vector<double>> elongations(classes.size());
  for (const TrueView& view : WholeTrueViews(classes, run_dir))
    elongations[view.class_index].push_back(SliceElongation(view.slice));
  // A floor: a rigid object's views vary at least this much with where it stands.
  return WithShapeModels(classes, elongations, min_views, 0.02);
}

namespace {

// The colour detector alone, before any check: the blobs whose widths the
// view checks must allow for.
BlobDetector ColourOnlyDetector(const CameraModel& camera,
                                const std::vector<ObjectClass>& classes) {
  BlobDetectorOptions colour_only;
  colour_only.separate_look_alikes = false;
  colour_only.max_view_distance = std::numeric_limits<double>::infinity();
  colour_only.max_blob_colour_distance = std::numeric_limits<double>::infinity();
  return BlobDetector(camera, classes, colour_only);
}

// Per class, the detector's blobs against known views: their arc-width errors
// and their mean colours.
class DetectorErrors {
 public:
  explicit DetectorErrors(size_t num_classes) : errors_(num_classes), chroma_(num_classes) {}

  // The class's largest blob of `found` lying mostly on `view` (as eval-detect
  // matches a sighting), if any: its arc width less the view's, in pixels at
  // the view's middle radius (when `arc_too`), and its mean chroma at the
  // class's brightness.
  void Add(const std::vector<Detection>& found, const std::vector<ObjectClass>& classes,
           int class_index, const BoundingSlice& view, bool arc_too) {
    const Detection* largest = nullptr;
    for (const Detection& d : found)
      if (d.class_index == class_index && SliceCoverage(d.slice, view) >= 0.5 &&
          (!largest || d.area_px > largest->area_px))
        largest = &d;
    if (!largest) return;
    const double middle_radius = view.u_r_px + 0.5 * view.s_r_px;
    if (arc_too)
      errors_[class_index].push_back((largest->slice.s_phi_rad - view.s_phi_rad) * middle_radius);
    const std::optional<ColourBox>& box = classes[class_index].colour;
    if (box)
      chroma_[class_index].push_back(ChromaAtBrightness(largest->mean_yuv, box->yuv_mean[0]));
  }

  // `classes` with
  // * arc_error_px for every class with a shape model and at least min_views
  //   errors: the 68th percentile of |error| (one standard deviation of a
  //   normal error; a textured object's few views that lose a whole edge
  //   would inflate a root mean square several times), at least 0.5 px (the
  //   blob's edges are whole pixels);
  // * the blob chroma of every class with a colour box and at least min_views
  //   blobs: mean and standard deviation, the latter at least
  //   `blob_chroma_floor` times the box's (one lighting in training says
  //   little about the next room's).
  std::vector<ObjectClass> Apply(const std::vector<ObjectClass>& classes, int min_views,
                                 double blob_chroma_floor) const {
    std::vector<ObjectClass> measured = classes;
    for (size_t c = 0; c < classes.size(); ++c) {
      const size_t needed = static_cast<size_t>(std::max(2, min_views));
      const std::vector<double>& e = errors_[c];
      if (measured[c].image_shape && e.size() >= needed) {
        std::vector<double> size(e.size());
        for (size_t k = 0; k < e.size(); ++k) size[k] = std::abs(e[k]);
        const size_t rank = static_cast<size_t>(0.68 * (size.size() - 1));
        std::nth_element(size.begin(), size.begin() + rank, size.end());
        measured[c].image_shape->arc_error_px = std::max(0.5, size[rank]);
      }
      const std::vector<std::array<double, 2>>& chroma = chroma_[c];
      if (measured[c].colour && chroma.size() >= needed) {
        BlobChroma blob;
        for (int ch = 0; ch < 2; ++ch) {
          double sum = 0, sum_sq = 0;
          for (const auto& value : chroma) sum += value[ch];
          blob.mean[ch] = sum / chroma.size();
          for (const auto& value : chroma) sum_sq += std::pow(value[ch] - blob.mean[ch], 2);
          const double pixel_std = std::max(1.0, measured[c].colour->yuv_std[ch + 1]);
          blob.std[ch] =
              std::max(std::sqrt(sum_sq / (chroma.size() - 1)), blob_chroma_floor * pixel_std);
        }
        measured[c].colour->blob_chroma = blob;
      }
    }
    return measured;
  }

 private:
  std::vector<std::vector<double>> errors_;
  std::vector<std::vector<std::array<double, 2>>> chroma_;
};

// The slice of an outline example's mask (read when not in memory); nullopt
// for an empty mask. Throws naming the mask when its size is not the camera's.
std::optional<BoundingSlice> OutlineSlice(const ColourExample& example, const CameraModel& camera) {
  const cv::Mat mask =
      example.mask.empty() ? ReadImage(example.mask_path, ImageColour::kGray) : example.mask;
  if (mask.cols != camera.image_width() || mask.rows != camera.image_height())
    throw Error::InFile(example.mask_path.empty() ? example.image_path : example.mask_path,
                        "outline mask size differs from the camera's image size");
  std::vector<double> radii, angles;
  for (int y = 0; y < mask.rows; ++y)
    for (int x = 0; x < mask.cols; ++x) {
      if (mask.at<uint8_t>(y, x) == 0) continue;
      const PolarPoint polar = camera.PixelToPolar(Eigen::Vector2d(x, y));
      radii.push_back(polar.radius_px);
      angles.push_back(polar.angle_rad);
    }
  if (radii.empty()) return std::nullopt;
  return SliceOfPixelCentres(radii, angles);
}

}  // namespace

std::vector<ObjectClass> MeasureDetectorErrors(const std::vector<ObjectClass>& classes,
                                               const std::string& run_dir, int min_views,
                                               double blob_chroma_floor) {
  std::map<long, std::vector<TrueView>> views_by_frame;
  for (const TrueView& view : WholeTrueViews(classes, run_dir, kMinColourViewPx))
    views_by_frame[view.frame].push_back(view);
  const std::unique_ptr<CameraModel> camera =
      LoadCamera((fs::path(run_dir) / "camera.yaml").string());
  const BlobDetector detector = ColourOnlyDetector(*camera, classes);
  const FrameSource frames(run_dir);
  DetectorErrors errors(classes.size());
  for (const auto& [frame, views] : views_by_frame) {
    if (frame < 0 || static_cast<size_t>(frame) >= frames.size())
      throw Error::InFile(run_dir, "ground_truth/visible_slices.csv names frame " +
                                       std::to_string(frame) + ", which the run does not have");
    const std::vector<Detection> found = detector.Detect(frames.Read(frame), frame);
    for (const TrueView& view : views)
      errors.Add(found, classes, view.class_index, view.slice, ShapeSized(view.slice));
  }
  return errors.Apply(classes, min_views, blob_chroma_floor);
}

std::vector<ObjectClass> MeasureDetectorErrorsFromExamples(
    const std::vector<ObjectClass>& classes, const std::vector<ColourExample>& examples,
    const CameraModel& camera, int min_views, double blob_chroma_floor) {
  const BlobDetector detector = ColourOnlyDetector(camera, classes);
  DetectorErrors errors(classes.size());
  for (const ColourExample& example : examples) {
    if (!example.outline) continue;
    const int class_index = FindClass(classes, example.class_name);
    if (class_index < 0) continue;
    const std::optional<BoundingSlice> view = OutlineSlice(example, camera);
    if (!view) continue;
    const cv::Mat image = ReadImage(example.image_path);
    errors.Add(detector.Detect(image, 0), classes, class_index, *view, true);
  }
  return errors.Apply(classes, min_views, blob_chroma_floor);
}

std::vector<ObjectClass> LearnImageShapesFromExamples(const std::vector<ObjectClass>& classes,
                                                      const std::vector<ColourExample>& examples,
                                                      const CameraModel& camera, int min_views) {
  std::vector<std::vector<double>> elongations(classes.size());
  for (const ColourExample& example : examples) {
    if (!example.outline) continue;
    const int class_index = FindClass(classes, example.class_name);
    if (class_index < 0) continue;
    const std::optional<BoundingSlice> view = OutlineSlice(example, camera);
    if (view) elongations[class_index].push_back(SliceElongation(*view));
  }
  return WithShapeModels(classes, elongations, min_views, 0.05);
}

std::vector<ObjectClass> TrainColourModels(const std::vector<ObjectClass>& classes,
                                           const std::vector<ColourExample>& examples,
                                           double k_sigma) {
  std::vector<ObjectClass> trained = classes;
  for (size_t c = 0; c < classes.size(); ++c) {
    std::vector<cv::Mat> images, masks;
    for (const ColourExample& example : examples) {
      if (example.class_name != classes[c].name) continue;
      cv::Mat image = example.image.empty() ? ReadImage(example.image_path) : example.image;
      cv::Mat mask;
      if (!example.mask.empty()) {
        mask = example.mask;
      } else if (example.mask_path.empty()) {
        if ((example.roi & cv::Rect(0, 0, image.cols, image.rows)) != example.roi)
          throw Error::InFile(example.image_path, "ROI lies outside the image");
        mask = cv::Mat::zeros(image.size(), CV_8UC1);
        mask(example.roi).setTo(255);
      } else {
        mask = ReadImage(example.mask_path, ImageColour::kGray);
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

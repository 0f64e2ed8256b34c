#include "pipeline/calibration_flow.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "calib/mei_camera.h"
#include "calib/rim_detection.h"
#include "core/error.h"
#include "core/image_file.h"
#include "core/text.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> ListImages(const std::string& dir) {
  if (!fs::is_directory(dir)) throw Error::InFile(dir, "not a directory");
  std::vector<fs::path> images;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (entry.is_regular_file() &&
        (ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".bmp" || ext == ".tif" ||
         ext == ".tiff" || ext == ".pgm" || ext == ".ppm"))
      images.push_back(entry.path());
  }
  std::sort(images.begin(), images.end());
  if (images.empty()) throw Error::InFile(dir, "no images (.jpg .png .bmp .tif .pgm .ppm)");
  return images;
}

// The views with their corners, and the grey images (one size).
struct Views {
  std::vector<CalibrationView> views;
  std::vector<cv::Mat> images;
  int width = 0, height = 0;
  double seconds = 0;
};

Views DetectCorners(const std::string& images_dir, const BoardPattern& pattern, bool subpix,
                    const StageOutput& output) {
  CornerDetectionOptions corner_options;
  corner_options.refine_with_corner_subpix = subpix;
  Views result;
  const auto start = std::chrono::steady_clock::now();
  for (const auto& path : ListImages(images_dir)) {
    cv::Mat image = ReadImage(path.string(), ImageColour::kGray);
    if (result.width == 0) {
      result.width = image.cols;
      result.height = image.rows;
    } else if (image.cols != result.width || image.rows != result.height) {
      throw Error::InFile(path.string(), "image is " + std::to_string(image.cols) + "x" +
                                             std::to_string(image.rows) + ", the first one " +
                                             std::to_string(result.width) + "x" +
                                             std::to_string(result.height));
    }
    CalibrationView view;
    view.name = path.filename().string();
    view.board_found = DetectBoardCorners(image, pattern, corner_options, &view.corners);
    output.Print(Format("corners: %-24s %s", view.name.c_str(),
                        view.board_found ? "board found" : "BOARD NOT FOUND (view not used)"));
    result.views.push_back(std::move(view));
    result.images.push_back(image);
  }
  result.seconds = SecondsSince(start);
  return result;
}

void ReportResult(const CalibrationResult& result, double corner_seconds,
                  const StageOutput& output) {
  output.Print(result.summary.BriefReport());
  output.Print(Format("corner detection %.2f s", corner_seconds));
  for (size_t i = 0; i < result.parameter_names.size(); ++i)
    output.Print(Format("  %-14s %14.6g +- %.3g", result.parameter_names[i].c_str(),
                        result.parameters[i], result.standard_deviations[i]));
  for (const CalibrationView& view : result.views) {
    if (view.board_found)
      output.Print(Format("  view %-24s RMS %.4f px%s", view.name.c_str(), view.rms_px,
                          view.outlier ? "  OUTLIER (kept; check the PNG)" : ""));
    else
      output.Print(Format("  view %-24s not used: board not found", view.name.c_str()));
  }
}

std::string MeiRow(const char* label, const MeiParameters& p, double rms,
                   const std::string& views) {
  return Format("%-22s %7.4f %8.2f %8.2f %8.2f %8.2f %9.5f %9.5f %9.5f %9.5f  %.4f  %s", label,
                p.xi, p.fx_px, p.fy_px, p.cx_px, p.cy_px, p.k1, p.k2, p.p1, p.p2, rms,
                views.c_str());
}

bool Uses(const OpenCvOmnidirResult& result, size_t view) {
  return std::find(result.used_views.begin(), result.used_views.end(), static_cast<int>(view)) !=
         result.used_views.end();
}

// cv::omnidir::calibrate on the same corners, beside ours: on all views,
// ours on cv::omnidir's views, and cv::omnidir's intrinsics on all views.
void CompareWithOpenCv(const Views& input, const BoardPattern& pattern,
                       const CalibrationOptions& options, const CalibrationResult& result,
                       const StageOutput& output) {
  // A report like the rest of the stage's: nothing under --quiet.
  const auto print = [&](const std::string& line) { output.Print(line); };
  const std::vector<CalibrationView>& views = input.views;
  const OpenCvOmnidirResult cv_result =
      CalibrateWithOpenCvOmnidir(views, pattern, input.width, input.height, true);
  if (!cv_result.ok) {
    output.Warn("cv::omnidir::calibrate failed: " + cv_result.error);
    return;
  }
  int found = 0;
  for (const auto& view : views) found += view.board_found;
  print(Format("\n%-22s %7s %8s %8s %8s %8s %9s %9s %9s %9s  %-6s  %s", "", "xi", "fx", "fy", "cx",
               "cy", "k1", "k2", "p1", "p2", "RMS", "views"));
  const std::string all = "/" + std::to_string(found);
  if (const auto* mei = dynamic_cast<const MeiCamera*>(result.camera.get()))
    print(MeiRow("oslam (mei)", mei->parameters(), result.summary.final_rms_px,
                 std::to_string(result.summary.views_used) + all + ", " +
                     std::to_string(result.summary.seconds).substr(0, 5) + " s"));
  else
    print(Format("%-22s RMS %.4f px (hyperbolic model, %d/%d views)", "oslam (hyperbolic)",
                 result.summary.final_rms_px, result.summary.views_used, found));
  print(MeiRow("cv::omnidir", cv_result.parameters, cv_result.rms_px,
               std::to_string(cv_result.used_views.size()) + all + ", " +
                   std::to_string(cv_result.seconds).substr(0, 5) + " s"));
  if (static_cast<int>(cv_result.used_views.size()) < found) {
    std::vector<CalibrationView> subset = views;
    for (size_t v = 0; v < subset.size(); ++v)
      if (!Uses(cv_result, v)) subset[v].board_found = false;
    CalibrationOptions mei_options = options;
    mei_options.model = "mei";
    const CalibrationResult same =
        CalibrateFromCorners(subset, pattern, input.width, input.height, mei_options);
    if (const auto* mei = dynamic_cast<const MeiCamera*>(same.camera.get()))
      print(MeiRow("oslam, omnidir's views", mei->parameters(), same.summary.final_rms_px,
                   std::to_string(same.summary.views_used) + all));
  }
  MeiCamera omnidir(cv_result.parameters, input.width, input.height, {0, 1});
  print(Format("cv::omnidir's intrinsics on all %d views (poses re-fitted): RMS %.4f px", found,
               MeiRmsWithFixedIntrinsics(omnidir, views, pattern)));
  for (size_t v = 0; v < views.size(); ++v)
    if (views[v].board_found && !Uses(cv_result, v))
      print("cv::omnidir dropped view " + views[v].name);
}

// The camera remounted at the height and yaw the floor board shows.
std::unique_ptr<CameraModel> MountFromFloorBoard(const CameraModel& camera,
                                                 const BoardPattern& boards,
                                                 const CalibrationFlowOptions& flow,
                                                 const StageOutput& output) {
  BoardPattern pattern = boards;
  if (flow.floor_board_pattern.cols > 0) {
    pattern.cols = flow.floor_board_pattern.cols;
    pattern.rows = flow.floor_board_pattern.rows;
  }
  if (flow.floor_board_pattern.square_m > 0) pattern.square_m = flow.floor_board_pattern.square_m;
  const cv::Mat image = ReadImage(flow.floor_board_image, ImageColour::kGray);
  if (image.cols != camera.image_width() || image.rows != camera.image_height())
    throw Error::InFile(flow.floor_board_image, "image is " + std::to_string(image.cols) + "x" +
                                                    std::to_string(image.rows) + ", the boards " +
                                                    std::to_string(camera.image_width()) + "x" +
                                                    std::to_string(camera.image_height()));
  Corners corners;
  if (!DetectBoardCorners(image, pattern, CornerDetectionOptions(), &corners))
    throw Error::InFile(flow.floor_board_image,
                        "no " + std::to_string(pattern.cols) + "x" + std::to_string(pattern.rows) +
                            " checkerboard found (the whole board must be visible)");
  MountEstimate mount;
  try {
    mount = EstimateMountFromFloorBoard(camera, corners, pattern, flow.floor_board);
  } catch (const Error& e) {
    throw Error::InFile(flow.floor_board_image, e.what());
  }
  std::unique_ptr<CameraModel> mounted =
      WithMount(camera, mount.focus_height_m, mount.yaw_change_rad, mount.mirrored);
  output.Print(
      Format("mount: focus height %.4f m, yaw %.4f rad from the floor board (%d corners, "
             "RMS %.1f mm on the floor, %.2f px in the image)",
             mount.focus_height_m, mount.yaw_change_rad, mount.corners, 1000.0 * mount.floor_rms_m,
             mount.image_rms_px));
  return mounted;
}

}  // namespace

CalibrationResult CalibrateFromImages(const std::string& images_dir, const BoardPattern& pattern,
                                      const CalibrationFlowOptions& flow,
                                      const StageOutput& output) {
  std::string why;
  if (!flow.Validate(&why)) throw Error("calibration: " + why);
  if (!flow.report_dir.empty()) fs::create_directories(flow.report_dir);
  CalibrationOptions options = flow.calibration;
  if (!flow.floor_board_image.empty()) {
    // Calibrated unmounted (1 m, yaw 0); the floor board sets the mount.
    options.focus_height_m = 1.0;
    options.mount_yaw_rad = 0.0;
  }

  const Views input = DetectCorners(images_dir, pattern, flow.refine_with_corner_subpix, output);

  // The mirror rim and blind disc (also the initial image centre).
  MirrorAnnulus annulus;
  bool have_rim = false;
  if (flow.detect_rim) {
    const RimDetectionResult rim = DetectMirrorRim(input.images, RimDetectionOptions());
    if (rim.found) {
      have_rim = true;
      annulus = rim.annulus;
      options.initial_cx_px = rim.center_px.x();
      options.initial_cy_px = rim.center_px.y();
      output.Print(
          Format("mirror rim: centre (%.2f, %.2f) px, rim radius %.1f px (%d inliers), blind disc "
                 "%.1f px (%d inliers)",
                 rim.center_px.x(), rim.center_px.y(), rim.annulus.rim_radius_px, rim.rim_inliers,
                 rim.annulus.blind_radius_px, rim.blind_inliers));
    } else {
      output.Print("mirror rim: not found (" + rim.message + "); annulus = whole image");
    }
  }

  output.Print("calibrating the " + options.model + " model...");
  CalibrationResult result =
      CalibrateFromCorners(input.views, pattern, input.width, input.height, options);
  if (have_rim) {
    // The blind disc / rim were measured around the rim centre; re-express them
    // around the calibrated centre conservatively.
    const double shift = (result.camera->ImageCenter() -
                          Eigen::Vector2d(options.initial_cx_px, options.initial_cy_px))
                             .norm();
    result.camera->set_annulus(
        {annulus.blind_radius_px + shift,
         std::max(annulus.blind_radius_px + shift + 1.0, annulus.rim_radius_px - shift)});
  }
  ReportResult(result, input.seconds, output);
  if (!flow.floor_board_image.empty())
    result.camera = MountFromFloorBoard(*result.camera, pattern, flow, output);
  if (flow.compare_opencv) CompareWithOpenCv(input, pattern, options, result, output);

  if (!flow.report_dir.empty()) {
    for (size_t v = 0; v < result.views.size(); ++v)
      WriteViewReportImage(input.images[v], result.views[v],
                           (fs::path(flow.report_dir) /
                            (fs::path(result.views[v].name).stem().string() + "_corners.png"))
                               .string());
    output.Print(
        Format("wrote %zu view images to %s", result.views.size(), flow.report_dir.c_str()));
  }
  return result;
}

}  // namespace oslam

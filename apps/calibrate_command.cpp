// oslam calibrate: intrinsic calibration of a catadioptric camera from a
// folder of checkerboard images (see docs/calibration.md).
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <opencv2/imgcodecs.hpp>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "calib/calibration.h"
#include "calib/camera_io.h"
#include "calib/mei_camera.h"
#include "calib/rim_detection.h"
#include "core/error.h"

namespace oslam {

namespace {

BoardPattern ParsePattern(const std::string& text, double square_m) {
  BoardPattern pattern;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &pattern.cols, &x, &pattern.rows, &extra) != 3 ||
      (x != 'x' && x != 'X') || pattern.cols < 2 || pattern.rows < 2)
    throw UsageError("--pattern expects COLSxROWS inner corners (e.g. 7x6), got '" + text + "'");
  if (!(square_m > 0) || square_m > 10)
    throw UsageError("--square expects the square size in metres (e.g. 0.03)");
  pattern.square_m = square_m;
  return pattern;
}

std::vector<std::filesystem::path> ListImages(const std::string& dir) {
  if (!std::filesystem::is_directory(dir)) throw Error::InFile(dir, "not a directory");
  std::vector<std::filesystem::path> images;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
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

void PrintMeiRow(const char* label, const MeiParameters& p, double rms, const std::string& views) {
  std::printf("%-22s %7.4f %8.2f %8.2f %8.2f %8.2f %9.5f %9.5f %9.5f %9.5f  %.4f  %s\n", label,
              p.xi, p.fx_px, p.fy_px, p.cx_px, p.cy_px, p.k1, p.k2, p.p1, p.p2, rms, views.c_str());
}

}  // namespace

int RunCalibrateCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam calibrate IMAGES_DIR --pattern COLSxROWS --square METRES [--model mei|hyperbolic] "
      "[--compare-opencv] [--report-dir DIR] -o CAMERA.yaml",
      "Calibrates a catadioptric camera from checkerboard images: corners on the raw images,\n"
      "Levenberg-Marquardt over intrinsics and board poses, every found board used, outlier\n"
      "views reported. Writes camera.yaml (mirror axis vertical at --focus-height).");
  arguments.AddPositional("IMAGES_DIR", "folder of checkerboard images (sorted by name)");
  arguments.AddOption("pattern", "", "COLSxROWS", "inner corners of the checkerboard, e.g. 7x6");
  arguments.AddOption("square", "", "METRES", "side of one square in metres, e.g. 0.03");
  arguments.AddOption("model", "", "NAME", "mei (unified model, like cv::omnidir) or hyperbolic",
                      "mei");
  arguments.AddOption("focus-height", "", "METRES", "mirror viewpoint height above the floor",
                      "1.0");
  arguments.AddOption("mirror-a", "", "METRES", "hyperbolic: mirror a (scale only)", "0.03929");
  arguments.AddOption("mirror-b", "", "METRES",
                      "hyperbolic: mirror b from a data sheet (default: estimated)");
  arguments.AddOption("report-dir", "", "DIR",
                      "write one PNG per view (corners and reprojections)");
  arguments.AddOption("output", "-o", "CAMERA.yaml", "write the calibrated camera here");
  arguments.AddFlag("compare-opencv", "also run cv::omnidir::calibrate on the same corners");
  arguments.AddFlag("subpix", "also refine corners with cv::cornerSubPix (worse on our sets)");
  arguments.AddFlag("no-rim", "do not detect the mirror rim / blind disc for the annulus");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("pattern")) throw UsageError("missing --pattern COLSxROWS");
  if (!arguments.Has("square")) throw UsageError("missing --square METRES");
  if (!arguments.Has("output")) throw UsageError("missing -o CAMERA.yaml");
  const BoardPattern pattern =
      ParsePattern(arguments.Get("pattern"), arguments.GetDouble("square"));
  CalibrationOptions options;
  options.model = arguments.Get("model");
  options.focus_height_m = arguments.GetDouble("focus-height");
  options.mirror_a_m = arguments.GetDouble("mirror-a");
  if (arguments.Has("mirror-b")) options.mirror_b_m = arguments.GetDouble("mirror-b");
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);
  const bool quiet = arguments.Flag("quiet");
  const std::string report_dir = arguments.Get("report-dir");
  if (!report_dir.empty()) std::filesystem::create_directories(report_dir);

  // 1. Corners.
  const std::vector<std::filesystem::path> paths = ListImages(arguments.Get("IMAGES_DIR"));
  CornerDetectionOptions corner_options;
  corner_options.refine_with_corner_subpix = arguments.Flag("subpix");
  std::vector<CalibrationView> views;
  std::vector<cv::Mat> images;
  int width = 0, height = 0;
  const auto start = std::chrono::steady_clock::now();
  for (const auto& path : paths) {
    cv::Mat image = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
    if (image.empty()) throw Error::InFile(path.string(), "cannot read image");
    if (width == 0) {
      width = image.cols;
      height = image.rows;
    } else if (image.cols != width || image.rows != height) {
      throw Error::InFile(path.string(), "image is " + std::to_string(image.cols) + "x" +
                                             std::to_string(image.rows) + ", the first one " +
                                             std::to_string(width) + "x" + std::to_string(height));
    }
    CalibrationView view;
    view.name = path.filename().string();
    view.board_found = DetectBoardCorners(image, pattern, corner_options, &view.corners);
    if (!quiet)
      std::printf("corners: %-24s %s\n", view.name.c_str(),
                  view.board_found ? "board found" : "BOARD NOT FOUND (view not used)");
    views.push_back(std::move(view));
    images.push_back(image);
  }
  const double corner_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // 2. Mirror rim and blind disc (also the initial image centre).
  MirrorAnnulus annulus;
  bool have_rim = false;
  if (!arguments.Flag("no-rim")) {
    RimDetectionOptions rim_options;
    RimDetectionResult rim = DetectMirrorRim(images, rim_options);
    if (rim.found) {
      have_rim = true;
      annulus = rim.annulus;
      options.initial_cx_px = rim.center_px.x();
      options.initial_cy_px = rim.center_px.y();
      if (!quiet)
        std::printf(
            "mirror rim: centre (%.2f, %.2f) px, rim radius %.1f px (%d inliers), blind disc "
            "%.1f px (%d inliers)\n",
            rim.center_px.x(), rim.center_px.y(), rim.annulus.rim_radius_px, rim.rim_inliers,
            rim.annulus.blind_radius_px, rim.blind_inliers);
    } else if (!quiet) {
      std::printf("mirror rim: not found (%s); annulus = whole image\n", rim.message.c_str());
    }
  }

  // 3. Calibration.
  if (!quiet) std::printf("calibrating the %s model...\n", options.model.c_str());
  CalibrationResult result = CalibrateFromCorners(views, pattern, width, height, options);
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
  if (!quiet) {
    std::printf("%s\n", result.summary.BriefReport().c_str());
    std::printf("corner detection %.2f s\n", corner_seconds);
    for (size_t i = 0; i < result.parameter_names.size(); ++i)
      std::printf("  %-14s %14.6g +- %.3g\n", result.parameter_names[i].c_str(),
                  result.parameters[i], result.standard_deviations[i]);
    for (const CalibrationView& view : result.views) {
      if (view.board_found)
        std::printf("  view %-24s RMS %.4f px%s\n", view.name.c_str(), view.rms_px,
                    view.outlier ? "  OUTLIER (kept; check the PNG)" : "");
      else
        std::printf("  view %-24s not used: board not found\n", view.name.c_str());
    }
  }

  // 4. cv::omnidir on the same corners.
  if (arguments.Flag("compare-opencv")) {
    const OpenCvOmnidirResult cv_result =
        CalibrateWithOpenCvOmnidir(views, pattern, width, height, true);
    if (!cv_result.ok) {
      std::printf("cv::omnidir::calibrate failed: %s\n", cv_result.error.c_str());
    } else {
      int found = 0;
      for (const auto& view : views) found += view.board_found;
      std::printf("\n%-22s %7s %8s %8s %8s %8s %9s %9s %9s %9s  %-6s  %s\n", "", "xi", "fx", "fy",
                  "cx", "cy", "k1", "k2", "p1", "p2", "RMS", "views");
      if (const auto* mei = dynamic_cast<const MeiCamera*>(result.camera.get()))
        PrintMeiRow("oslam (mei)", mei->parameters(), result.summary.final_rms_px,
                    std::to_string(result.summary.views_used) + "/" + std::to_string(found) + ", " +
                        std::to_string(result.summary.seconds).substr(0, 5) + " s");
      else
        std::printf("%-22s RMS %.4f px (hyperbolic model, %d/%d views)\n", "oslam (hyperbolic)",
                    result.summary.final_rms_px, result.summary.views_used, found);
      PrintMeiRow("cv::omnidir", cv_result.parameters, cv_result.rms_px,
                  std::to_string(cv_result.used_views.size()) + "/" + std::to_string(found) + ", " +
                      std::to_string(cv_result.seconds).substr(0, 5) + " s");
      // Same views as cv::omnidir, and cv::omnidir's intrinsics on every view.
      std::vector<CalibrationView> subset = views;
      for (size_t v = 0; v < subset.size(); ++v)
        if (std::find(cv_result.used_views.begin(), cv_result.used_views.end(),
                      static_cast<int>(v)) == cv_result.used_views.end())
          subset[v].board_found = false;
      if (static_cast<int>(cv_result.used_views.size()) < found) {
        CalibrationOptions mei_options = options;
        mei_options.model = "mei";
        const CalibrationResult same =
            CalibrateFromCorners(subset, pattern, width, height, mei_options);
        if (const auto* mei = dynamic_cast<const MeiCamera*>(same.camera.get()))
          PrintMeiRow("oslam, omnidir's views", mei->parameters(), same.summary.final_rms_px,
                      std::to_string(same.summary.views_used) + "/" + std::to_string(found));
      }
      MeiCamera omnidir(cv_result.parameters, width, height, {0, 1});
      std::printf("cv::omnidir's intrinsics on all %d views (poses re-fitted): RMS %.4f px\n",
                  found, MeiRmsWithFixedIntrinsics(omnidir, views, pattern));
      for (size_t v = 0; v < views.size(); ++v)
        if (views[v].board_found &&
            std::find(cv_result.used_views.begin(), cv_result.used_views.end(),
                      static_cast<int>(v)) == cv_result.used_views.end())
          std::printf("cv::omnidir dropped view %s\n", views[v].name.c_str());
    }
  }

  // 5. Outputs.
  if (!report_dir.empty()) {
    for (size_t v = 0; v < result.views.size(); ++v) {
      const std::string path =
          (std::filesystem::path(report_dir) /
           (std::filesystem::path(result.views[v].name).stem().string() + "_corners.png"))
              .string();
      WriteViewReportImage(images[v], result.views[v], path);
    }
    if (!quiet)
      std::printf("wrote %zu view images to %s\n", result.views.size(), report_dir.c_str());
  }
  SaveCamera(*result.camera, arguments.Get("output"));
  if (!quiet) std::printf("wrote %s\n", arguments.Get("output").c_str());
  return 0;
}

}  // namespace oslam

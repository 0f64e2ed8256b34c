#include "export/figures.h"

#include <plplot/plplot.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <mutex>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "core/bounds.h"
#include "core/csv.h"
#include "core/error.h"
#include "export/display_scene.h"
#include "export/label_layout.h"

namespace oslam {
namespace {

// ---------------------------------------------------------------- PLplot

// PLplot keeps its state in globals: one figure at a time.
std::mutex& PlplotMutex() {
  static std::mutex mutex;
  return mutex;
}

// cmap0 entries: 0 background, 1 black; 2.. set per mark as it is drawn.
constexpr PLINT kBackground = 0, kBlackIndex = 1, kFirstFree = 2, kColours = 64;

class Palette {
 public:
  // A cmap0 index holding `rgb` at `alpha`, made current when `use`.
  PLINT Index(const Rgb& rgb, double alpha = 1.0) {
    const PLINT index = next_++;
    if (next_ >= kColours) next_ = kFirstFree;
    plscol0a(index, rgb[0], rgb[1], rgb[2], std::clamp(alpha, 0.0, 1.0));
    return index;
  }
  void Use(const Rgb& rgb, double alpha = 1.0) { plcol0(Index(rgb, alpha)); }

 private:
  PLINT next_ = kFirstFree;
};

const Rgb kBlack{0, 0, 0}, kGrid{205, 205, 205}, kDarkGrey{90, 90, 90};

// What a drawing needs to size its marks: the scale of text and lines
// relative to an 800-pixel figure, and the page in millimetres.
struct Page {
  int width_px = 0, height_px = 0;
  double scale = 1.0;
};

// PLplot ends the process on a fatal error (for instance when it cannot write
// the list of its device drivers to a full temporary folder). This handler
// turns that into an Error; libplplot carries unwind tables, so the exception
// crosses its frames.
int ThrowPlplotError(PLCHAR_VECTOR message) {
  throw Error(std::string("PLplot cannot draw: ") + message);
}

// Runs `draw` once per output (PNG through memory, SVG through a memory
// stream), on a fresh PLplot stream each time, and fills the figure.
Figure Render(const FigureOptions& options, const std::function<void(const Page&)>& draw) {
  std::string why;
  if (!options.Validate(&why)) throw Error("figure: " + why);
  const std::lock_guard<std::mutex> lock(PlplotMutex());
  plsexit(&ThrowPlplotError);
  const Page page{options.width_px, options.height_px,
                  std::min(options.width_px, options.height_px) / 800.0};
  Figure figure;
  auto start = [&](const char* device) {
    PLINT stream = 0;
    plmkstrm(&stream);
    plsdev(device);
    plscmap0n(kColours);
    plscolbg(255, 255, 255);
    plscol0(kBlackIndex, 0, 0, 0);
  };
  auto finish_geometry = [&] {
    PLFLT vx0, vx1, vy0, vy1, wx0, wx1, wy0, wy1;
    plgvpd(&vx0, &vx1, &vy0, &vy1);
    plgvpw(&wx0, &wx1, &wy0, &wy1);
    figure.window = {wx0, wx1, wy0, wy1};
    figure.viewport_px = cv::Rect2d(vx0 * page.width_px, (1.0 - vy1) * page.height_px,
                                    (vx1 - vx0) * page.width_px, (vy1 - vy0) * page.height_px);
  };

  // PNG: the memory cairo device draws into an RGBA buffer.
  std::vector<unsigned char> rgba(static_cast<size_t>(page.width_px) * page.height_px * 4, 255);
  start("memcairo");
  plsmema(page.width_px, page.height_px, rgba.data());
  plinit();
  draw(page);
  finish_geometry();
  plend1();
  const cv::Mat pixels(page.height_px, page.width_px, CV_8UC4, rgba.data());
  cv::cvtColor(pixels, figure.image, cv::COLOR_RGBA2BGR);

  // SVG: written to a memory stream, which PLplot closes at the end.
  char* buffer = nullptr;
  size_t size = 0;
  FILE* stream = open_memstream(&buffer, &size);
  if (stream == nullptr) throw Error("figure: no memory for the SVG");
  start("svgcairo");
  plsfile(stream);
  plspage(0, 0, page.width_px, page.height_px, 0, 0);
  plinit();
  draw(page);
  plend1();
  figure.svg.assign(buffer, size);
  std::free(buffer);
  return figure;
}

// Character height in millimetres and page size in millimetres.
double CharHeightMm() {
  PLFLT default_height, height;
  plgchr(&default_height, &height);
  return height;
}

Eigen::Vector2d PageMm() {
  PLFLT x0, x1, y0, y1;
  plgspa(&x0, &x1, &y0, &y1);
  return {x1 - x0, y1 - y0};
}

// Sets text and line sizes for the page: everything scales with the figure
// (PLplot's default character height is already a fixed share of the page).
void ScaleTo(const Page& page, double text = 1.0) {
  plschr(0.0, 0.85 * text);
  plwidth(1.0 * page.scale);
}

struct LegendEntry {
  enum Kind { kLine, kBox, kSymbol, kText } kind;
  Rgb rgb;
  double alpha;
  bool dashed;
  std::string symbol;
  std::string text;
};

// Draws the legend along the bottom of the page in `columns` columns and
// returns its height as a fraction of the page.
double DrawLegend(const std::vector<LegendEntry>& entries, const Page& page, Palette* palette,
                  int columns) {
  plvpor(0.0, 1.0, 0.0, 1.0);
  plwind(0.0, 1.0, 0.0, 1.0);
  const auto n = static_cast<PLINT>(entries.size());
  std::vector<PLINT> opt(n), text_colours(n, kBlackIndex), box_colours(n), box_patterns(n, 0),
      line_colours(n), line_styles(n), symbol_colours(n), symbol_numbers(n, 1);
  std::vector<PLFLT> box_scales(n, 0.8), box_line_widths(n, 1.0), line_widths(n),
      symbol_scales(n, 1.0);
  std::vector<std::string> symbols(n, ""), texts(n);
  for (PLINT i = 0; i < n; ++i) {
    const LegendEntry& e = entries[static_cast<size_t>(i)];
    texts[i] = e.text;
    const PLINT colour = palette->Index(e.rgb, e.alpha);
    switch (e.kind) {
      case LegendEntry::kLine:
        opt[i] = PL_LEGEND_LINE;
        line_colours[i] = colour;
        line_styles[i] = e.dashed ? 3 : 1;
        line_widths[i] = 2.0 * page.scale;
        break;
      case LegendEntry::kBox:
        opt[i] = PL_LEGEND_COLOR_BOX;
        box_colours[i] = colour;
        break;
      case LegendEntry::kSymbol:
        opt[i] = PL_LEGEND_SYMBOL;
        symbol_colours[i] = colour;
        symbols[i] = e.symbol;
        break;
      case LegendEntry::kText:
        opt[i] = PL_LEGEND_NONE;
        break;
    }
  }
  std::vector<const char*> text_pointers, symbol_pointers;
  for (PLINT i = 0; i < n; ++i) {
    text_pointers.push_back(texts[i].c_str());
    symbol_pointers.push_back(symbols[i].c_str());
  }
  PLFLT width = 0, height = 0;
  const PLINT rows = (n + columns - 1) / columns;
  pllegend(&width, &height, PL_LEGEND_BACKGROUND | PL_LEGEND_ROW_MAJOR,
           PL_POSITION_BOTTOM | PL_POSITION_INSIDE | PL_POSITION_SUBPAGE, 0.0, 0.01, 0.06,
           kBackground, kBlackIndex, 1, rows, columns, n, opt.data(), 0.8, 0.8, 1.9, 0.0,
           text_colours.data(), text_pointers.data(), box_colours.data(), box_patterns.data(),
           box_scales.data(), box_line_widths.data(), line_colours.data(), line_styles.data(),
           line_widths.data(), symbol_colours.data(), symbol_scales.data(), symbol_numbers.data(),
           symbol_pointers.data());
  return height + 0.01;
}

// World (plot window) to millimetres on the page, and back.
class PlotMm {
 public:
  PlotMm() {
    plgvpd(&vx0_, &vx1_, &vy0_, &vy1_);
    plgvpw(&wx0_, &wx1_, &wy0_, &wy1_);
    page_ = PageMm();
  }
  cv::Point2d ToMm(double x, double y) const {
    return {page_.x() * (vx0_ + (x - wx0_) / (wx1_ - wx0_) * (vx1_ - vx0_)),
            page_.y() * (vy0_ + (y - wy0_) / (wy1_ - wy0_) * (vy1_ - vy0_))};
  }
  cv::Point2d ToWorld(const cv::Point2d& mm) const {
    return {wx0_ + (mm.x / page_.x() - vx0_) / (vx1_ - vx0_) * (wx1_ - wx0_),
            wy0_ + (mm.y / page_.y() - vy0_) / (vy1_ - vy0_) * (wy1_ - wy0_)};
  }
  double MmPerUnitX() const { return page_.x() * (vx1_ - vx0_) / (wx1_ - wx0_); }
  cv::Rect2d ViewportMm() const {
    return {page_.x() * vx0_, page_.y() * vy0_, page_.x() * (vx1_ - vx0_),
            page_.y() * (vy1_ - vy0_)};
  }

 private:
  PLFLT vx0_, vx1_, vy0_, vy1_, wx0_, wx1_, wy0_, wy1_;
  Eigen::Vector2d page_;
};

// About how wide a label of this many characters is in the sans-serif font
// the cairo devices use (PLplot exposes no text measurement).
double TextWidthMm(const std::string& text, double char_height_mm) {
  size_t glyphs = 0;
  for (const unsigned char c : text)
    if ((c & 0xC0) != 0x80) ++glyphs;  // UTF-8: count lead bytes only
  return 0.66 * char_height_mm * static_cast<double>(glyphs);
}

void Line(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() >= 2) plline(static_cast<PLINT>(x.size()), x.data(), y.data());
}

std::string Fixed(double value, int digits) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", digits, value);
  return text;
}

// ---------------------------------------------------------------- bird's eye

std::vector<double> PositionErrors(const std::vector<Pose2>& poses,
                                   const std::vector<Pose2>& truth) {
  std::vector<double> errors;
  for (size_t i = 0; i < std::min(poses.size(), truth.size()); ++i)
    errors.push_back(std::hypot(poses[i].x - truth[i].x, poses[i].y - truth[i].y));
  return errors;
}

std::string BirdsEyeCsv(const ExportScene& scene, const std::vector<const OMapObject*>& objects) {
  std::string csv = "mark,name,id,frame,x_m,y_m,diameter_m,height_m,existence_probability\n";
  for (const OMapObject* o : objects)
    csv += "object," + o->class_name + "," + std::to_string(o->id) + ",," +
           CsvNumber(o->base_world.x()) + "," + CsvNumber(o->base_world.y()) + "," +
           CsvNumber(o->diameter_m) + "," + CsvNumber(o->height_m) + "," +
           CsvNumber(o->existence_probability) + "\n";
  for (const NamedTrajectory& t : SceneTrajectories(scene))
    for (size_t i = 0; i < t.poses.size(); ++i)
      csv += "trajectory," + t.name + ",," + std::to_string(i) + "," + CsvNumber(t.poses[i].x) +
             "," + CsvNumber(t.poses[i].y) + ",,,\n";
  return csv;
}

}  // namespace

cv::Point2d Figure::PixelOf(double x, double y) const {
  return {viewport_px.x + (x - window[0]) / (window[1] - window[0]) * viewport_px.width,
          viewport_px.y + (window[3] - y) / (window[3] - window[2]) * viewport_px.height};
}

bool FigureOptions::Validate(std::string* why) const {
  if (width_px < 64 || height_px < 64 || width_px > bounds::kFigureSidePx ||
      height_px > bounds::kFigureSidePx) {
    *why = "figures must be 64 to " + std::to_string(bounds::kFigureSidePx) +
           " pixels wide and high (docs/formats.md, Bounds)";
    return false;
  }
  if (!(min_existence >= 0.0 && min_existence <= 1.0)) {
    *why = "min-existence must be in [0, 1]";
    return false;
  }
  if (cylinder_segments < 3) {
    *why = "a cylinder needs at least 3 segments";
    return false;
  }
  return true;
}

Figure BirdsEyeFigure(const ExportScene& scene, const FigureOptions& options) {
  const std::vector<const OMapObject*> objects = ShownObjects(scene.map, options.min_existence);
  const std::vector<NamedTrajectory> trajectories = SceneTrajectories(scene);
  const Eigen::Vector4d extent = FloorExtent(scene, options.min_existence, 0.5);
  // Each object's outline seen from above, around its base point.
  std::vector<std::vector<cv::Point2f>> footprints;
  ExportOptions models;
  models.min_existence = options.min_existence;
  models.cylinder_segments = options.cylinder_segments;
  for (const DisplayObject& shown : BuildDisplayScene(scene, models).objects) {
    std::vector<cv::Point2f> points, hull;
    for (const Eigen::Vector3f& p : shown.local.positions) points.emplace_back(p.x(), p.y());
    cv::convexHull(points, hull);
    footprints.push_back(hull);
  }

  Figure figure = Render(options, [&](const Page& page) {
    Palette palette;
    ScaleTo(page);
    pladv(0);
    // Legend first, along the bottom: the plot takes the space above it.
    std::vector<LegendEntry> legend;
    for (const NamedTrajectory& t : trajectories)
      legend.push_back({LegendEntry::kLine, t.rgb, 1.0, t.name == "estimated", "",
                        t.name == "estimated"  ? "estimated trajectory"
                        : t.name == "odometry" ? "odometry"
                                               : "ground truth"});
    std::map<std::string, Rgb> classes;
    for (const OMapObject* o : objects)
      classes.emplace(o->class_name, ClassColour(scene.classes, o->class_name));
    for (const auto& [name, rgb] : classes)
      legend.push_back({LegendEntry::kBox, rgb, 1.0, false, "",
                        (name.empty() ? std::string("object") : name) + " (" +
                            ObjectShapeName(ClassShape(scene.classes, name)) + ")"});
    legend.push_back(
        {LegendEntry::kBox, {110, 110, 110}, 0.25, false, "", "paler: less likely (opacity = π)"});
    legend.push_back({LegendEntry::kSymbol, kBlack, 1.0, false, "+", "base point"});
    ScaleTo(page, 0.9);
    const double legend_height = DrawLegend(legend, page, &palette, 2);
    ScaleTo(page);

    const double char_fraction = CharHeightMm() / PageMm().y();
    plvpas(0.1, 0.97, legend_height + 5.0 * char_fraction, 1.0 - 3.0 * char_fraction,
           (extent[3] - extent[1]) / (extent[2] - extent[0]));
    plwind(extent[0], extent[2], extent[1], extent[3]);
    // Grid first, everything else over it.
    palette.Use(kGrid);
    plbox("g", 0.0, 0, "g", 0.0, 0);
    // References first, the estimate on top.
    for (auto it = trajectories.rbegin(); it != trajectories.rend(); ++it) {
      std::vector<double> x, y;
      for (const Pose2& p : it->poses) {
        x.push_back(p.x);
        y.push_back(p.y);
      }
      palette.Use(it->rgb);
      pllsty(it->name == "estimated" ? 3 : 1);
      plwidth((it->name == "estimated" ? 1.6 : 1.2) * page.scale);
      Line(x, y);
    }
    pllsty(1);
    plwidth(page.scale);
    const PlotMm mm;
    // Footprints in the shape of each class (as in the 3D files), at least
    // 1.5 mm across so the smallest stay visible; fill and base point both
    // with opacity pi.
    for (size_t i = 0; i < objects.size(); ++i) {
      const OMapObject* o = objects[i];
      const Rgb rgb = ClassColour(scene.classes, o->class_name);
      const double grow =
          std::max(1.0, 0.75 / std::max(0.5 * o->diameter_m * mm.MmPerUnitX(), 1e-9));
      std::vector<double> x, y;
      for (const cv::Point2f& p : footprints[i]) {
        x.push_back(o->base_world.x() + grow * p.x);
        y.push_back(o->base_world.y() + grow * p.y);
      }
      palette.Use(rgb, o->existence_probability);
      plfill(static_cast<PLINT>(x.size()), x.data(), y.data());
      x.push_back(x.front());
      y.push_back(y.front());
      palette.Use(rgb, std::min(1.0, o->existence_probability + 0.2));
      Line(x, y);
      palette.Use(kBlack, o->existence_probability);
      const PLFLT cx = o->base_world.x(), cy = o->base_world.y();
      plstring(1, &cx, &cy, "+");
    }
    // Labels: beside their discs, moved apart where they would collide,
    // with a leader line then. Beyond 60 objects (a park of trees) they
    // would only cover each other.
    constexpr size_t kMaxLabels = 60;
    if (objects.size() <= kMaxLabels) {
      const double h = CharHeightMm();
      std::vector<LabelRequest> requests;
      std::vector<std::string> texts;
      for (size_t i = 0; i < objects.size(); ++i) {
        const OMapObject* o = objects[i];
        texts.push_back(ObjectLabel(*o) + "  π " + Fixed(o->existence_probability, 2));
        double half_x = 0.0, half_y = 0.0;
        for (const cv::Point2f& p : footprints[i]) {
          half_x = std::max(half_x, static_cast<double>(std::abs(p.x)));
          half_y = std::max(half_y, static_cast<double>(std::abs(p.y)));
        }
        requests.push_back({mm.ToMm(o->base_world.x(), o->base_world.y()),
                            {TextWidthMm(texts.back(), h), 1.4 * h},
                            {half_x * mm.MmPerUnitX(), half_y * mm.MmPerUnitX()}});
      }
      const std::vector<PlacedLabel> placed = PlaceLabels(requests, mm.ViewportMm(), {}, 0.5 * h);
      for (size_t i = 0; i < placed.size(); ++i) {
        const cv::Rect2d& box = placed[i].box;
        if (placed[i].needs_leader) {
          const cv::Point2d from = mm.ToWorld(requests[i].anchor);
          const cv::Point2d to = mm.ToWorld(NearestPointOnBox(box, requests[i].anchor));
          palette.Use(kDarkGrey);
          Line({from.x, to.x}, {from.y, to.y});
        }
        const cv::Point2d at = mm.ToWorld({box.x, box.y + 0.5 * box.height});
        palette.Use(kBlack);
        plptex(at.x, at.y, 1.0, 0.0, 0.0, texts[i].c_str());
      }
    }
    plcol0(kBlackIndex);
    plbox("bcnst", 0.0, 0, "bcnstv", 0.0, 0);
    pllab("x [m]", "y [m]",
          ("O-Map seen from above: " + std::to_string(objects.size()) + " objects with π ≥ " +
           Fixed(options.min_existence, 2))
              .c_str());
  });
  figure.csv = BirdsEyeCsv(scene, objects);
  return figure;
}

Figure LinePlotFigure(const std::string& title, const std::string& x_label,
                      const std::string& y_label, const std::vector<PlotSeries>& series,
                      const FigureOptions& options) {
  double x0 = 1e300, x1 = -1e300, y0 = 0.0, y1 = -1e300;
  for (const PlotSeries& s : series) {
    for (const double x : s.x) x0 = std::min(x0, x), x1 = std::max(x1, x);
    for (const double y : s.y) y0 = std::min(y0, y), y1 = std::max(y1, y);
  }
  if (!(x0 < x1)) x0 = 0.0, x1 = std::max(1.0, x1);
  if (!(y1 > y0)) y1 = y0 + 1.0;
  const double pad = 0.05 * (y1 - y0);
  y1 += pad;
  if (y0 < 0) y0 -= pad;

  Figure figure = Render(options, [&](const Page& page) {
    Palette palette;
    ScaleTo(page);
    pladv(0);
    std::vector<LegendEntry> legend;
    for (const PlotSeries& s : series)
      legend.push_back({LegendEntry::kLine, s.rgb, 1.0, s.dashed, "", s.name});
    ScaleTo(page, 1.1);
    const double legend_height =
        DrawLegend(legend, page, &palette,
                   std::min<int>(3, std::max<int>(1, static_cast<int>(series.size()))));
    ScaleTo(page, 1.2);
    const double char_fraction = CharHeightMm() / PageMm().y();
    plvpor(0.12, 0.96, legend_height + 5.0 * char_fraction, 1.0 - 3.0 * char_fraction);
    plwind(x0, x1, y0, y1);
    palette.Use(kGrid);
    plbox("g", 0.0, 0, "g", 0.0, 0);
    for (const PlotSeries& s : series) {
      palette.Use(s.rgb);
      pllsty(s.dashed ? 3 : 1);
      plwidth(1.5 * page.scale);
      Line(s.x, s.y);
    }
    pllsty(1);
    plwidth(page.scale);
    plcol0(kBlackIndex);
    plbox("bcnst", 0.0, 0, "bcnstv", 0.0, 0);
    pllab(x_label.c_str(), y_label.c_str(), title.c_str());
  });
  // Rows by x value; a series without a value there leaves its cell empty.
  std::map<double, std::vector<std::string>> rows;
  for (size_t k = 0; k < series.size(); ++k)
    for (size_t i = 0; i < std::min(series[k].x.size(), series[k].y.size()); ++i) {
      std::vector<std::string>& row = rows[series[k].x[i]];
      row.resize(series.size());
      row[k] = CsvNumber(series[k].y[i]);
    }
  std::string csv = "x";
  for (const PlotSeries& s : series) csv += "," + (s.column.empty() ? s.name : s.column);
  csv += "\n";
  for (auto& [x, row] : rows) {
    row.resize(series.size());
    csv += CsvNumber(x);
    for (const std::string& cell : row) csv += "," + cell;
    csv += "\n";
  }
  figure.csv = csv;
  return figure;
}

Figure TrajectoryErrorFigure(const ExportScene& scene, const FigureOptions& options) {
  if (scene.ground_truth.empty()) throw Error("trajectory plot: no ground truth to compare with");
  std::vector<PlotSeries> series;
  for (const NamedTrajectory& t : SceneTrajectories(scene)) {
    if (t.name == "ground truth") continue;
    PlotSeries s;
    s.name = t.name == "estimated" ? "estimated trajectory" : t.name;
    s.column = t.name + "_error_m";
    s.y = PositionErrors(t.poses, scene.ground_truth);
    for (size_t i = 0; i < s.y.size(); ++i) s.x.push_back(static_cast<double>(i));
    s.rgb = t.rgb;
    s.dashed = t.name == "estimated";
    series.push_back(s);
  }
  Figure figure = LinePlotFigure("Horizontal position error against ground truth", "frame",
                                 "error [m]", series, options);
  // The CSV's first column is the frame.
  figure.csv.replace(0, 1, "frame");
  return figure;
}

std::string EncodePng(const cv::Mat& image, bool fast) {
  std::vector<unsigned char> png;
  // Level 1 with the "huffman only"-like fast strategy costs a fraction of
  // the default's time for a frame with noise; the default packs figures
  // tighter.
  std::vector<int> parameters;
  if (fast)
    parameters = {cv::IMWRITE_PNG_COMPRESSION, 1, cv::IMWRITE_PNG_STRATEGY,
                  cv::IMWRITE_PNG_STRATEGY_RLE};
  if (image.empty() || !cv::imencode(".png", image, png, parameters))
    throw Error("cannot encode the image as PNG");
  return std::string(reinterpret_cast<const char*>(png.data()), png.size());
}

void WritePng(const cv::Mat& image, const std::string& path, FileSync sync) {
  // Encoded in memory, so the only write is WriteFileAtomically's, checked.
  std::string png;
  try {
    png = EncodePng(image);
  } catch (const Error&) {
    throw Error::InFile(path, "cannot encode the image as PNG");
  }
  WriteFileAtomically(path, png, sync);
}

}  // namespace oslam

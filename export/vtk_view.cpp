#include "export/vtk_view.h"

// GLEW before any OpenGL header (VTK's included).
#include <GL/glew.h>
// clang-format off
#include <EGL/egl.h>
#include <EGL/eglext.h>
// clang-format on

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <mutex>

#include <vtkActor.h>
#include <vtkActor2D.h>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkImageData.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkPolyDataMapper2D.h>
#include <vtkProperty.h>
#include <vtkProperty2D.h>
#include <vtkRenderWindow.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowToImageFilter.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "export/label_layout.h"

namespace oslam {
namespace {

// ---------------------------------------------------------------- off-screen

// An OpenGL 3.2 core context of Mesa's EGL on a pbuffer, current in the
// calling thread while it lives. Surfaceless first (works with no display and
// no GPU: llvmpipe), then the default display.
class EglContext {
 public:
  EglContext(int width, int height) {
    auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_platform_display != nullptr)
      display_ = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display_ == EGL_NO_DISPLAY || !eglInitialize(display_, nullptr, nullptr)) {
      display_ = eglGetDisplay(EGL_DEFAULT_DISPLAY);
      if (display_ == EGL_NO_DISPLAY || !eglInitialize(display_, nullptr, nullptr))
        Fail("no EGL display");
    }
    const EGLint config_attributes[] = {EGL_SURFACE_TYPE,
                                        EGL_PBUFFER_BIT,
                                        EGL_RED_SIZE,
                                        8,
                                        EGL_GREEN_SIZE,
                                        8,
                                        EGL_BLUE_SIZE,
                                        8,
                                        EGL_ALPHA_SIZE,
                                        8,
                                        EGL_DEPTH_SIZE,
                                        24,
                                        EGL_RENDERABLE_TYPE,
                                        EGL_OPENGL_BIT,
                                        EGL_NONE};
    EGLConfig config = nullptr;
    EGLint configs = 0;
    if (!eglChooseConfig(display_, config_attributes, &config, 1, &configs) || configs < 1)
      Fail("no EGL configuration for OpenGL on a pbuffer");
    if (!eglBindAPI(EGL_OPENGL_API)) Fail("EGL has no desktop OpenGL");
    const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION,
                                         3,
                                         EGL_CONTEXT_MINOR_VERSION,
                                         2,
                                         EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                         EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                         EGL_NONE};
    context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, context_attributes);
    if (context_ == EGL_NO_CONTEXT) Fail("cannot create an OpenGL 3.2 context");
    const EGLint surface_attributes[] = {EGL_WIDTH, width, EGL_HEIGHT, height, EGL_NONE};
    surface_ = eglCreatePbufferSurface(display_, config, surface_attributes);
    if (surface_ == EGL_NO_SURFACE) Fail("cannot create a pbuffer");
    if (!eglMakeCurrent(display_, surface_, surface_, context_)) Fail("cannot make it current");
  }
  ~EglContext() { Release(); }
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

 private:
  [[noreturn]] void Fail(const std::string& what) {
    const EGLint code = eglGetError();
    Release();
    char hex[16];
    std::snprintf(hex, sizeof(hex), "0x%04x", code);
    throw Error("off-screen rendering: " + what + " (EGL error " + hex +
                "; needs Mesa's EGL, Debian package libegl-mesa0)");
  }
  void Release() {
    if (display_ == EGL_NO_DISPLAY) return;
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (surface_ != EGL_NO_SURFACE) eglDestroySurface(display_, surface_);
    if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
    surface_ = EGL_NO_SURFACE;
    context_ = EGL_NO_CONTEXT;
  }
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  EGLSurface surface_ = EGL_NO_SURFACE;
};

// VTK renders into a context made elsewhere through vtkGenericOpenGLRenderWindow.
// Debian's VTK loads OpenGL with GLEW built for GLX: glewInit loads every GL
// entry point, then fails on the GLX part for want of an X display, and VTK
// gives up. The GL entry points are all VTK uses, so that one failure is let
// through here.
class EglRenderWindow : public vtkGenericOpenGLRenderWindow {
 public:
  static EglRenderWindow* New();
  vtkTypeMacro(EglRenderWindow, vtkGenericOpenGLRenderWindow);

 protected:
  void OpenGLInitContext() override {
    this->ContextCreationTime.Modified();
    if (this->Initialized) return;
    const GLenum result = glewInit();
    if ((result != GLEW_OK && result != GLEW_ERROR_NO_GLX_DISPLAY) || !GLEW_VERSION_3_2) {
      vtkErrorMacro("OpenGL 3.2 functions could not be loaded");
      return;
    }
    this->GlewInitValid = true;
    this->Initialized = true;
  }
};
vtkStandardNewMacro(EglRenderWindow);

// ---------------------------------------------------------------- geometry

vtkSmartPointer<vtkPolyData> ToPolyData(const ShadedMesh& mesh) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToFloat();
  points->SetNumberOfPoints(static_cast<vtkIdType>(mesh.positions.size()));
  vtkNew<vtkFloatArray> normals;
  normals->SetNumberOfComponents(3);
  normals->SetNumberOfTuples(static_cast<vtkIdType>(mesh.normals.size()));
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    points->SetPoint(static_cast<vtkIdType>(i), mesh.positions[i].data());
    normals->SetTypedTuple(static_cast<vtkIdType>(i), mesh.normals[i].data());
  }
  vtkNew<vtkCellArray> triangles;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const vtkIdType ids[3] = {mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]};
    triangles->InsertNextCell(3, ids);
  }
  auto data = vtkSmartPointer<vtkPolyData>::New();
  data->SetPoints(points);
  data->SetPolys(triangles);
  data->GetPointData()->SetNormals(normals);
  return data;
}

void SetColour(vtkProperty* property, const Rgb& rgb) {
  property->SetColor(rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
}

vtkSmartPointer<vtkActor> MeshActor(const ShadedMesh& mesh, const Rgb& rgb, double opacity) {
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(ToPolyData(mesh));
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  SetColour(actor->GetProperty(), rgb);
  actor->GetProperty()->SetOpacity(opacity);
  // Closed meshes: culling the far side leaves one layer per transparent
  // object, as in the glTF.
  actor->GetProperty()->BackfaceCullingOn();
  actor->GetProperty()->SetAmbient(0.25);
  actor->GetProperty()->SetDiffuse(0.75);
  actor->GetProperty()->SetSpecular(0.15);
  return actor;
}

// Line segments (pairs of points) as one actor.
vtkSmartPointer<vtkActor> LinesActor(const std::vector<Eigen::Vector3d>& ends, const Rgb& rgb,
                                     double width) {
  vtkNew<vtkPoints> points;
  vtkNew<vtkCellArray> lines;
  for (size_t i = 0; i + 1 < ends.size(); i += 2) {
    const vtkIdType ids[2] = {points->InsertNextPoint(ends[i].data()),
                              points->InsertNextPoint(ends[i + 1].data())};
    lines->InsertNextCell(2, ids);
  }
  vtkNew<vtkPolyData> data;
  data->SetPoints(points);
  data->SetLines(lines);
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(data);
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  SetColour(actor->GetProperty(), rgb);
  actor->GetProperty()->SetLineWidth(static_cast<float>(width));
  actor->GetProperty()->LightingOff();
  return actor;
}

// A 2D shape in display pixels (origin bottom left): a filled polygon, or a
// polyline when `closed` is false.
vtkSmartPointer<vtkActor2D> Shape2D(const std::vector<cv::Point2d>& corners, bool filled,
                                    const Rgb& rgb, double opacity, double line_width) {
  vtkNew<vtkPoints> points;
  std::vector<vtkIdType> ids;
  for (const cv::Point2d& c : corners) ids.push_back(points->InsertNextPoint(c.x, c.y, 0.0));
  vtkNew<vtkCellArray> cells;
  cells->InsertNextCell(static_cast<vtkIdType>(ids.size()), ids.data());
  vtkNew<vtkPolyData> data;
  data->SetPoints(points);
  if (filled)
    data->SetPolys(cells);
  else
    data->SetLines(cells);
  vtkNew<vtkPolyDataMapper2D> mapper;
  mapper->SetInputData(data);
  auto actor = vtkSmartPointer<vtkActor2D>::New();
  actor->SetMapper(mapper);
  actor->GetProperty()->SetColor(rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
  actor->GetProperty()->SetOpacity(opacity);
  actor->GetProperty()->SetLineWidth(static_cast<float>(line_width));
  return actor;
}

vtkSmartPointer<vtkTextActor> Text(const std::string& text, int font_px, const Rgb& rgb,
                                   bool bold = false) {
  auto actor = vtkSmartPointer<vtkTextActor>::New();
  actor->SetInput(text.c_str());
  vtkTextProperty* property = actor->GetTextProperty();
  property->SetFontFamilyToArial();
  property->SetFontSize(font_px);
  property->SetColor(rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
  property->SetBold(bold);
  property->SetJustificationToLeft();
  property->SetVerticalJustificationToBottom();
  return actor;
}

std::string Format(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

// ---------------------------------------------------------------- the scene

const Rgb kBlack{0, 0, 0}, kDarkGrey{70, 70, 70}, kGridGrey{165, 165, 165},
    kFloorGrey{238, 238, 234}, kWhite{255, 255, 255};

class ViewScene {
 public:
  ViewScene(vtkRenderer* renderer, const ExportScene& scene, const DisplayScene& display,
            const ViewOptions& options)
      : renderer_(renderer), scene_(scene), display_(display), options_(options) {
    font_px_ = std::max(10, static_cast<int>(std::lround(options.height_px / 46.0)));
    renderer_->SetBackground(1.0, 1.0, 1.0);
    renderer_->UseFXAAOn();
    AddFloor();
    for (const DisplayTrajectory& trajectory : display_.trajectories)
      if (!trajectory.tube.triangles.empty())
        renderer_->AddActor(MeshActor(Shade(trajectory.tube), trajectory.rgb, 1.0));
    for (const DisplayObject& shown : display_.objects) {
      renderer_->AddActor(MeshActor(Shade(shown.World()), shown.rgb, shown.alpha));
      AddObjectLabel(shown);
    }
    AddLegend();
    SelectPose(options.selected_pose);
    FitCamera();
    // The 2D layout (labels, axis values) depends on the camera: redone
    // before every render, so it follows the interactive camera too.
    layout_callback_->SetClientData(this);
    layout_callback_->SetCallback([](vtkObject*, unsigned long, void* self, void*) {
      static_cast<ViewScene*>(self)->Layout();
    });
    renderer_->AddObserver(vtkCommand::StartEvent, layout_callback_);
  }

  ~ViewScene() { renderer_->RemoveObserver(layout_callback_); }

  long selected_pose() const { return selected_pose_; }

  // Draws the frame of estimated pose `index` (none when out of range).
  void SelectPose(long index) {
    for (vtkSmartPointer<vtkActor>& axis : pose_axes_) {
      if (axis) renderer_->RemoveActor(axis);
      axis = nullptr;
    }
    selected_pose_ = -1;
    pose_text_->SetInput("");
    const std::vector<Pose2>& poses = scene_.map.trajectory;
    if (index < 0 || index >= static_cast<long>(poses.size())) return;
    selected_pose_ = index;
    const Pose2& pose = poses[static_cast<size_t>(index)];
    const Eigen::Vector4d& f = display_.floor;
    const double length =
        std::max(18.0 * display_.tube_radius_m, 0.06 * std::hypot(f[2] - f[0], f[3] - f[1]));
    const double z = 6.0 * display_.tube_radius_m;
    const Eigen::Vector3d origin(pose.x, pose.y, z);
    const Eigen::Vector3d forward(std::cos(pose.theta), std::sin(pose.theta), 0.0);
    const Eigen::Vector3d left(-forward.y(), forward.x(), 0.0);
    const Eigen::Vector3d axes[3] = {forward, left, Eigen::Vector3d::UnitZ()};
    const Rgb colours[3] = {{220, 30, 30}, {30, 170, 30}, {40, 60, 220}};
    for (int k = 0; k < 3; ++k) {
      pose_axes_[k] =
          LinesActor({origin, origin + length * axes[k]}, colours[k], 3.0 * LineScale());
      renderer_->AddActor(pose_axes_[k]);
    }
    pose_text_->SetInput(("pose " + std::to_string(index) + ": x " + Format("%.2f", pose.x) +
                          " m, y " + Format("%.2f", pose.y) + " m, heading " +
                          Format("%.0f", pose.theta * 180.0 / M_PI) +
                          " deg (axes: red forward, green left, blue up)")
                             .c_str());
  }

 private:
  double LineScale() const { return std::max(1.0, options_.height_px / 600.0); }

  void AddFloor() {
    const Eigen::Vector4d& f = display_.floor;
    ShadedMesh plane;
    for (const auto& [x, y] : {std::pair{f[0], f[1]}, {f[2], f[1]}, {f[2], f[3]}, {f[0], f[3]}}) {
      plane.positions.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.f);
      plane.normals.push_back(Eigen::Vector3f::UnitZ());
    }
    plane.indices = {0, 1, 2, 0, 2, 3};
    vtkSmartPointer<vtkActor> floor = MeshActor(plane, kFloorGrey, 1.0);
    floor->GetProperty()->BackfaceCullingOff();
    floor->GetProperty()->SetSpecular(0.0);
    // Evenly light whatever the view: the floor is context, not a shape.
    floor->GetProperty()->SetAmbient(0.8);
    floor->GetProperty()->SetDiffuse(0.2);
    renderer_->AddActor(floor);
    const double step = display_.grid_step_m, z = 0.004;
    std::vector<Eigen::Vector3d> ends;
    for (double x = std::ceil(f[0] / step) * step; x <= f[2] + 1e-9; x += step) {
      ends.emplace_back(x, f[1], z);
      ends.emplace_back(x, f[3], z);
      grid_x_.push_back(x);
    }
    for (double y = std::ceil(f[1] / step) * step; y <= f[3] + 1e-9; y += step) {
      ends.emplace_back(f[0], y, z);
      ends.emplace_back(f[2], y, z);
      grid_y_.push_back(y);
    }
    renderer_->AddActor(LinesActor(ends, kGridGrey, LineScale()));
    // Axis values along the two floor edges nearest the camera, and titles.
    for (size_t i = 0; i < grid_x_.size() + grid_y_.size(); ++i) {
      const bool is_x = i < grid_x_.size();
      const double value = is_x ? grid_x_[i] : grid_y_[i - grid_x_.size()];
      axis_values_.push_back(Text(Format("%g", std::abs(value) < 1e-9 ? 0.0 : value),
                                  std::max(9, font_px_ - 2), kDarkGrey));
      renderer_->AddActor2D(axis_values_.back());
    }
    for (const char* title : {"x [m]", "y [m]"}) {
      axis_titles_.push_back(Text(title, font_px_, kDarkGrey, true));
      renderer_->AddActor2D(axis_titles_.back());
    }
  }

  void AddObjectLabel(const DisplayObject& shown) {
    Label label;
    const OMapObject& object = *shown.object;
    label.anchor = object.base_world + Eigen::Vector3d(0, 0, object.height_m);
    label.text = Text(shown.label + "  " + Format("%.2f", shown.alpha), font_px_, kBlack);
    label.text->GetTextProperty()->SetBackgroundColor(1.0, 1.0, 1.0);
    label.text->GetTextProperty()->SetBackgroundOpacity(0.7);
    label.leader = Shape2D({{0, 0}, {1, 1}}, false, kDarkGrey, 1.0, LineScale());
    renderer_->AddActor2D(label.leader);
    renderer_->AddActor2D(label.text);
    labels_.push_back(label);
  }

  // Top left: what every mark means.
  void AddLegend() {
    struct Entry {
      enum { kLine, kSquare, kNone } swatch;
      Rgb rgb;
      double opacity;
      std::string text;
    };
    std::vector<Entry> entries;
    for (const DisplayTrajectory& trajectory : display_.trajectories)
      entries.push_back({Entry::kLine, trajectory.rgb, 1.0,
                         trajectory.name == "estimated"  ? "estimated trajectory"
                         : trajectory.name == "odometry" ? "odometry (dead reckoning)"
                                                         : "ground truth"});
    std::map<std::string, const DisplayObject*> classes;
    for (const DisplayObject& shown : display_.objects)
      classes.emplace(shown.object->class_name, &shown);
    for (const auto& [name, shown] : classes)
      entries.push_back({Entry::kSquare, shown->rgb, 1.0,
                         (name.empty() ? std::string("object") : name) + " (" +
                             ObjectShapeName(shown->shape) + ")"});
    entries.push_back({Entry::kSquare,
                       {120, 120, 120},
                       0.3,
                       "opacity = existence probability (label: id, probability)"});
    entries.push_back({Entry::kNone, kBlack, 1.0,
                       "left out: probability < " + Format("%.2f", options_.min_existence) +
                           "; grid " + Format("%g", display_.grid_step_m) + " m"});
    const int font = std::max(9, static_cast<int>(std::lround(0.85 * font_px_)));
    const double row = 1.3 * font, swatch = 1.6 * font, margin = 0.6 * font_px_;
    double y = options_.height_px - margin - row;
    double widest = 0.0;
    std::vector<vtkSmartPointer<vtkTextActor>> texts;
    for (const Entry& entry : entries) {
      const double x = margin, middle = y + 0.35 * font;
      if (entry.swatch == Entry::kLine)
        legend_.push_back(
            Shape2D({{x, middle}, {x + swatch, middle}}, false, entry.rgb, 1.0, 3.0 * LineScale()));
      else if (entry.swatch == Entry::kSquare)
        legend_.push_back(Shape2D({{x + 0.2 * swatch, middle - 0.3 * swatch},
                                   {x + 0.8 * swatch, middle - 0.3 * swatch},
                                   {x + 0.8 * swatch, middle + 0.3 * swatch},
                                   {x + 0.2 * swatch, middle + 0.3 * swatch}},
                                  true, entry.rgb, entry.opacity, 1.0));
      texts.push_back(Text(entry.text, font, kBlack));
      texts.back()->SetDisplayPosition(static_cast<int>(x + swatch + 0.5 * font),
                                       static_cast<int>(y));
      double extent[2];
      texts.back()->GetSize(renderer_, extent);
      widest = std::max(widest, swatch + 0.5 * font + extent[0]);
      y -= row;
    }
    pose_text_ = Text("", font_px_, kBlack);
    pose_text_->SetDisplayPosition(static_cast<int>(margin), static_cast<int>(margin));
    renderer_->AddActor2D(pose_text_);
    legend_box_ = cv::Rect2d(0, 0, widest + 2 * margin, options_.height_px - y - 0.2 * row);
    // Background first so the swatches and text draw over it.
    renderer_->AddActor2D(Shape2D({{0, y + 0.6 * row},
                                   {legend_box_.width, y + 0.6 * row},
                                   {legend_box_.width, static_cast<double>(options_.height_px)},
                                   {0, static_cast<double>(options_.height_px)}},
                                  true, kWhite, 0.8, 1.0));
    for (const auto& actor : legend_) renderer_->AddActor2D(actor);
    for (const auto& actor : texts) renderer_->AddActor2D(actor);
  }

  Eigen::Vector3d Bounds(bool high) const {
    const Eigen::Vector4d& f = display_.floor;
    double top = 0.5;
    for (const DisplayObject& shown : display_.objects)
      top = std::max(top, shown.object->base_world.z() + shown.object->height_m);
    return high ? Eigen::Vector3d(f[2], f[3], top) : Eigen::Vector3d(f[0], f[1], 0.0);
  }

  // Looks at the scene from the options' direction, as close as keeps every
  // corner of its box in view, centred in the part of the image the legend
  // leaves free (right of it or below it, whichever is larger).
  void FitCamera() {
    const Eigen::Vector3d low = Bounds(false), high = Bounds(true);
    std::vector<Eigen::Vector3d> corners;
    for (int i = 0; i < 8; ++i)
      corners.emplace_back(i & 1 ? high.x() : low.x(), i & 2 ? high.y() : low.y(),
                           i & 4 ? high.z() : low.z());
    const double w = options_.width_px, h = options_.height_px;
    // Free region in normalised image coordinates [-1, 1], y up.
    Eigen::Vector4d region(-1, -1, 1, 1);
    if ((w - legend_box_.width) * h >= w * (h - legend_box_.height))
      region[0] = 2.0 * legend_box_.width / w - 1.0;
    else
      region[3] = 1.0 - 2.0 * legend_box_.height / h;
    // Room for the axis values and titles around the floor.
    const double margin_x = 4.0 * font_px_ / w, margin_y = 3.0 * font_px_ / h;
    region += Eigen::Vector4d(margin_x, margin_y, -margin_x, -margin_y);
    if (scene_.map.trajectory.size() > 0) region[1] += 2.0 * font_px_ / h;  // the pose line
    const Eigen::Vector2d centre(0.5 * (region[0] + region[2]), 0.5 * (region[1] + region[3]));

    const double view_angle = 30.0;
    const double tan_v = std::tan(0.5 * view_angle * M_PI / 180.0), aspect = w / h;
    const Eigen::Vector3d direction(
        std::cos(options_.elevation_rad) * std::cos(options_.azimuth_rad),
        std::cos(options_.elevation_rad) * std::sin(options_.azimuth_rad),
        std::sin(options_.elevation_rad));
    const Eigen::Vector3d forward = -direction;
    const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d up = right.cross(forward);
    // Extent of the corners in normalised image coordinates from `eye`.
    auto extent = [&](const Eigen::Vector3d& eye) {
      Eigen::Vector4d box(1e9, 1e9, -1e9, -1e9);
      for (const Eigen::Vector3d& c : corners) {
        const Eigen::Vector3d d = c - eye;
        const double depth = std::max(d.dot(forward), 1e-6);
        const double u = d.dot(right) / depth / (tan_v * aspect), v = d.dot(up) / depth / tan_v;
        box = {std::min(box[0], u), std::min(box[1], v), std::max(box[2], u), std::max(box[3], v)};
      }
      return box;
    };
    Eigen::Vector3d target = 0.5 * (low + high);
    double distance = 1.0;
    for (int pass = 0; pass < 4; ++pass) {
      // The nearest distance at which the box fits the region's size...
      double near = 1e-3, far = 1e5;
      for (int i = 0; i < 60; ++i) {
        const double middle = 0.5 * (near + far);
        const Eigen::Vector4d box = extent(target + middle * direction);
        const bool fits =
            box[2] - box[0] <= region[2] - region[0] && box[3] - box[1] <= region[3] - region[1];
        (fits ? far : near) = middle;
      }
      distance = far;
      // ... then moved so the box's middle lands on the region's.
      const Eigen::Vector4d box = extent(target + distance * direction);
      const Eigen::Vector2d offset(0.5 * (box[0] + box[2]) - centre.x(),
                                   0.5 * (box[1] + box[3]) - centre.y());
      target +=
          right * (offset.x() * tan_v * aspect * distance) + up * (offset.y() * tan_v * distance);
    }
    vtkCamera* camera = renderer_->GetActiveCamera();
    camera->SetViewAngle(view_angle);
    camera->SetFocalPoint(target.data());
    const Eigen::Vector3d eye = target + distance * direction;
    camera->SetPosition(eye.data());
    camera->SetViewUp(0.0, 0.0, 1.0);
    renderer_->ResetCameraClippingRange(low.x(), high.x(), low.y(), high.y(), low.z(), high.z());
  }

  // World point to display pixels (origin bottom left); false behind the camera.
  bool ToDisplay(const Eigen::Vector3d& p, cv::Point2d* out) {
    vtkCamera* camera = renderer_->GetActiveCamera();
    double direction[3];
    camera->GetDirectionOfProjection(direction);
    const double* eye = camera->GetPosition();
    if ((p - Eigen::Vector3d(eye[0], eye[1], eye[2]))
            .dot(Eigen::Vector3d(direction[0], direction[1], direction[2])) <= 0)
      return false;
    renderer_->SetWorldPoint(p.x(), p.y(), p.z(), 1.0);
    renderer_->WorldToDisplay();
    double display[3];
    renderer_->GetDisplayPoint(display);
    *out = {display[0], display[1]};
    return true;
  }

  void Layout() {
    int* size = renderer_->GetSize();
    const double height = size[1];
    const cv::Rect2d canvas(0, 0, size[0], size[1]);
    // Axis values: along the floor edges nearer the camera.
    const Eigen::Vector4d& f = display_.floor;
    const double* eye = renderer_->GetActiveCamera()->GetPosition();
    const double x_edge = std::abs(eye[0] - f[0]) < std::abs(eye[0] - f[2]) ? f[0] : f[2];
    const double y_edge = std::abs(eye[1] - f[1]) < std::abs(eye[1] - f[3]) ? f[1] : f[3];
    std::vector<cv::Rect2d> obstacles = {
        {legend_box_.x, height - legend_box_.height, legend_box_.width, legend_box_.height}};
    auto place_centred = [&](vtkTextActor* text, const Eigen::Vector3d& at) {
      cv::Point2d p;
      if (!ToDisplay(at, &p)) {
        text->SetVisibility(false);
        return;
      }
      double extent[2];
      text->GetSize(renderer_, extent);
      text->SetVisibility(true);
      text->SetDisplayPosition(static_cast<int>(p.x - 0.5 * extent[0]),
                               static_cast<int>(p.y - 0.5 * extent[1]));
      obstacles.push_back({p.x - 0.5 * extent[0], p.y - 0.5 * extent[1], extent[0], extent[1]});
    };
    const double outside = 4.0 * display_.tube_radius_m + 0.04 * std::max(f[2] - f[0], f[3] - f[1]);
    const double y_out = y_edge == f[1] ? -outside : outside,
                 x_out = x_edge == f[0] ? -outside : outside;
    for (size_t i = 0; i < grid_x_.size(); ++i)
      place_centred(axis_values_[i], {grid_x_[i], y_edge + y_out, 0.0});
    for (size_t i = 0; i < grid_y_.size(); ++i)
      place_centred(axis_values_[grid_x_.size() + i], {x_edge + x_out, grid_y_[i], 0.0});
    place_centred(axis_titles_[0], {0.5 * (f[0] + f[2]), y_edge + 2.6 * y_out, 0.0});
    place_centred(axis_titles_[1], {x_edge + 2.6 * x_out, 0.5 * (f[1] + f[3]), 0.0});

    // Object labels: above each object's top centre, moved apart.
    std::vector<LabelRequest> requests;
    std::vector<size_t> shown;
    for (size_t i = 0; i < labels_.size(); ++i) {
      cv::Point2d anchor;
      if (!ToDisplay(labels_[i].anchor, &anchor)) {
        labels_[i].text->SetVisibility(false);
        labels_[i].leader->SetVisibility(false);
        continue;
      }
      double extent[2];
      labels_[i].text->GetSize(renderer_, extent);
      requests.push_back({anchor, {extent[0], extent[1]}, {0.3 * font_px_, 0.3 * font_px_}});
      shown.push_back(i);
    }
    const std::vector<PlacedLabel> placed =
        PlaceLabels(requests, canvas, obstacles, 0.4 * font_px_);
    for (size_t k = 0; k < placed.size(); ++k) {
      Label& label = labels_[shown[k]];
      label.text->SetVisibility(true);
      label.text->SetDisplayPosition(static_cast<int>(placed[k].box.x),
                                     static_cast<int>(placed[k].box.y));
      const cv::Point2d end = NearestPointOnBox(placed[k].box, requests[k].anchor);
      vtkPoints* points =
          vtkPolyData::SafeDownCast(label.leader->GetMapper()->GetInputDataObject(0, 0))
              ->GetPoints();
      points->SetPoint(0, requests[k].anchor.x, requests[k].anchor.y, 0.0);
      points->SetPoint(1, end.x, end.y, 0.0);
      points->Modified();
      label.leader->SetVisibility(placed[k].needs_leader);
    }
  }

  struct Label {
    Eigen::Vector3d anchor;
    vtkSmartPointer<vtkTextActor> text;
    vtkSmartPointer<vtkActor2D> leader;
  };

  vtkRenderer* renderer_;
  const ExportScene& scene_;
  const DisplayScene& display_;
  ViewOptions options_;
  int font_px_ = 13;
  std::vector<Label> labels_;
  std::vector<double> grid_x_, grid_y_;
  std::vector<vtkSmartPointer<vtkTextActor>> axis_values_, axis_titles_;
  std::vector<vtkSmartPointer<vtkActor2D>> legend_;
  cv::Rect2d legend_box_;
  vtkSmartPointer<vtkTextActor> pose_text_;
  vtkSmartPointer<vtkActor> pose_axes_[3];
  long selected_pose_ = -1;
  vtkNew<vtkCallbackCommand> layout_callback_;
};

// One off-screen render at a time: VTK's OpenGL state and Mesa's context
// creation are not meant to be shared between threads.
std::mutex& RenderMutex() {
  static std::mutex mutex;
  return mutex;
}

}  // namespace

bool ViewOptions::Validate(std::string* why) const {
  if (width_px < 64 || height_px < 64 || width_px > 8192 || height_px > 8192) {
    *why = "the view must be 64 to 8192 pixels wide and high";
    return false;
  }
  if (!(min_existence >= 0.0 && min_existence <= 1.0)) {
    *why = "min-existence must be in [0, 1]";
    return false;
  }
  return true;
}

cv::Mat RenderView(const ExportScene& scene, const DisplayScene& display,
                   const ViewOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("view: " + why);
  const std::lock_guard<std::mutex> lock(RenderMutex());
  const EglContext context(options.width_px, options.height_px);
  cv::Mat image;
  {
    vtkNew<EglRenderWindow> window;
    window->SetSize(options.width_px, options.height_px);
    window->SetOffScreenRendering(1);
    window->SetIsCurrent(true);
    window->SetReadyForRendering(true);
    window->SetOwnContext(0);
    window->SetMultiSamples(0);  // FXAA instead: cheaper on a software rasteriser
    vtkNew<vtkRenderer> renderer;
    window->AddRenderer(renderer);
    ViewScene view(renderer, scene, display, options);
    window->Render();
    vtkNew<vtkWindowToImageFilter> grab;
    grab->SetInput(window);
    grab->SetInputBufferTypeToRGB();
    grab->ReadFrontBufferOff();
    grab->Update();
    vtkImageData* pixels = grab->GetOutput();
    int dimensions[3];
    pixels->GetDimensions(dimensions);
    if (dimensions[0] != options.width_px || dimensions[1] != options.height_px)
      throw Error("off-screen rendering: got a " + std::to_string(dimensions[0]) + "x" +
                  std::to_string(dimensions[1]) + " image");
    const cv::Mat rgb(dimensions[1], dimensions[0], CV_8UC3, pixels->GetScalarPointer());
    cv::Mat flipped;
    cv::flip(rgb, flipped, 0);  // OpenGL's rows run bottom up
    cv::cvtColor(flipped, image, cv::COLOR_RGB2BGR);
    window->Finalize();
  }
  return image;
}

void ShowView(const ExportScene& scene, const DisplayScene& display, const ViewOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("view: " + why);
  const char* x_display = std::getenv("DISPLAY");
  if (x_display == nullptr || *x_display == '\0')
    throw Error(
        "oslam view: no display (DISPLAY is not set); --screenshot FILE.png renders "
        "off-screen");
  vtkNew<vtkRenderWindow> window;
  window->SetSize(options.width_px, options.height_px);
  window->SetWindowName("oslam view");
  vtkNew<vtkRenderer> renderer;
  window->AddRenderer(renderer);
  ViewScene view(renderer, scene, display, options);
  vtkNew<vtkRenderWindowInteractor> interactor;
  vtkNew<vtkInteractorStyleTrackballCamera> style;
  interactor->SetInteractorStyle(style);
  interactor->SetRenderWindow(window);
  // Left/Right: previous/next estimated pose.
  struct KeyContext {
    ViewScene* view;
    vtkRenderWindowInteractor* interactor;
    long poses;
  } keys{&view, interactor, static_cast<long>(scene.map.trajectory.size())};
  vtkNew<vtkCallbackCommand> on_key;
  on_key->SetClientData(&keys);
  on_key->SetCallback([](vtkObject*, unsigned long, void* data, void*) {
    auto* k = static_cast<KeyContext*>(data);
    const std::string key = k->interactor->GetKeySym() ? k->interactor->GetKeySym() : "";
    if (k->poses == 0 || (key != "Left" && key != "Right")) return;
    const long current = std::max(0L, k->view->selected_pose());
    const long next =
        key == "Right" ? (current + 1) % k->poses : (current + k->poses - 1) % k->poses;
    k->view->SelectPose(next);
    k->interactor->Render();
  });
  interactor->AddObserver(vtkCommand::KeyPressEvent, on_key);
  window->Render();
  interactor->Start();
}

}  // namespace oslam

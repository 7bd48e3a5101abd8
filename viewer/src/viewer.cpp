#include "tsf/viewer/viewer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <thread>

#include <X11/Xlib.h>
#include <vtkActor.h>
#include <vtkActor2D.h>
#include <vtkAnnotatedCubeActor.h>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCapsuleSource.h>
#include <vtkCellArray.h>
#include <vtkCommand.h>
#include <vtkCoordinate.h>
#include <vtkCubeSource.h>
#include <vtkImageActor.h>
#include <vtkImageData.h>
#include <vtkImageMapper3D.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkLight.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPNGWriter.h>
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
#include <vtkSphereSource.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkTransform.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowToImageFilter.h>

#include "tsf/common/error.h"
#include "tsf/haptics/input_device.h"
#include "tsf/viewer/label_colours.h"
#include "tsf/viewer/live_haptics.h"
#include "tsf/viewer/surface_uploader.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::viewer {

const char* const kViewerKeyHelp =
    "mouse: move tool (no button), rotate (left drag), pan (middle), zoom (right drag, wheel) | "
    "up/down, PgUp/PgDn (held): tool depth | space: engage/lift tool | p/a/c: press/ablate/cut | "
    "t: next tool | x/y/z: slices | l: labels | h: HUD | r: reset camera | q, Esc: quit";

DisplayStatus x_display_status() {
  DisplayStatus s;
  const char* name = std::getenv("DISPLAY");
  if (name == nullptr || *name == '\0') {
    s.reason =
        "no X display: DISPLAY is unset (Debian's VTK renders through X only; run under "
        "`xvfb-run -a` for offscreen frames)";
    return s;
  }
  // Xlib must be told before its first call that more than one thread may use it.
  static const Status threads = XInitThreads();
  (void)threads;
  // A server that is resetting (its last client just left) refuses connections for a moment:
  // try a few times over about half a second before calling the display unavailable.
  Display* d = nullptr;
  for (int attempt = 0; attempt < 5 && d == nullptr; ++attempt) {
    if (attempt > 0) std::this_thread::sleep_for(std::chrono::milliseconds(100 * attempt));
    d = XOpenDisplay(name);
  }
  if (d == nullptr) {
    s.reason = std::string("cannot open the X display '") + name +
               "' (is the X server running? try `xvfb-run -a`)";
    return s;
  }
  XCloseDisplay(d);
  s.available = true;
  return s;
}

void ViewOptions::validate() const {
  require(width >= 64 && width <= 8192,
          "view: width must be in [64, 8192], got " + std::to_string(width));
  require(height >= 64 && height <= 8192,
          "view: height must be in [64, 8192], got " + std::to_string(height));
  require(camera.zoom > 0 && std::isfinite(camera.zoom), "view: camera.zoom must be > 0");
  require(slices.opacity > 0 && slices.opacity <= 1, "view: slices.opacity must be in (0, 1]");
  require(frame_s > 0 && frame_s <= 1, "view: frame time must be in (0, 1] s");
}

namespace {

using Clock = std::chrono::steady_clock;

const char* mode_name(interaction::ToolMode m) {
  return interaction::to_string(m);
}

std::array<double, 3> mode_colour(interaction::ToolMode m) {
  switch (m) {
    case interaction::ToolMode::kPress:
      return {0.35, 0.6, 1.0};
    case interaction::ToolMode::kAblate:
      return {1.0, 0.55, 0.1};
    case interaction::ToolMode::kCut:
      return {1.0, 0.2, 0.25};
    default:
      return {0.75, 0.75, 0.78};
  }
}

/// The tool's surface in its local frame (tool.h: capsule along local z, blade extents x, y, z).
vtkSmartPointer<vtkPolyData> tool_geometry(const interaction::Tool& t) {
  switch (t.shape) {
    case collision::ToolShape::kSphere: {
      vtkNew<vtkSphereSource> s;
      s->SetRadius(t.radius_mm);
      s->SetThetaResolution(32);
      s->SetPhiResolution(24);
      s->Update();
      return s->GetOutput();
    }
    case collision::ToolShape::kCapsule: {
      // vtkCapsuleSource lies along y; turn it onto z.
      vtkNew<vtkCapsuleSource> c;
      c->SetRadius(t.radius_mm);
      c->SetCylinderLength(2 * t.half_length_mm);
      c->SetThetaResolution(32);
      c->SetPhiResolution(24);
      c->Update();
      vtkSmartPointer<vtkPolyData> out = vtkSmartPointer<vtkPolyData>::New();
      out->DeepCopy(c->GetOutput());
      vtkNew<vtkTransform> rot;
      rot->RotateX(90);
      vtkPoints* pts = out->GetPoints();
      for (vtkIdType i = 0; i < pts->GetNumberOfPoints(); ++i) {
        double p[3];
        pts->GetPoint(i, p);
        rot->TransformPoint(p, p);
        pts->SetPoint(i, p);
      }
      out->GetPointData()->SetNormals(nullptr);
      return out;
    }
    case collision::ToolShape::kMesh: {
      vtkNew<vtkPoints> points;
      for (const Vec3f& v : t.mesh->vertices) points->InsertNextPoint(v.x, v.y, v.z);
      vtkNew<vtkCellArray> cells;
      for (const auto& tri : t.mesh->triangles) {
        const vtkIdType ids[3] = {tri[0], tri[1], tri[2]};
        cells->InsertNextCell(3, ids);
      }
      vtkSmartPointer<vtkPolyData> out = vtkSmartPointer<vtkPolyData>::New();
      out->SetPoints(points);
      out->SetPolys(cells);
      return out;
    }
    case collision::ToolShape::kBlade:
    default: {
      vtkNew<vtkCubeSource> b;
      b->SetXLength(2 * t.half_extents_mm.x);
      b->SetYLength(2 * t.half_extents_mm.y);
      b->SetZLength(2 * t.half_extents_mm.z);
      b->Update();
      return b->GetOutput();
    }
  }
}

void set_pose(vtkActor* actor, const ToolPose& pose) {
  vtkNew<vtkTransform> t;
  t->Translate(pose.position.x, pose.position.y, pose.position.z);
  const Rotation& q = pose.orientation;
  const double w = std::clamp(q.w, -1.0, 1.0);
  const double angle = 2 * std::acos(w) * 180.0 / M_PI;
  const double s = std::sqrt(std::max(0.0, 1 - w * w));
  if (s > 1e-9) t->RotateWXYZ(angle, q.x / s, q.y / s, q.z / s);
  actor->SetUserTransform(t);
}

std::string thousands(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.0f", v);
  std::string s = buf, out;
  const std::size_t start = (s[0] == '-') ? 1 : 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    out += s[i];
    const std::size_t left = s.size() - 1 - i;
    if (i >= start && left > 0 && left % 3 == 0) out += ',';
  }
  return out;
}

/// A two-series strip chart in the lower right of the viewport (normalised viewport coords).
class LivePlot {
 public:
  static constexpr std::size_t kSamples = 240;
  explicit LivePlot(vtkRenderer* renderer) {
    for (int s = 0; s < 2; ++s) {
      lines_[s] = vtkSmartPointer<vtkPolyData>::New();
      vtkNew<vtkPolyDataMapper2D> m;
      m->SetInputData(lines_[s]);
      vtkNew<vtkCoordinate> c;
      c->SetCoordinateSystemToNormalizedViewport();
      m->SetTransformCoordinate(c);
      actors_[s] = vtkSmartPointer<vtkActor2D>::New();
      actors_[s]->SetMapper(m);
      actors_[s]->GetProperty()->SetLineWidth(2);
      renderer->AddActor2D(actors_[s]);
      labels_[s] = vtkSmartPointer<vtkTextActor>::New();
      labels_[s]->GetTextProperty()->SetFontSize(14);
      labels_[s]->GetTextProperty()->SetFontFamilyToCourier();
      labels_[s]->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
      labels_[s]->SetPosition(kX0 + 0.005, kY1 + 0.005 + 0.028 * s);
      renderer->AddActor2D(labels_[s]);
    }
    actors_[0]->GetProperty()->SetColor(1.0, 0.6, 0.2);
    labels_[0]->GetTextProperty()->SetColor(1.0, 0.6, 0.2);
    actors_[1]->GetProperty()->SetColor(0.4, 0.85, 1.0);
    labels_[1]->GetTextProperty()->SetColor(0.4, 0.85, 1.0);
    // Frame and background.
    frame_ = vtkSmartPointer<vtkPolyData>::New();
    vtkNew<vtkPoints> p;
    p->InsertNextPoint(kX0, kY0, 0);
    p->InsertNextPoint(kX1, kY0, 0);
    p->InsertNextPoint(kX1, kY1, 0);
    p->InsertNextPoint(kX0, kY1, 0);
    vtkNew<vtkCellArray> poly;
    const vtkIdType quad[4] = {0, 1, 2, 3};
    poly->InsertNextCell(4, quad);
    frame_->SetPoints(p);
    frame_->SetPolys(poly);
    vtkNew<vtkPolyDataMapper2D> fm;
    fm->SetInputData(frame_);
    vtkNew<vtkCoordinate> c;
    c->SetCoordinateSystemToNormalizedViewport();
    fm->SetTransformCoordinate(c);
    background_ = vtkSmartPointer<vtkActor2D>::New();
    background_->SetMapper(fm);
    background_->GetProperty()->SetColor(0.05, 0.06, 0.09);
    background_->GetProperty()->SetOpacity(0.75);
    renderer->AddActor2D(background_);
    // Draw the background first: re-add the series after it.
    for (int s = 0; s < 2; ++s) {
      renderer->RemoveActor2D(actors_[s]);
      renderer->AddActor2D(actors_[s]);
    }
  }

  void add(double force_un, double steps_per_s) {
    samples_[0].push_back(force_un);
    samples_[1].push_back(steps_per_s);
    for (auto& s : samples_)
      while (s.size() > kSamples) s.pop_front();
  }

  /// The first series' name: the tool's contact force, or the haptic device's force.
  void set_force_name(const char* name) { force_name_ = name; }

  void update() {
    const char* const names[2] = {force_name_, "sim rate   "};
    static const char* const units[2] = {"uN", "steps/s"};
    for (int s = 0; s < 2; ++s) {
      const auto& v = samples_[s];
      double hi = 0;
      for (double x : v) hi = std::max(hi, x);
      const double scale = hi > 0 ? 1.0 / (hi * 1.1) : 0.0;
      vtkNew<vtkPoints> p;
      vtkNew<vtkCellArray> line;
      line->InsertNextCell(static_cast<vtkIdType>(v.size()));
      for (std::size_t i = 0; i < v.size(); ++i) {
        const double x = kX0 + (kX1 - kX0) * static_cast<double>(i) / (kSamples - 1);
        const double y = kY0 + 0.01 + (kY1 - kY0 - 0.02) * v[i] * scale;
        line->InsertCellPoint(p->InsertNextPoint(x, y, 0));
      }
      lines_[s]->SetPoints(p);
      lines_[s]->SetLines(line);
      char buf[128];
      std::snprintf(buf, sizeof buf, "%s now %s  max %s %s", names[s],
                    thousands(v.empty() ? 0.0 : v.back()).c_str(), thousands(hi).c_str(), units[s]);
      labels_[s]->SetInput(buf);
    }
  }

  void set_visible(bool on) {
    background_->SetVisibility(on);
    for (int s = 0; s < 2; ++s) {
      actors_[s]->SetVisibility(on);
      labels_[s]->SetVisibility(on);
    }
  }

 private:
  static constexpr double kX0 = 0.62, kX1 = 0.985, kY0 = 0.03, kY1 = 0.22;
  const char* force_name_ = "|tool force|";
  std::deque<double> samples_[2];
  vtkSmartPointer<vtkPolyData> lines_[2];
  vtkSmartPointer<vtkActor2D> actors_[2];
  vtkSmartPointer<vtkTextActor> labels_[2];
  vtkSmartPointer<vtkPolyData> frame_;
  vtkSmartPointer<vtkActor2D> background_;
};

}  // namespace

// ---- the interactor style: the mouse holds the tool -----------------------------------------

class ToolInteractorStyle : public vtkInteractorStyleTrackballCamera {
 public:
  static ToolInteractorStyle* New();
  vtkTypeMacro(ToolInteractorStyle, vtkInteractorStyleTrackballCamera) Viewer::Impl* impl = nullptr;
  void OnMouseMove() override;
  void OnChar() override;
  void OnKeyPress() override;
  void OnKeyRelease() override;
};
vtkStandardNewMacro(ToolInteractorStyle);

struct Viewer::Impl {
  SimulationSession* session = nullptr;
  ViewOptions options;
  vtkSmartPointer<vtkRenderWindow> window;
  vtkSmartPointer<vtkRenderer> renderer;
  vtkSmartPointer<vtkRenderer> marker_renderer;  // the orientation cube (null: no patient frame)
  vtkSmartPointer<vtkRenderWindowInteractor> interactor;
  SurfaceUploader uploader;
  vtkSmartPointer<vtkActor> surface_actor;
  std::vector<vtkSmartPointer<vtkActor>> tool_actors;  // one per session tool
  vtkSmartPointer<vtkImageData> slice_image;           // RGB, grey density with the label overlay
  std::vector<std::uint8_t> slice_grey, slice_labels;
  std::string slice_description;
  vtkSmartPointer<vtkImageActor> slice_actors[3];  // sagittal (x), coronal (y), axial (z)
  int slice_index[3] = {0, 0, 0};
  int slice_lo[3] = {0, 0, 0}, slice_hi[3] = {0, 0, 0};  // voxels that show something
  vtkSmartPointer<vtkTextActor> hud, help;
  std::unique_ptr<LivePlot> plot;
  SimulationStats stats;
  ToolCommand command;  // what the hand holds (window mode)
  interaction::ToolMode armed_mode = interaction::ToolMode::kPress;  // mode when engaged
  bool engaged = false;
  SimulationThread* thread = nullptr;
  LiveHaptics* haptics = nullptr;         // the session's live haptics (null: none)
  haptics::InputDevice* input = nullptr;  // its device, when the mouse and keys are the device
  const ViewScript* script = nullptr;     // window: hands played in wall-clock time
  Clock::time_point window_start;
  Vec3d shown_force{0, 0, 0};       // the force in the HUD and plot this frame
  std::deque<double> render_times;  // seconds, recent renders
  std::deque<Clock::time_point> render_stamps;
  int frames_rendered = 0;
  double bounds[6] = {0, 1, 0, 1, 0, 1};

  void build_slices(const SliceVolume& volume);
  void refresh_slice_colours();
  void place_slices(const Vec3d& mm);
  void reset_camera();
  void update_frame(const std::vector<ToolCommand>& shown);
  void update_hud(const std::vector<ToolCommand>& shown);
  /// Where the first hand's tool is now: the device's pose with live haptics, else the mouse's.
  Vec3d hand_position() const {
    return haptics != nullptr ? haptics->device_state().pose.position : command.pose.position;
  }
  void build_orientation_cube();
  void sync_orientation_cube();
  void push_command() {
    ToolCommand c = command;
    c.mode = engaged ? armed_mode : interaction::ToolMode::kIdle;
    if (input != nullptr) input->set_pressing(engaged);
    if (thread != nullptr && script == nullptr) thread->set_tool(c);
  }
  /// The hands of the window's view script at the wall time now (played in real time).
  std::vector<ToolCommand> scripted_hands() const {
    const double t = std::chrono::duration<double>(Clock::now() - window_start).count();
    return script->commands_at(static_cast<int>(std::floor(t / options.frame_s)));
  }
};

void ToolInteractorStyle::OnMouseMove() {
  vtkRenderWindowInteractor* rwi = GetInteractor();
  const bool buttons = State != VTKIS_NONE;
  if (buttons || impl == nullptr) {
    vtkInteractorStyleTrackballCamera::OnMouseMove();
    return;
  }
  // Move the tool in the screen-parallel plane through its current position.
  vtkRenderer* r = impl->renderer;
  const Vec3d p = impl->hand_position();
  r->SetWorldPoint(p.x, p.y, p.z, 1.0);
  r->WorldToDisplay();
  const double depth = r->GetDisplayPoint()[2];
  const int* pos = rwi->GetEventPosition();
  r->SetDisplayPoint(pos[0], pos[1], depth);
  r->DisplayToWorld();
  const double* w = r->GetWorldPoint();
  if (w[3] != 0.0) {
    const Vec3d target{w[0] / w[3], w[1] / w[3], w[2] / w[3]};
    if (impl->input != nullptr)
      impl->input->move_by(target - p);  // the device moves; the loop reads it at 1 kHz
    else
      impl->command.pose.position = target;
  }
  impl->push_command();
}

void ToolInteractorStyle::OnKeyPress() {
  if (impl == nullptr) return;
  const std::string key = GetInteractor()->GetKeySym() ? GetInteractor()->GetKeySym() : "";
  const bool shift = GetInteractor()->GetShiftKey() != 0;
  double step = shift ? 2.0 : 0.5;  // mm
  if ((key == "Up" || key == "Prior" || key == "Down" || key == "Next") && impl->input != nullptr) {
    // The device: the tool moves along the view direction while the key is held.
    impl->input->key(2, key == "Down" || key == "Next" ? -1 : 1, true);
  } else if (key == "Up" || key == "Prior" || key == "Down" || key == "Next") {
    if (key == "Down" || key == "Next") step = -step;
    // Along the view direction: away from the camera for "Up" (deeper).
    double dir[3];
    impl->renderer->GetActiveCamera()->GetDirectionOfProjection(dir);
    Vec3d& p = impl->command.pose.position;
    p = p + Vec3d{dir[0], dir[1], dir[2]} * step;
    impl->push_command();
  } else if (key == "Escape") {
    GetInteractor()->TerminateApp();
  }
}

void ToolInteractorStyle::OnKeyRelease() {
  if (impl == nullptr || impl->input == nullptr) return;
  const std::string key = GetInteractor()->GetKeySym() ? GetInteractor()->GetKeySym() : "";
  if (key == "Up" || key == "Prior" || key == "Down" || key == "Next")
    impl->input->key(2, 0, false);
}

void ToolInteractorStyle::OnChar() {
  if (impl == nullptr) return;
  const char c = GetInteractor()->GetKeyCode();
  Viewer::Impl& v = *impl;
  switch (c) {
    case ' ':
      v.engaged = !v.engaged;
      break;
    case 'p':
      v.armed_mode = interaction::ToolMode::kPress;
      break;
    case 'a':
      v.armed_mode = interaction::ToolMode::kAblate;
      break;
    case 'c':
      v.armed_mode = interaction::ToolMode::kCut;
      break;
    case 't':
      v.engaged = false;
      v.command.tool = (v.command.tool + 1) % static_cast<int>(v.session->tools().size());
      break;
    case 'x':
    case 'y':
    case 'z': {
      vtkImageActor* a = v.slice_actors[c - 'x'];
      if (a != nullptr) a->SetVisibility(!a->GetVisibility());
      break;
    }
    case 'l':
      v.options.slices.labels = !v.options.slices.labels;
      v.refresh_slice_colours();
      break;
    case 'h':
      v.options.show_hud = !v.options.show_hud;
      v.hud->SetVisibility(v.options.show_hud);
      v.help->SetVisibility(v.options.show_hud);
      v.plot->set_visible(v.options.show_hud && v.options.show_plot);
      break;
    case 'r':
      v.reset_camera();
      break;
    case 'q':
      GetInteractor()->TerminateApp();
      break;
    default:
      break;  // VTK's own keys (wireframe, stereo, fly-to...) are off on purpose
  }
  // A mode the tool cannot run (cut with a sphere) stays armed but is refused with a message.
  const interaction::Tool& tool = v.session->tools()[static_cast<std::size_t>(v.command.tool)].tool;
  if (v.engaged && !tool.supports(v.armed_mode)) v.engaged = false;
  v.push_command();
}

// ---- slices -----------------------------------------------------------------------------------

void Viewer::Impl::build_slices(const SliceVolume& volume) {
  volume.validate();
  const VolumeGeometry& g = volume.geometry;
  slice_image = vtkSmartPointer<vtkImageData>::New();
  slice_image->SetDimensions(g.dims.x, g.dims.y, g.dims.z);
  slice_image->SetSpacing(g.spacing.x, g.spacing.y, g.spacing.z);
  slice_image->SetOrigin(g.origin.x, g.origin.y, g.origin.z);
  slice_image->AllocateScalars(VTK_UNSIGNED_CHAR, 4);
  const std::size_t n = volume.values.size();
  slice_grey.resize(n);
  slice_labels = volume.labels;
  if (slice_labels.empty()) slice_labels.assign(n, kLabelOutside);
  const double lo = volume.window_low, scale = 255.0 / (volume.window_high - volume.window_low);
  for (std::size_t i = 0; i < n; ++i)
    slice_grey[i] = static_cast<std::uint8_t>(
        std::lround(std::clamp((double{volume.values[i]} - lo) * scale, 0.0, 255.0)));
  slice_description = volume.description;
  // The planes span the voxels that show something (above the window's black, or labelled):
  // opaque planes cropped to the body hide less of the scene than whole-volume planes, and stay
  // in the opaque pass (see-through air would need depth peeling, which llvmpipe renders badly).
  int first[3] = {g.dims.x, g.dims.y, g.dims.z}, last[3] = {-1, -1, -1};
  std::size_t i = 0;
  for (int z = 0; z < g.dims.z; ++z)
    for (int y = 0; y < g.dims.y; ++y)
      for (int x = 0; x < g.dims.x; ++x, ++i)
        if (slice_labels[i] != kLabelOutside) {
          const int c[3] = {x, y, z};
          for (int a = 0; a < 3; ++a) {
            first[a] = std::min(first[a], c[a]);
            last[a] = std::max(last[a], c[a]);
          }
        }
  for (int a = 0; a < 3; ++a) {
    slice_lo[a] = last[a] >= first[a] ? first[a] : 0;
    slice_hi[a] = last[a] >= first[a] ? last[a] : g.dims[a] - 1;
  }
  refresh_slice_colours();
  for (int a = 0; a < 3; ++a) {
    slice_actors[a] = vtkSmartPointer<vtkImageActor>::New();
    slice_actors[a]->GetMapper()->SetInputData(slice_image);
    slice_actors[a]->SetOpacity(options.slices.opacity);
    slice_actors[a]->InterpolateOn();
    const bool on =
        options.slices.show && (a == 0 ? options.slices.sagittal
                                       : (a == 1 ? options.slices.coronal : options.slices.axial));
    slice_actors[a]->SetVisibility(on);
    renderer->AddActor(slice_actors[a]);
  }
}

void Viewer::Impl::refresh_slice_colours() {
  if (!slice_image) return;
  auto* rgb = static_cast<std::uint8_t*>(slice_image->GetScalarPointer());
  const bool labels = options.slices.labels;
  for (std::size_t i = 0; i < slice_grey.size(); ++i) {
    const double grey = slice_grey[i];
    double out[3] = {grey, grey, grey};
    if (labels) {
      const double a = label_overlay_opacity(slice_labels[i]);
      const Rgb c = label_colour(slice_labels[i]);
      for (int k = 0; k < 3; ++k) out[k] = (1 - a) * grey + a * c[static_cast<std::size_t>(k)];
    }
    for (int k = 0; k < 3; ++k) rgb[4 * i + k] = static_cast<std::uint8_t>(std::lround(out[k]));
    // Air around the body (black, unlabelled) is see-through.
    rgb[4 * i + 3] = (slice_grey[i] == 0 && slice_labels[i] == kLabelOutside) ? 0 : 255;
  }
  slice_image->Modified();
}

void Viewer::Impl::place_slices(const Vec3d& mm) {
  if (!slice_image) return;
  int dims[3];
  double origin[3], spacing[3];
  slice_image->GetDimensions(dims);
  slice_image->GetOrigin(origin);
  slice_image->GetSpacing(spacing);
  for (int a = 0; a < 3; ++a) {
    const double v = a == 0 ? mm.x : (a == 1 ? mm.y : mm.z);
    slice_index[a] =
        std::clamp(static_cast<int>(std::lround((v - origin[a]) / spacing[a])), 0, dims[a] - 1);
  }
  const int* l = slice_lo;
  const int* h = slice_hi;
  slice_actors[0]->SetDisplayExtent(slice_index[0], slice_index[0], l[1], h[1], l[2], h[2]);
  slice_actors[1]->SetDisplayExtent(l[0], h[0], slice_index[1], slice_index[1], l[2], h[2]);
  slice_actors[2]->SetDisplayExtent(l[0], h[0], l[1], h[1], slice_index[2], slice_index[2]);
}

void Viewer::Impl::reset_camera() {
  const CameraOptions& c = options.camera;
  Vec3d centre{(bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2,
               (bounds[4] + bounds[5]) / 2};
  if (std::isfinite(c.focus_mm.x) && std::isfinite(c.focus_mm.y) && std::isfinite(c.focus_mm.z))
    centre = c.focus_mm;
  const double diag = std::sqrt((bounds[1] - bounds[0]) * (bounds[1] - bounds[0]) +
                                (bounds[3] - bounds[2]) * (bounds[3] - bounds[2]) +
                                (bounds[5] - bounds[4]) * (bounds[5] - bounds[4]));
  vtkCamera* cam = renderer->GetActiveCamera();
  const Vec3d ant = options.patient.anterior, up = options.patient.superior;
  cam->SetFocalPoint(centre.x, centre.y, centre.z);
  cam->SetPosition(centre.x + 2.0 * diag * ant.x, centre.y + 2.0 * diag * ant.y,
                   centre.z + 2.0 * diag * ant.z);
  cam->SetViewUp(up.x, up.y, up.z);
  cam->SetViewAngle(30);
  cam->Azimuth(c.azimuth_deg);
  cam->Elevation(c.elevation_deg);
  cam->OrthogonalizeViewUp();
  cam->Zoom(c.zoom);
  renderer->ResetCameraClippingRange();
}

// ---- frames -----------------------------------------------------------------------------------

void Viewer::Impl::update_frame(const std::vector<ToolCommand>& shown) {
  const Clock::time_point start = Clock::now();
  stats = session->exchange().consume(
      [&](const SurfaceBuffers& b, const SurfaceDelta& d) { uploader.apply(b, d); });
  for (std::size_t i = 0; i < tool_actors.size(); ++i) {
    vtkActor* a = tool_actors[i];
    const ToolCommand* hand = nullptr;
    for (const ToolCommand& c : shown)
      if (c.tool == static_cast<int>(i)) hand = &c;
    const bool visible = options.show_tool && hand != nullptr;
    a->SetVisibility(visible);
    if (!visible) continue;
    set_pose(a, hand->pose);
    const auto col = mode_colour(hand->mode);
    a->GetProperty()->SetColor(col[0], col[1], col[2]);
    a->GetProperty()->SetOpacity(hand->mode == interaction::ToolMode::kIdle ? 0.55 : 0.9);
  }
  shown_force = haptics != nullptr ? haptics->force_un() : stats.tool_force_un;
  if (haptics != nullptr) haptics->note_force(length(shown_force));
  if (options.show_plot) {
    plot->add(length(shown_force), stats.steps_per_s);
    plot->update();
  }
  update_hud(shown);
  renderer->ResetCameraClippingRange();
  sync_orientation_cube();
  window->Render();
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  render_times.push_back(seconds);
  render_stamps.push_back(Clock::now());
  while (render_times.size() > 60) render_times.pop_front();
  while (render_stamps.size() > 2 &&
         render_stamps.back() - render_stamps.front() > std::chrono::seconds(1))
    render_stamps.pop_front();
  ++frames_rendered;
}

/// The patient direction a tissue axis points toward: "L", "R", "A", "P", "S" or "I" for the
/// patient axis it is closest to (with "?" when left/right is not recorded).
std::string patient_letter(const PatientAxes& p, const Vec3d& axis) {
  const double l = dot(axis, p.left), a = dot(axis, p.anterior), s = dot(axis, p.superior);
  if (std::abs(l) >= std::abs(a) && std::abs(l) >= std::abs(s))
    return std::string(l > 0 ? "L" : "R") + (p.left_right_known ? "" : "?");
  if (std::abs(a) >= std::abs(s)) return a > 0 ? "A" : "P";
  return s > 0 ? "S" : "I";
}

void Viewer::Impl::build_orientation_cube() {
  const PatientAxes& p = options.patient;
  if (!p.known) return;
  vtkNew<vtkAnnotatedCubeActor> cube;
  cube->SetXPlusFaceText(patient_letter(p, {1, 0, 0}).c_str());
  cube->SetXMinusFaceText(patient_letter(p, {-1, 0, 0}).c_str());
  cube->SetYPlusFaceText(patient_letter(p, {0, 1, 0}).c_str());
  cube->SetYMinusFaceText(patient_letter(p, {0, -1, 0}).c_str());
  cube->SetZPlusFaceText(patient_letter(p, {0, 0, 1}).c_str());
  cube->SetZMinusFaceText(patient_letter(p, {0, 0, -1}).c_str());
  cube->SetFaceTextScale(0.55);
  cube->GetCubeProperty()->SetColor(0.32, 0.36, 0.44);
  cube->GetTextEdgesProperty()->SetColor(0.9, 0.9, 0.9);
  for (vtkProperty* f : {cube->GetXPlusFaceProperty(), cube->GetXMinusFaceProperty()})
    f->SetColor(1.0, 0.45, 0.45);
  for (vtkProperty* f : {cube->GetYPlusFaceProperty(), cube->GetYMinusFaceProperty()})
    f->SetColor(0.5, 0.9, 0.5);
  for (vtkProperty* f : {cube->GetZPlusFaceProperty(), cube->GetZMinusFaceProperty()})
    f->SetColor(0.5, 0.7, 1.0);
  marker_renderer = vtkSmartPointer<vtkRenderer>::New();
  marker_renderer->SetViewport(0.86, 0.76, 0.995, 0.985);
  marker_renderer->SetLayer(1);
  marker_renderer->InteractiveOff();
  marker_renderer->AddActor(cube);
  window->SetNumberOfLayers(2);
  window->AddRenderer(marker_renderer);
}

void Viewer::Impl::sync_orientation_cube() {
  if (!marker_renderer) return;
  vtkCamera* main = renderer->GetActiveCamera();
  vtkCamera* cam = marker_renderer->GetActiveCamera();
  double dop[3], up[3];
  main->GetDirectionOfProjection(dop);
  main->GetViewUp(up);
  cam->SetFocalPoint(0, 0, 0);
  cam->SetPosition(-3.2 * dop[0], -3.2 * dop[1], -3.2 * dop[2]);
  cam->SetViewUp(up);
  marker_renderer->ResetCameraClippingRange();
}

void Viewer::Impl::update_hud(const std::vector<ToolCommand>& hands) {
  if (!options.show_hud) return;
  const ToolCommand shown =
      hands.empty() ? ToolCommand{-1, {}, interaction::ToolMode::kIdle} : hands.front();
  double fps = 0;
  if (render_stamps.size() >= 2)
    fps = static_cast<double>(render_stamps.size() - 1) /
          std::chrono::duration<double>(render_stamps.back() - render_stamps.front()).count();
  double mean = 0;
  for (double t : render_times) mean += t;
  if (!render_times.empty()) mean /= static_cast<double>(render_times.size());
  const bool holding = shown.tool >= 0 && shown.tool < static_cast<int>(session->tools().size());
  const NamedTool& tool = session->tools()[static_cast<std::size_t>(holding ? shown.tool : 0)];
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "backend  %s   lattice %d x %d x %d (%s nodes alive)   dt %.3g s (%.2fx the "
                "stable estimate)   %s\n"
                "sim      %s steps/s   %.3gx real time   t = %.4f s\n"
                "render   %.0f fps   %.1f ms/frame   %s triangles\n"
                "tool     %s (%s)  [%s%s]   |F| = %s uN   removed %.1f mm3%s%s",
                stats.backend.c_str(), stats.lattice_dims.x, stats.lattice_dims.y,
                stats.lattice_dims.z, thousands(static_cast<double>(stats.alive_nodes)).c_str(),
                stats.dt_s, stats.dt_over_estimate, stats.stability.c_str(),
                thousands(stats.steps_per_s).c_str(), stats.realtime, stats.simulated_s, fps,
                mean * 1e3, thousands(static_cast<double>(uploader.live_triangles())).c_str(),
                holding ? tool.name.c_str() : "none",
                holding ? interaction::to_string(tool.tool.shape) : "-", mode_name(shown.mode),
                (options.offscreen || shown.mode != interaction::ToolMode::kIdle)
                    ? ""
                    : (std::string(", space: ") + mode_name(armed_mode)).c_str(),
                thousands(length(stats.tool_force_un)).c_str(), stats.removed_mm3,
                stats.error.empty() ? "" : "\nSTOPPED  ", stats.error.c_str());
  std::string text = buf;
  for (std::size_t h = 1; h < hands.size(); ++h) {
    if (hands[h].tool < 0 || hands[h].tool >= static_cast<int>(session->tools().size())) continue;
    const NamedTool& other = session->tools()[static_cast<std::size_t>(hands[h].tool)];
    std::snprintf(buf, sizeof buf, "\nhand %zu   %s (%s)  [%s]", h + 1, other.name.c_str(),
                  interaction::to_string(other.tool.shape), mode_name(hands[h].mode));
    text += buf;
  }
  if (haptics != nullptr) {
    const LiveHapticsOptions& ho = haptics->options();
    if (haptics->running())
      std::snprintf(
          buf, sizeof buf, "\nhaptics  %s model, %s at %.0f Hz (%.0f achieved)   |F| = %s uN",
          haptics::to_string(ho.model), haptics->device().describe().c_str(), ho.loop.rate_hz,
          haptics->recent_rate_hz(), thousands(length(shown_force)).c_str());
    else
      std::snprintf(buf, sizeof buf, "\nhaptics  %s model, %s, one tick per frame   |F| = %s uN",
                    haptics::to_string(ho.model), haptics->device().describe().c_str(),
                    thousands(length(shown_force)).c_str());
    text += buf;
  }
  if (options.slices.show && !slice_description.empty())
    text += "\nslices   " + slice_description + (options.slices.labels ? " + tissue labels" : "");
  if (!options.patient.description.empty()) text += "\npatient  " + options.patient.description;
  if (!stats.warning.empty()) text += "\nWARNING  " + stats.warning;
  hud->SetInput(text.c_str());
}

// ---- Viewer -------------------------------------------------------------------------------------

Viewer::Viewer(SimulationSession& session, const SliceVolume* slices, const ViewOptions& options)
    : impl_(std::make_unique<Impl>()), options_(options) {
  options.validate();
  const DisplayStatus display = x_display_status();
  if (!display.available) throw Error("tsf view: " + display.reason);
  Impl& v = *impl_;
  v.session = &session;
  v.options = options;
  v.renderer = vtkSmartPointer<vtkRenderer>::New();
  v.renderer->GradientBackgroundOn();
  v.renderer->SetBackground(0.09, 0.1, 0.13);
  v.renderer->SetBackground2(0.28, 0.31, 0.38);
  v.window = vtkSmartPointer<vtkRenderWindow>::New();
  v.window->SetSize(options.width, options.height);
  v.window->SetOffScreenRendering(options.offscreen ? 1 : 0);
  v.window->SetWindowName("tsf view");
  // The slice planes are see-through where there is air: depth peeling sorts them against each
  // other (it needs multisampling off; FXAA smooths the edges instead).
  v.window->SetMultiSamples(0);
  v.window->AddRenderer(v.renderer);
  v.build_orientation_cube();
  v.renderer->SetUseDepthPeeling(1);
  v.renderer->SetMaximumNumberOfPeels(8);
  v.renderer->SetOcclusionRatio(0.0);
  v.renderer->UseFXAAOn();

  // Tissue surface: per-vertex label colours, smooth normals, a little specular.
  session.publish_initial();
  v.stats = session.exchange().consume(
      [&](const SurfaceBuffers& b, const SurfaceDelta&) { v.uploader.apply_full(b); });
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(v.uploader.poly_data());
  mapper->SetColorModeToDirectScalars();
  mapper->ScalarVisibilityOn();
  v.surface_actor = vtkSmartPointer<vtkActor>::New();
  v.surface_actor->SetMapper(mapper);
  vtkProperty* prop = v.surface_actor->GetProperty();
  prop->SetInterpolationToPhong();
  prop->SetAmbient(0.15);
  prop->SetDiffuse(0.8);
  prop->SetSpecular(0.25);
  prop->SetSpecularPower(30);
  v.renderer->AddActor(v.surface_actor);
  v.uploader.poly_data()->GetBounds(v.bounds);
  if (v.uploader.live_triangles() == 0) {
    const VolumeGeometry& g = session.model().volume().geometry();
    const Vec3d hi =
        g.index_to_tissue({double(g.dims.x - 1), double(g.dims.y - 1), double(g.dims.z - 1)});
    v.bounds[0] = g.origin.x, v.bounds[1] = hi.x, v.bounds[2] = g.origin.y, v.bounds[3] = hi.y,
    v.bounds[4] = g.origin.z, v.bounds[5] = hi.z;
  }

  // Slice planes through the scan (or the tissue's own volume).
  if (slices != nullptr)
    v.build_slices(*slices);
  else
    v.build_slices(slices_from_tissue(session.model().volume()));
  Vec3d at = options.slices.position_mm;
  if (!std::isfinite(at.x)) at.x = (v.bounds[0] + v.bounds[1]) / 2;
  if (!std::isfinite(at.y)) at.y = (v.bounds[2] + v.bounds[3]) / 2;
  if (!std::isfinite(at.z)) at.z = (v.bounds[4] + v.bounds[5]) / 2;
  v.place_slices(at);

  // Tools.
  for (const NamedTool& t : session.tools()) {
    vtkNew<vtkPolyDataMapper> m;
    m->SetInputData(tool_geometry(t.tool));
    auto a = vtkSmartPointer<vtkActor>::New();
    a->SetMapper(m);
    a->GetProperty()->SetSpecular(0.5);
    a->GetProperty()->SetSpecularPower(40);
    a->SetVisibility(false);
    v.renderer->AddActor(a);
    v.tool_actors.push_back(a);
  }
  // Start the hand above the tissue's centre.
  v.command.pose.position = {(v.bounds[0] + v.bounds[1]) / 2, (v.bounds[2] + v.bounds[3]) / 2,
                             v.bounds[5] + 5.0};
  v.haptics = session.haptics();
  if (v.haptics != nullptr) {
    v.input = dynamic_cast<haptics::InputDevice*>(&v.haptics->device());
    if (v.input != nullptr) v.input->set_home(v.command.pose.position);
  }

  // Overlays.
  v.hud = vtkSmartPointer<vtkTextActor>::New();
  v.hud->GetTextProperty()->SetFontFamilyToCourier();
  v.hud->GetTextProperty()->SetFontSize(std::max(12, options.height / 50));
  v.hud->GetTextProperty()->SetColor(0.92, 0.94, 0.97);
  v.hud->GetTextProperty()->SetBackgroundColor(0.0, 0.0, 0.0);
  v.hud->GetTextProperty()->SetBackgroundOpacity(0.45);
  v.hud->GetTextProperty()->SetVerticalJustificationToTop();
  v.hud->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  v.hud->SetPosition(0.01, 0.985);
  v.hud->SetVisibility(options.show_hud);
  v.renderer->AddActor2D(v.hud);
  v.help = vtkSmartPointer<vtkTextActor>::New();
  v.help->SetInput(options.offscreen ? "tsf view --offscreen" : kViewerKeyHelp);
  v.help->GetTextProperty()->SetFontSize(std::max(10, options.height / 70));
  v.help->GetTextProperty()->SetColor(0.75, 0.78, 0.85);
  v.help->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  v.help->SetPosition(0.01, 0.005);
  v.help->SetVisibility(options.show_hud && !options.offscreen);
  v.renderer->AddActor2D(v.help);
  v.plot = std::make_unique<LivePlot>(v.renderer);
  if (v.haptics != nullptr) v.plot->set_force_name("|haptic F| ");
  v.plot->set_visible(options.show_hud && options.show_plot);

  // Light from the camera plus a fill from above.
  v.renderer->LightFollowCameraOn();
  v.reset_camera();
}

Viewer::~Viewer() = default;

int Viewer::run_window(const ViewScript* script) {
  Impl& v = *impl_;
  require(!options_.offscreen, "tsf view: run_window() needs a window (not --offscreen)");
  v.interactor = vtkSmartPointer<vtkRenderWindowInteractor>::New();
  v.interactor->SetRenderWindow(v.window);
  vtkNew<ToolInteractorStyle> style;
  style->impl = &v;
  v.interactor->SetInteractorStyle(style);
  v.interactor->Initialize();
  v.script = script != nullptr && !script->hands.empty() ? script : nullptr;
  v.window_start = Clock::now();
  if (v.input != nullptr) v.input->set_pressing(false);  // lifted until space engages it
  if (v.haptics != nullptr) {
    v.haptics->start();
    if (options_.on_haptics_started) options_.on_haptics_started();
  }
  SimulationThread thread(*v.session, options_.frame_s);
  v.thread = &thread;
  v.push_command();
  if (v.script != nullptr) thread.set_hands(v.scripted_hands());
  vtkNew<vtkCallbackCommand> tick;
  tick->SetClientData(&v);
  tick->SetCallback([](vtkObject* caller, unsigned long, void* client, void*) {
    auto* impl = static_cast<Viewer::Impl*>(client);
    if (impl->script != nullptr) impl->thread->set_hands(impl->scripted_hands());
    if (impl->input != nullptr) {
      // The keys move the device along the view's axes.
      double dop[3], up[3];
      vtkCamera* cam = impl->renderer->GetActiveCamera();
      cam->GetDirectionOfProjection(dop);
      cam->GetViewUp(up);
      const Vec3d f{dop[0], dop[1], dop[2]}, u{up[0], up[1], up[2]};
      impl->input->set_view_axes(cross(f, u), u, f);
    }
    std::vector<ToolCommand> shown = impl->thread->applied_hands();
    if (shown.empty()) {
      ToolCommand c = impl->command;
      c.mode = impl->engaged ? impl->armed_mode : interaction::ToolMode::kIdle;
      if (impl->haptics != nullptr) c.pose = impl->haptics->device_state().pose;
      shown.push_back(c);
    }
    impl->update_frame(shown);
    if (impl->options.close_after_frames >= 0 &&
        impl->frames_rendered >= impl->options.close_after_frames)
      static_cast<vtkRenderWindowInteractor*>(caller)->TerminateApp();
    if (impl->options.close_after_s > 0 &&
        std::chrono::duration<double>(Clock::now() - impl->window_start).count() >=
            impl->options.close_after_s)
      static_cast<vtkRenderWindowInteractor*>(caller)->TerminateApp();
  });
  v.interactor->AddObserver(vtkCommand::TimerEvent, tick);
  v.interactor->CreateRepeatingTimer(15);
  v.window->Render();
  v.interactor->Start();
  thread.stop();
  if (v.haptics != nullptr) v.haptics->stop();
  v.thread = nullptr;
  v.interactor->RemoveAllObservers();
  style->impl = nullptr;
  v.window->Finalize();
  v.interactor->TerminateApp();
  return v.frames_rendered;
}

void Viewer::step_and_render(const ToolCommand& command) {
  impl_->session->step(options_.frame_s, command);
  render(command);
}

void Viewer::render(const ToolCommand& command) {
  impl_->update_frame({command});
}

void Viewer::render_hands(const std::vector<ToolCommand>& hands) {
  impl_->update_frame(hands);
}

double Viewer::shown_force_un() const {
  return length(impl_->shown_force);
}

Frame Viewer::capture() const {
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(impl_->window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->ShouldRerenderOff();
  grab->Update();
  vtkImageData* img = grab->GetOutput();
  int dims[3];
  img->GetDimensions(dims);
  Frame f;
  f.width = dims[0];
  f.height = dims[1];
  const auto* p = static_cast<const std::uint8_t*>(img->GetScalarPointer());
  f.rgb.assign(p, p + static_cast<std::size_t>(dims[0]) * dims[1] * 3);
  return f;
}

void Viewer::write_png(const std::filesystem::path& path) const {
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(impl_->window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->ShouldRerenderOff();
  grab->Update();
  std::error_code ec;
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : ".";
  if (!std::filesystem::is_directory(folder, ec))
    throw Error(path.string() + ": cannot write the PNG: the folder " + folder.string() +
                " does not exist");
  // vtkPNGWriter writes in place: write beside, then rename.
  std::filesystem::path tmp = path;
  tmp += ".part";
  vtkNew<vtkPNGWriter> w;
  w->SetFileName(tmp.string().c_str());
  w->SetInputConnection(grab->GetOutputPort());
  w->Write();
  if (w->GetErrorCode() != 0 || !std::filesystem::exists(tmp, ec)) {
    std::filesystem::remove(tmp, ec);
    throw Error(path.string() + ": cannot write the PNG (is the folder writable?)");
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw Error(path.string() + ": cannot rename the PNG into place: " + ec.message());
  }
}

std::array<double, 2> Viewer::world_to_pixel(const Vec3d& p) const {
  vtkRenderer* r = impl_->renderer;
  r->SetWorldPoint(p.x, p.y, p.z, 1.0);
  r->WorldToDisplay();
  const double* d = r->GetDisplayPoint();
  return {d[0], d[1]};
}

double Viewer::render_seconds() const {
  double s = 0;
  for (double t : impl_->render_times) s += t;
  return impl_->render_times.empty() ? 0.0 : s / static_cast<double>(impl_->render_times.size());
}

}  // namespace tsf::viewer

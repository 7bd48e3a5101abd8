// `tsf view [SCENE|VOLUME]`: the live viewer. A scene (YAML) gives the tissue, its tools and
// anchors; a density volume (PREFIX-density.nrrd from `tsf segment`) gets default tools, bone
// anchored and no gravity. The window shows the deforming, cuttable tissue, slice planes through
// the scan with the label overlay, the tool under the mouse, a heads-up display and a live plot;
// the simulation runs on its own thread (CUDA when available, else CPU).
//
//   tsf view scenes/view-block.yaml
//   xvfb-run -a tsf view scenes/view-block.yaml --offscreen
//       --script scenes/view-block-ablate.yaml --out out/view-block
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "output/output_folder.h"
#include "scene/anatomy_placement.h"
#include "scene/haptic_devices.h"
#include "scene/interaction_run.h"
#include "scene/scene.h"
#include "scene/scene_outputs.h"
#include "scene/scene_session.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/haptics/device_registry.h"
#include "tsf/version.h"
#include "tsf/viewer/live_haptics.h"
#include "tsf/viewer/offscreen_render.h"
#include "tsf/viewer/view_script.h"
#include "tsf/viewer/viewer.h"
#include "tsf/volume/tissue_labels.h"
#ifdef TSF_HAVE_LINK_CMD
#include "link/link_session.h"  // --igtl-port: the surface served over OpenIGTLink (docs/live.md)
#endif
#ifdef TSF_HAVE_IMPORT
#include <fstream>

#include "tsf/import/import_volume.h"
#include "tsf/import/tissue_volume_io.h"
#endif

namespace tsf::app {
namespace {

struct ViewArguments {
  std::string input;
  bool offscreen = false;
  std::string script;
  int frames = -1;
  std::string out = "out/view";
  int width = 0, height = 0;
  std::string backend;
  std::string ct;
  double frame_time = 0;
  bool force = false;
  bool no_slices = false;
  bool quiet = false;
  std::string device;   ///< --device (window: mouse; offscreen: scripted)
  std::string haptics;  ///< --haptics MODEL | off (default: lattice in a window, off offscreen)
  double haptic_rate = 1000;
  int haptic_filter = 1;
  double seconds = 0;  ///< window: close after this many seconds
  std::string report;  ///< window: JSON report
#ifdef TSF_HAVE_LINK_CMD
  link::LinkOptions link;
#endif
};

/// Tools for a bare volume: a ball, an ablation wand and a scalpel (sizes of the shipped scenes).
std::vector<viewer::NamedTool> default_tools() {
  std::vector<viewer::NamedTool> tools(3);
  tools[0].name = "ball";
  tools[0].tool.shape = collision::ToolShape::kSphere;
  tools[0].tool.radius_mm = 3.0;
  tools[1].name = "wand";
  tools[1].tool.shape = collision::ToolShape::kCapsule;
  tools[1].tool.radius_mm = 1.5;
  tools[1].tool.half_length_mm = 2.0;
  tools[2].name = "scalpel";
  tools[2].tool.shape = collision::ToolShape::kBlade;
  tools[2].tool.half_extents_mm = {10.0, 10.0, 0.5};
  return tools;
}

/// The scene's script as the view's hands (time = frame index, `frame_s` simulated seconds per
/// frame), one hand per tool, so tools act at once as in `tsf simulate`: trajectory keyframes at
/// their frames, lifted one frame after the last; an event is a stroke from → to over one frame,
/// then a lift. Keyframes of one hand that fall on one frame move on by one.
viewer::ViewScript hand_from_scene_script(const Scene& scene, const viewer::ViewOptions& options,
                                          double frame_s) {
  struct Key {
    double frame;
    interaction::Keyframe k;
  };
  std::vector<std::vector<Key>> by_tool(scene.tools.size());
  std::vector<int> first_use;  // tools in the order they appear: their hands
  auto tool_index = [&](const std::string& name) {
    const int t = scene_tool_slot(scene, name);
    if (std::find(first_use.begin(), first_use.end(), t) == first_use.end()) first_use.push_back(t);
    return static_cast<std::size_t>(t);
  };
  auto frame_of = [&](double t) { return std::round(t / frame_s); };
  for (const SceneTrajectory& t : scene.script.trajectories) {
    const std::size_t tool = tool_index(t.tool);
    for (const interaction::Keyframe& k : t.keyframes)
      by_tool[tool].push_back({frame_of(k.time_s), k});
    interaction::Keyframe lift = t.keyframes.back();
    lift.mode = interaction::ToolMode::kIdle;
    by_tool[tool].push_back({frame_of(t.keyframes.back().time_s) + 1, lift});
  }
  for (const SceneEvent& e : scene.script.events) {
    const std::size_t tool = tool_index(e.tool);
    const double f = frame_of(e.time_s);
    by_tool[tool].push_back({f, {0, e.from, e.mode}});
    by_tool[tool].push_back({f + 1, {0, e.to, e.mode}});
    by_tool[tool].push_back({f + 2, {0, e.to, interaction::ToolMode::kIdle}});
  }
  viewer::ViewScript script;
  script.options = options;
  for (const int t : first_use) {
    std::vector<Key>& keys = by_tool[static_cast<std::size_t>(t)];
    std::stable_sort(keys.begin(), keys.end(),
                     [](const Key& a, const Key& b) { return a.frame < b.frame; });
    viewer::ViewHand hand;
    std::vector<interaction::Keyframe> frames;
    double last = -1;
    for (Key& key : keys) {
      key.k.time_s = std::max(key.frame, last + 1);
      last = key.k.time_s;
      frames.push_back(key.k);
      hand.keyframe_tools.push_back(t);
    }
    hand.path = interaction::Trajectory(frames);
    script.hands.push_back(std::move(hand));
  }
  return script;
}

/// Hand 0 of a view script as a path in seconds (frame f at f·frame_s): what a scripted device
/// plays in a window.
interaction::Trajectory hand_in_seconds(const viewer::ViewScript& script, double frame_s) {
  if (script.hands.empty() || script.hands.front().path.empty()) return {};
  std::vector<interaction::Keyframe> keys = script.hands.front().path.keyframes();
  for (interaction::Keyframe& k : keys) k.time_s *= frame_s;
  return interaction::Trajectory(std::move(keys));
}

#ifdef TSF_HAVE_IMPORT
/// The CT a segmented volume came from: PREFIX-report.json (tsf segment) names its input. Empty
/// when there is no report or the CT is not where it says (relative paths: from the working
/// folder, then from the report's folder's parent).
std::filesystem::path find_source_ct(const std::filesystem::path& density) {
  const std::filesystem::path report = segment_report_beside(density);
  if (report.empty()) return {};
  std::ifstream in(report);
  if (!in) return {};
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    const std::filesystem::path ct = j.at("input").at("path").get<std::string>();
    if (ct.is_absolute()) return std::filesystem::exists(ct) ? ct : std::filesystem::path();
    if (std::filesystem::exists(ct)) return ct;
    const std::filesystem::path beside = report.parent_path().parent_path() / ct;
    if (std::filesystem::exists(beside)) return beside;
  } catch (const std::exception&) {
  }
  return {};
}

/// Where the patient's directions point in tissue space, for the default camera (facing the
/// patient) and the orientation cube: the anatomy of the segment report beside `density` when
/// there is one (its detected facing, and whether left/right was recorded), else the volume's
/// recorded frame. A box (no density) has no patient.
viewer::PatientAxes view_patient_axes(const std::filesystem::path& density,
                                      const VolumeGeometry& frame) {
  viewer::PatientAxes p;
  if (density.empty()) return p;
  auto to_tissue = [&](const Vec3d& v) {  // Dᵀ·v: D is orthonormal
    const auto& d = frame.direction;
    return Vec3d{d[0] * v.x + d[3] * v.y + d[6] * v.z, d[1] * v.x + d[4] * v.y + d[7] * v.z,
                 d[2] * v.x + d[5] * v.y + d[8] * v.z};
  };
  AnatomyAxes axes;
  bool from_anatomy = false;
  const std::filesystem::path report = segment_report_beside(density);
  std::ifstream in(report);
  if (!report.empty() && in) {
    try {
      if (const auto a = anatomy_axes(nlohmann::json::parse(in))) {
        axes = *a;
        from_anatomy = true;
      }
    } catch (const std::exception&) {
    }
  }
  if (!from_anatomy) axes.orientation_recorded = true;  // the volume's header frame
  p.known = true;
  p.left = to_tissue(axes.left);
  p.anterior = to_tissue(axes.anterior);
  p.superior = to_tissue(axes.superior);
  p.left_right_known = axes.orientation_recorded;
  char conf[32];
  std::snprintf(conf, sizeof conf, "%.2f", axes.facing_confidence);
  p.description =
      std::string(axes.orientation_recorded ? "frame LPS recorded"
                                            : "frame not recorded: LEFT/RIGHT UNKNOWN") +
      (from_anatomy ? std::string("; face found by the anatomy (confidence ") + conf + ")"
                    : "; face toward the frame's anterior");
  return p;
}

/// The CT (HU) as slice planes with `labels`' labels over it. Throws tsf::Error naming the file
/// when it cannot be read or is not axis-aligned.
viewer::SliceVolume ct_slices(const std::filesystem::path& ct, const VoxelVolume& labels) {
  import::ImportResult r = import::import_volume(ct, import::ImportOptions{});
  const import::HuImage* image = r.image.GetPointer();
  const auto dir = image->GetDirection();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      if (std::abs(dir[a][b] - (a == b ? 1.0 : 0.0)) > 1e-6)
        throw Error(ct.string() +
                    ": the CT's axes are not aligned with tissue space (direction "
                    "cosines not identity); the viewer shows axis-aligned slices");
  VolumeGeometry g;
  const auto size = image->GetLargestPossibleRegion().GetSize();
  const auto spacing = image->GetSpacing();
  const auto origin = image->GetOrigin();
  for (int a = 0; a < 3; ++a) {
    g.dims[a] = static_cast<int>(size[static_cast<unsigned>(a)]);
    g.spacing[a] = spacing[static_cast<unsigned>(a)];
    g.origin[a] = origin[static_cast<unsigned>(a)];
  }
  const float* hu = image->GetBufferPointer();
  std::vector<float> values(hu, hu + g.dims.volume());
  return viewer::slices_from_ct(g, std::move(values), &labels,
                                "CT " + ct.filename().string() + " (HU)");
}
#endif

bool is_yaml(const std::filesystem::path& p) {
  const std::string e = p.extension().string();
  return e == ".yaml" || e == ".yml";
}

/// What `tsf view` shows, read and checked before the (slow) model: the scene (absent for a bare
/// density volume), its tools, the view script and its options.
struct ViewInputs {
  std::optional<Scene> scene;
  std::vector<viewer::NamedTool> tools;
  viewer::ViewScript script;
  bool scene_script = false;     ///< the scene's script is the hands (no --script)
  bool scripted_window = false;  ///< a window whose hands play the script (--device scripted)
};

/// The haptic device's name: --device, else `scripted` offscreen and `mouse` in a window.
std::string device_name(const ViewArguments& args) {
  if (!args.device.empty()) return haptics::parse_device_request(args.device).name;
  return args.offscreen ? "scripted" : "mouse";
}

ViewInputs read_view_inputs(const ViewArguments& args) {
  const std::filesystem::path input = args.input;
  if (args.offscreen && args.frames == 0) throw Error("--frames: expected at least 1 frame, got 0");
  if (!args.ct.empty() && args.ct != "none" && !std::filesystem::exists(args.ct))
    throw Error("--ct: no such file: " + args.ct);
  const std::string ext = input.extension().string();
  if (!is_yaml(input) && ext != ".nrrd" && ext != ".nhdr" && ext != ".mha" && ext != ".mhd")
    throw Error(input.string() +
                ": expected a scene (.yaml) or a density volume (PREFIX-density.nrrd from `tsf "
                "segment`)");
  ViewInputs in;
  if (is_yaml(input)) {
    in.scene = read_scene(input);
    check_scene_for_command(*in.scene, SceneCommand::kView);
    override_backend(*in.scene, args.backend);
    for (const SceneTool& t : in.scene->tools) in.tools.push_back({t.name, t.tool});
  }
  if (in.tools.empty()) in.tools = default_tools();
  viewer::ViewOptions defaults;
  defaults.offscreen = args.offscreen;
  // The scene's script plays offscreen unless --script replaces it (a view script: camera,
  // slices and the hands); in the live window the mouse is the tool, unless the device is
  // `scripted` (the script's hands then play in wall-clock time).
  const bool has_script = in.scene && in.scene->script_given;
  in.scripted_window = !args.offscreen && device_name(args) == "scripted";
  in.scene_script = has_script && args.script.empty() && (args.offscreen || in.scripted_window);
  if (has_script && args.script.empty()) defaults.frame_s = 1.0 / in.scene->script.frame_rate_hz;
  in.script.options = defaults;
  if (!args.script.empty())
    in.script = viewer::read_view_script(args.script, in.tools, defaults);
  else if (in.scene_script)
    in.script = hand_from_scene_script(*in.scene, defaults, defaults.frame_s);
  viewer::ViewOptions& o = in.script.options;
  if (args.width > 0) o.width = args.width;
  if (args.height > 0) o.height = args.height;
  if (args.frame_time > 0) o.frame_s = args.frame_time;
  if (args.no_slices) o.slices.show = false;
  o.offscreen = args.offscreen;
  o.validate();
  if (!args.quiet && has_script)
    std::printf("tsf view: %s\n",
                !args.script.empty()
                    ? "script: the view script given with --script replaces the scene's script"
                : args.offscreen || in.scripted_window
                    ? "script: playing the scene's script (trajectories and events as the hands)"
                    : "script: not played in the live window (the mouse is the tool; "
                      "--offscreen or --device scripted plays it)");
  return in;
}

/// The tissue model: the scene's (one builder for every command), or a bare density volume
/// with one soft material and its bone held.
struct ViewModel {
  std::unique_ptr<interaction::TissueModel> model;
  VolumeGeometry patient_frame;
  nlohmann::json session = nullptr;
};

ViewModel build_view_model(const ViewArguments& args, const ViewInputs& in) {
  ViewModel vm;
  if (in.scene) {
    TissueInstance built = build_tissue_instance(*in.scene, 0);
    vm.session = built.summary;
    vm.patient_frame = built.patient_frame;
    vm.model = std::move(built.model);
    return vm;
  }
#ifdef TSF_HAVE_IMPORT
  interaction::TissueModelOptions mo;
  if (!args.backend.empty()) mo.solver.backend = parse_backend(args.backend);
  mo.solver.materials.at(0).youngs_modulus_pa = 30000;
  mo.solver.materials.at(0).viscosity_pa_s = 5;
  mo.solver.stability.kinetic_damping = 0.01;
  // Bone holds still (no gravity: nothing else holds the tissue).
  mo.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_with_labels(l, {kLabelCancellousBone, kLabelCorticalBone});
  };
  vm.model = std::make_unique<interaction::TissueModel>(import::read_tissue_volume(args.input), mo);
  vm.patient_frame = vm.model->volume().geometry();
  return vm;
#else
  throw Error(args.input +
              ": reading a volume needs a build with ITK (reconfigure with -DTSF_WITH_ITK=ON); "
              "give a scene file (.yaml) instead");
#endif
}

/// Slice planes: the CT the tissue came from (--ct, else the one its segmentation report names)
/// with the labels over it; else the whole tissue volume when the scene is a crop of it; else
/// none (the viewer then slices the tissue's own volume).
std::optional<viewer::SliceVolume> view_slices(const ViewArguments& args, const ViewInputs& in,
                                               const interaction::TissueModel& model) {
  std::optional<viewer::SliceVolume> slices;
#ifdef TSF_HAVE_IMPORT
  const std::optional<Scene>& scene = in.scene;
  std::filesystem::path density;
  if (!scene)
    density = args.input;
  else if (scene->instances[0].lattice.source == SceneLattice::Source::kVolume)
    density = scene->instances[0].lattice.volume;
  std::optional<VoxelVolume> whole;
  if (scene && scene->instances[0].lattice.cropped && !density.empty())
    whole = import::read_tissue_volume(density);
  const VoxelVolume& labels = whole ? *whole : model.volume();
  std::filesystem::path ct = args.ct;
  if (ct.empty() && !density.empty()) ct = find_source_ct(density);
  if (!ct.empty() && args.ct != "none")
    slices = ct_slices(ct, labels);
  else if (whole)
    slices = viewer::slices_from_tissue(*whole);
#else
  (void)in;
  (void)model;
  if (!args.ct.empty() && args.ct != "none")
    throw Error("--ct: reading a CT needs a build with ITK (reconfigure with -DTSF_WITH_ITK=ON)");
#endif
  return slices;
}

/// Frames to render offscreen: --frames, else the scene script's duration, else the view
/// script's last keyframe plus 0.05 s of settling, else 60.
int offscreen_frame_count(const ViewArguments& args, const ViewInputs& in) {
  if (args.frames >= 0) return args.frames;
  const viewer::ViewOptions& o = in.script.options;
  if (in.scene_script)
    return std::max(1, static_cast<int>(std::ceil(in.scene->script.played_s() / o.frame_s - 1e-9)));
  return in.script.last_keyframe() < 0 ? 60
                                       : static_cast<int>(in.script.last_keyframe()) + 1 +
                                             static_cast<int>(std::ceil(0.05 / o.frame_s));
}

/// The live haptic loop of the view: the device named by --device drives the first hand's tool,
/// the model of --haptics computes the force. Null when --haptics off, or offscreen with no hand
/// to drive.
std::unique_ptr<viewer::LiveHaptics> build_live_haptics(const ViewArguments& args,
                                                        const ViewInputs& in,
                                                        const VolumeGeometry& patient_frame) {
  const std::string model = !args.haptics.empty() ? args.haptics
                            : args.offscreen      ? "off"
                                                  : "lattice";
  if (model == "off") return nullptr;
  const viewer::ViewOptions& o = in.script.options;
  const haptics::DeviceRequest request =
      haptics::parse_device_request(args.device.empty() ? device_name(args) : args.device);
  if (args.offscreen && request.name != "scripted")
    throw Error("--device " + request.text +
                ": offscreen frames are played by the script: the device is `scripted`");
  if (args.offscreen && (in.script.hands.empty() || in.script.hands.front().path.empty()))
    return nullptr;  // nothing in hand to drive
  // Offscreen the device follows the frame clock (frame index); in a window, wall-clock seconds.
  const interaction::Trajectory path =
      args.offscreen
          ? (in.script.hands.empty() ? interaction::Trajectory{} : in.script.hands.front().path)
          : hand_in_seconds(in.script, o.frame_s);
  DeviceContext context;
  context.trajectory = &path;
  context.window = !args.offscreen;
  std::unique_ptr<haptics::HapticDevice> device = haptic_devices(context).create(request);
  viewer::LiveHapticsOptions ho;
  ho.model = haptics::force_model_from_string(model);
  // The stylus of the voxel and mesh models: the size of the first hand's first tool.
  int tool = 0;
  if (!in.script.hands.empty() && !in.script.hands.front().keyframe_tools.empty())
    tool = in.script.hands.front().keyframe_tools.front();
  ho.force.stylus_radius_mm = stylus_radius_of(in.tools.at(static_cast<std::size_t>(tool)).tool);
  ho.loop.rate_hz = args.haptic_rate;
  ho.loop.filter_window = args.haptic_filter;
  ho.loop.frame = haptics::DeviceFrame(patient_frame);
  ho.loop.on_thread_start = request_haptic_thread_priority;
  return std::make_unique<viewer::LiveHaptics>(std::move(device), ho);
}

/// The loop's statistics for a report.
nlohmann::json haptics_json(viewer::LiveHaptics* h, bool live) {
  if (h == nullptr) return nullptr;
  nlohmann::json j = {{"model", haptics::to_string(h->options().model)},
                      {"device", h->device().describe()},
                      {"rate_hz_target", h->options().loop.rate_hz},
                      {"filter_window", h->options().loop.filter_window},
                      {"max_force_un", h->max_force_seen_un()},
                      {"live", live}};
  if (!live) {
    j["ticks"] = h->ticks();
    return j;
  }
  j.update(loop_statistics_json(h->statistics()));
  return j;
}

void render_view_offscreen(const ViewArguments& args, const ViewInputs& in,
                           viewer::SimulationSession& session, const viewer::SliceVolume* slices,
                           const OutputFolder& folder, SceneOutputWriter& outputs,
                           const std::filesystem::path& scene_report,
                           const nlohmann::json& session_summary) {
  const viewer::ViewOptions& o = in.script.options;
  const int frames = offscreen_frame_count(args, in);
  Progress progress("view " + std::filesystem::path(args.input).filename().string(),
                    static_cast<std::uint64_t>(frames),
                    !args.quiet && Progress::stderr_is_terminal());
  const viewer::OffscreenResult r =
      viewer::render_offscreen(session, slices, in.script, frames, folder.path(), [&](int f) {
        progress.set(static_cast<std::uint64_t>(f + 1));
        outputs.frame(session.model(), f + 1, (f + 1) * o.frame_s, f + 1 == frames);
      });
  progress.finish();
  const nlohmann::json report = {
      {"tsf_version", TSF_VERSION_STRING},
      {"input", absolute_path(args.input).string()},
      {"frame", "patient (LPS), mm"},
      {"session", session_summary},
      {"stability", stability_json(session.model().stability())},
      {"script", args.script.empty() ? (in.scene_script ? "the scene's script" : "")
                                     : absolute_path(args.script).string()},
      {"frames", r.frames},
      {"width", o.width},
      {"height", o.height},
      {"frame_time_s", o.frame_s},
      {"backend", r.last.backend},
      {"lattice_dims", {r.last.lattice_dims.x, r.last.lattice_dims.y, r.last.lattice_dims.z}},
      {"triangles_end", r.last.live_triangles},
      {"removed_mm3", r.last.removed_mm3},
      {"mean_render_s", r.mean_render_s},
      {"mean_simulate_s", r.mean_simulate_s},
      {"max_force_un", r.max_force_un},
      {"haptics", haptics_json(session.haptics(), false)},
  };
  write_text_atomically(folder.file("view-report.json"), report.dump(2) + "\n");
  outputs.finish(session.model().deformed_mesh(), r.frames * o.frame_s);
  if (!scene_report.empty()) write_text_atomically(scene_report, report.dump(2) + "\n");
  if (!args.quiet)
    std::printf(
        "tsf view: wrote %d frames to %s (render %.1f ms/frame, simulate %.1f ms/frame, "
        "%zu triangles at the end)\n",
        r.frames, folder.path().c_str(), r.mean_render_s * 1e3, r.mean_simulate_s * 1e3,
        r.last.live_triangles);
}

#ifdef TSF_HAVE_LINK_CMD
/// --igtl-port: every surface the simulation publishes goes out as POLYDATA (patient frame, RAS on
/// the wire unless --igtl-frame lps) at --igtl-rate at most (docs/live.md). Null when not asked.
std::unique_ptr<link::LinkSession> start_view_link(const ViewArguments& args,
                                                   viewer::SimulationSession& session,
                                                   const VolumeGeometry& patient_frame,
                                                   const std::string& name) {
  if (!args.link.enabled()) return nullptr;
  auto live = std::make_unique<link::LinkSession>(
      args.link, std::vector<link::LinkSession::NamedTool>{}, name);
  link::LinkSession* l = live.get();
  session.set_on_published([l, patient_frame](const interaction::TissueModel& model) {
    if (l->surface_due())
      l->publish_surface(mesh_in_patient_frame(model.deformed_mesh(), patient_frame));
  });
  if (!args.quiet) {
    std::printf("tsf view: OpenIGTLink %s\n", live->describe().c_str());
    std::fflush(stdout);
  }
  return live;
}
#endif

void run_view(const ViewArguments& args) {
  // Cheap checks first (scene, tools, script, display, output folder), then the tissue model.
  ViewInputs in = read_view_inputs(args);
  const viewer::DisplayStatus display = viewer::x_display_status();
  if (!display.available) throw Error("tsf view: " + display.reason);
  OutputFolder folder;
  if (args.offscreen || (in.scene && in.scene->outputs_given))
    folder = OutputFolder::prepare(args.out, args.force, "--out");

  Stopwatch setup;
  ViewModel vm = build_view_model(args, in);
  {
    std::filesystem::path density;
    if (!in.scene)
      density = args.input;
    else if (in.scene->instances[0].lattice.source == SceneLattice::Source::kVolume)
      density = in.scene->instances[0].lattice.volume;
    in.script.options.patient = view_patient_axes(density, vm.patient_frame);
  }
  // The scene's outputs (names inside --out): the rest mesh now, states every states_every
  // frames, the final mesh and the report at the end.
  InteractionOutputs files;
  if (in.scene && in.scene->outputs_given) {
    const SceneOutputs& names = in.scene->outputs;
    files = {folder.file(names.mesh), folder.file(names.rest_mesh), folder.file(names.report),
             folder.file(names.states), names.states_every};
  }
  SceneOutputWriter outputs(files, vm.patient_frame, *vm.model);
  viewer::SimulationSession session(std::move(vm.model), in.tools);
  const std::unique_ptr<viewer::LiveHaptics> live = build_live_haptics(args, in, vm.patient_frame);
  session.attach_haptics(live.get());
  const std::optional<viewer::SliceVolume> slice_volume = view_slices(args, in, session.model());
  const viewer::SliceVolume* slices = slice_volume ? &*slice_volume : nullptr;
#ifdef TSF_HAVE_LINK_CMD
  const std::unique_ptr<link::LinkSession> served = start_view_link(
      args, session, vm.patient_frame,
      in.scene ? in.scene->name : std::filesystem::path(args.input).stem().string());
#endif
  if (!args.quiet)
    std::printf("tsf view: %s on %s, lattice %d x %d x %d, %zu triangles (setup %.2f s)\n",
                args.input.c_str(), session.stats().backend.c_str(), session.stats().lattice_dims.x,
                session.stats().lattice_dims.y, session.stats().lattice_dims.z,
                session.stats().live_triangles, setup.seconds());
  if (args.offscreen)
    return render_view_offscreen(args, in, session, slices, folder, outputs, files.report,
                                 vm.session);
  viewer::ViewOptions o = in.script.options;
  o.close_after_frames = args.frames;
  o.close_after_s = args.seconds;
  if (live) o.on_haptics_started = lower_other_threads_priority;
  if (!args.quiet) std::printf("%s\n", viewer::kViewerKeyHelp);
  viewer::Viewer v(session, slices, o);
  Stopwatch window_clock;
  const int frames = v.run_window(in.scripted_window ? &in.script : nullptr);
  const double window_s = window_clock.seconds();
  if (live && !args.quiet) {
    const haptics::LoopStatistics st = live->statistics();
    std::printf(
        "tsf view: haptics %s at %.0f Hz: %lld ticks in %.2f s = %.1f Hz (%lld missed), tick "
        "latency p50 %.0f µs, p99 %.0f µs, max %.0f µs; %s\n",
        haptics::to_string(live->options().model), st.target_rate_hz,
        static_cast<long long>(st.ticks), st.elapsed_s, st.rate_hz,
        static_cast<long long>(st.missed_ticks), st.latency_p50_us, st.latency_p99_us,
        st.latency_max_us, st.scheduling.c_str());
  }
  if (!args.report.empty())
    write_text_atomically(args.report,
                          nlohmann::json{{"tsf_version", TSF_VERSION_STRING},
                                         {"input", absolute_path(args.input).string()},
                                         {"frame", "patient (LPS), mm"},
                                         {"window", true},
                                         {"frames", frames},
                                         {"seconds", window_s},
                                         {"render_fps", window_s > 0 ? frames / window_s : 0.0},
                                         {"simulated_s", session.model().totals().simulated_s},
                                         {"steps", session.model().totals().steps},
                                         {"session", vm.session},
                                         {"stability", stability_json(session.model().stability())},
                                         {"haptics", haptics_json(live.get(), true)}}
                                  .dump(2) +
                              "\n");
  if (!args.quiet) {
    // The live loop's rates, as the HUD last showed them: the simulation thread's steps per
    // second and real-time factor (recent), and the window's mean frame rate.
    const viewer::SimulationStats st = session.stats();
    std::printf(
        "tsf view: closed after %d frames in %.2f s (%.1f frames/s); simulation %.4g s simulated "
        "at %.0f steps/s, %.3gx real time\n",
        frames, window_s, window_s > 0 ? frames / window_s : 0.0, st.simulated_s, st.steps_per_s,
        st.realtime);
  }
  // The window played `frames` frames: its last state is the final one.
  outputs.frame(session.model(), frames, frames * o.frame_s, true);
  outputs.finish(session.model().deformed_mesh(), frames * o.frame_s);
  if (!files.report.empty())
    write_text_atomically(
        files.report, nlohmann::json{{"frames", frames}, {"session", vm.session}}.dump(2) + "\n");
}

}  // namespace

void add_view_command(CLI::App& app) {
  CLI::App* sub = app.add_subcommand(
      "view",
      "Live viewer: the deforming, cuttable tissue of a scene or a density volume, slice planes "
      "with the label overlay, the tool under the mouse (press / ablate / cut), a heads-up "
      "display and a live plot; or, with --offscreen, PNG frames of a view script. Needs an X "
      "display (offscreen: run under `xvfb-run -a`).");
  auto args = std::make_shared<ViewArguments>();
  sub->add_option("input", args->input,
                  "Scene (.yaml, e.g. scenes/view-block.yaml) or density volume "
                  "(PREFIX-density.nrrd from `tsf segment`)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_flag("--offscreen", args->offscreen,
                "Render frames to PNG files instead of opening a window");
  sub->add_option(
         "--script", args->script,
         "View script (YAML: camera, slices, overlays, tool keyframes; see docs/viewer.md)")
      ->check(CLI::ExistingFile);
  sub->add_option("--frames", args->frames,
                  "Offscreen: frames to render (default: the script's last keyframe + 0.05 s, "
                  "else 60). Window: close after this many frames")
      ->check(CLI::Range(0, 1'000'000));
  sub->add_option("--out,-o", args->out,
                  "Offscreen: folder for frame-NNNN.png, view-report.json and the scene's "
                  "outputs (new or empty, see --force)")
      ->capture_default_str();
  sub->add_option("--width", args->width, "Window width in pixels (default 1280)")
      ->check(CLI::Range(64, 8192));
  sub->add_option("--height", args->height, "Window height in pixels (default 800)")
      ->check(CLI::Range(64, 8192));
  sub->add_option("--frame-time", args->frame_time,
                  "Simulated seconds per frame (default 1/120, or the script's frame_time)")
      ->check(CLI::Range(1e-6, 1.0));
  sub->add_option("--backend", args->backend,
                  "Solver backend: cpu, cuda or auto (default: the "
                  "scene's; auto = CUDA when a device is present)")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}));
  sub->add_option("--ct", args->ct,
                  "CT (NRRD, MHA, NIfTI, DICOM folder) for the slice planes, in the tissue's space "
                  "(default: the CT named by PREFIX-report.json beside the density volume; "
                  "'none': the tissue density)");
  sub->add_flag("--no-slices", args->no_slices, "Hide the slice planes");
  sub->add_option("--device", args->device,
                  "Haptic device driving the first hand: mouse (window default: the mouse and "
                  "keys), scripted (the view script's or scene script's first hand; offscreen "
                  "always), or a driver's NAME[:KEY=VALUE,…] (docs/haptics.md)");
  sub->add_option("--haptics", args->haptics,
                  "Haptic force model of the live loop: lattice (the tool's contact reaction; "
                  "the window's default), voxel, mesh, or off (the offscreen default; offscreen "
                  "a model takes one haptic tick per frame)")
      ->check(CLI::IsMember({"lattice", "voxel", "mesh", "off"}));
  sub->add_option("--haptic-rate", args->haptic_rate, "Haptic loop rate, Hz (default 1000)")
      ->check(CLI::Range(1.0, 20000.0));
  sub->add_option("--haptic-filter", args->haptic_filter,
                  "Moving-average window of the haptic force, ticks (default 1)")
      ->check(CLI::Range(1, 1000));
  sub->add_option("--seconds", args->seconds, "Window: close after this many seconds of wall time")
      ->check(CLI::Range(0.001, 1e6));
  sub->add_option("--report", args->report,
                  "Window: write a JSON report at close (frames, simulation, the haptic loop's "
                  "rate and tick latency)");
  sub->add_flag("--force", args->force,
                "Replace the files of an earlier tsf run in the --out folder");
  sub->add_flag("--quiet,-q", args->quiet, "No summary or progress on the terminal");
  sub->footer(std::string("Keys: ") + viewer::kViewerKeyHelp);
#ifdef TSF_HAVE_LINK_CMD
  link::add_link_options(*sub, args->link, -1, false);
#endif
  sub->callback([args] { run_view(*args); });
}

}  // namespace tsf::app

// `tsf haptics SCENE --trajectory FILE --model voxel|lattice|mesh --out DIR`: drives a virtual
// stylus along a scripted haptic trajectory through a scene's tissue (thesis §8.6: software
// replaces hand and device) and records what a haptic device would render, tick by tick:
//   DIR/samples.csv    one row per haptic tick (time, stylus position, raw and rendered force, …)
//   DIR/metrics.json   jitter, kicks, pop-through, latency, compute time, and the run's settings
//   DIR/force.png      force magnitude and direction (angle to the motion) over time (gnuplot)
// The playback is deterministic (haptic_playback.h): simulation steps and haptic ticks interleave
// as in a live session, on one thread. `--live SECONDS` runs the same loop for real instead: its
// own thread in wall-clock time, a device (--device, default the scripted trajectory) driving the
// stylus, the simulation pumped on another thread; it reports the achieved rate and the tick
// latency percentiles beside the same samples, metrics and plot. Trajectory files are YAML
// (scenes/trajectories/*.yaml):
//
//   stylus: {radius: 2.5, voxel_resolution: 16, sphere_resolution: 1, sampling: trilinear}
//   force_law: {c1: 1.0e4, c2: 1.0, cutoff: 0.5, taper: 0.5}
//   lattice_gain: 1.0
//   loop: {rate: 1000, sim_rate: 200, filter_window: 1, max_force: 3.0e6}
//   target: {shape: sphere, radius: 8, voxel: 0.5}  # optional: a rigid analytic target instead
//                                                    # of the scene's tissue (sphere |
//                                                    chamfered-cube)
//   path:
//     kind: straight | press-and-hold | sweep | keyframes
//     mode: press | probe            # press: the stylus deforms the tissue; probe: it only feels
//     ...                            # per kind: docs/haptics.md
#include <yaml-cpp/yaml.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "commands.h"
#include "output/interrupt.h"
#include "output/output_folder.h"
#include "scene/haptic_devices.h"
#include "scene/interaction_run.h"
#include "scene/scene.h"
#include "scene/scene_session.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/haptics/force_models.h"
#include "tsf/haptics/frame_capture.h"
#include "tsf/haptics/haptic_loop.h"
#include "tsf/haptics/haptic_metrics.h"
#include "tsf/haptics/haptic_playback.h"
#include "tsf/haptics/haptic_trajectory.h"
#include "tsf/haptics/scripted_device.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/version.h"
#include "tsf/volume/analytic_volumes.h"
#include "yaml_field.h"

namespace tsf::app {
namespace {

using nlohmann::json;

using Field = YamlField;

/// Points of a trajectory file (stylus path, target centre) lie within 100 m of the scene's
/// origin: farther, a haptic window's voxel indices would not fit (frame_capture.h).
constexpr double kMaxCoordinateMm = 1e5;

// ---- the trajectory file -------------------------------------------------------------------

struct RigidTarget {
  std::string shape;  ///< "sphere" | "chamfered-cube"
  double size_mm = 8, chamfer_mm = 2, voxel_mm = 0.5;
  Vec3d centre_mm{0, 0, 0};
};

struct HapticRunFile {
  std::string file;
  std::string kind;
  interaction::Trajectory trajectory;
  haptics::ForceModelOptions model;
  haptics::PlaybackOptions playback;
  std::optional<RigidTarget> target;
};

HapticRunFile read_trajectory_file(const std::filesystem::path& path) {
  HapticRunFile run;
  run.file = path.string();
  const Field top(load_yaml_file(run.file), "", run.file);
  if (!top.defined()) top.fail("the trajectory file is empty");
  top.expect_keys({"stylus", "force_law", "lattice_gain", "loop", "target", "path"});
  const Field st = top["stylus"];
  st.expect_keys({"radius", "voxel_resolution", "sphere_resolution", "sampling"});
  run.model.stylus_radius_mm = st["radius"].number(2.0, 0.0, 100.0, true);
  run.model.voxel_resolution = st["voxel_resolution"].integer(16, 2, 128);
  run.model.sphere_resolution = st["sphere_resolution"].integer(1, 1, 32);
  const std::string sampling = st["sampling"].text("trilinear");
  if (sampling != "trilinear" && sampling != "nearest")
    st["sampling"].fail("expected trilinear or nearest, got '" + sampling + "'");
  run.model.sampling = sampling == "nearest" ? haptics::DensitySampling::kNearest
                                             : haptics::DensitySampling::kTrilinear;
  const Field law = top["force_law"];
  law.expect_keys({"c1", "c2", "cutoff", "taper"});
  run.model.law.c1 = law["c1"].number(1e4, 0.0, 1e12, true);
  run.model.law.c2 = law["c2"].number(1.0, 0.0, 4.0, true);
  run.model.law.cutoff_fraction = law["cutoff"].number(0.5, 0.0, 1.0, true);
  run.model.law.taper_fraction = law["taper"].number(0.5, 0.0, 0.99);
  run.model.lattice_gain = top["lattice_gain"].number(1.0, 0.0, 1e6, true);
  const Field loop = top["loop"];
  loop.expect_keys({"rate", "sim_rate", "filter_window", "max_force"});
  run.playback.haptic_rate_hz = loop["rate"].number(1000, 0.0, 20000, true);
  run.playback.sim_rate_hz = loop["sim_rate"].number(200, 0.0, 20000, true);
  if (run.playback.sim_rate_hz > run.playback.haptic_rate_hz)
    loop["sim_rate"].fail("expected at most the haptic rate (loop.rate)");
  run.playback.filter_window = loop["filter_window"].integer(1, 1, 1000);
  run.playback.max_force_un = loop["max_force"].number(0, 0, 1e12);

  const Field target = top["target"];
  if (target.defined()) {
    target.expect_keys({"shape", "size", "chamfer", "voxel", "centre"});
    RigidTarget t;
    t.shape = target["shape"].text("");
    if (t.shape != "sphere" && t.shape != "chamfered-cube")
      target["shape"].fail("expected sphere or chamfered-cube, got '" + t.shape + "'");
    t.size_mm = target["size"].required_number(0.0, 1000.0, true);
    t.chamfer_mm = target["chamfer"].number(0.25 * t.size_mm, 0.0, t.size_mm);
    t.voxel_mm = target["voxel"].number(0.5, 0.01, 10.0);
    if (2.0 * t.size_mm / t.voxel_mm > 1024)
      target["voxel"].fail("the target would need more than 1024 voxels across");
    t.centre_mm = target["centre"].vec3_within(kMaxCoordinateMm);
    run.target = t;
  }

  const Field p = top["path"];
  if (!p.defined()) p.fail("is required");
  run.kind = p["kind"].text("");
  const std::string mode_text = p["mode"].text("probe");
  if (mode_text != "press" && mode_text != "probe")
    p["mode"].fail("expected press or probe, got '" + mode_text + "'");
  const interaction::ToolMode mode =
      mode_text == "press" ? interaction::ToolMode::kPress : interaction::ToolMode::kIdle;
  try {
    if (run.kind == "straight") {
      p.expect_keys({"kind", "mode", "from", "to", "speed"});
      run.trajectory = haptics::straight_pass(p["from"].vec3_within(kMaxCoordinateMm),
                                              p["to"].vec3_within(kMaxCoordinateMm),
                                              p["speed"].required_number(0, 1e4, true), mode);
    } else if (run.kind == "press-and-hold") {
      p.expect_keys({"kind", "mode", "point", "normal", "depth", "approach", "speed", "hold"});
      run.trajectory = haptics::press_and_hold(
          p["point"].vec3_within(kMaxCoordinateMm), p["normal"].vec3_within(kMaxCoordinateMm),
          run.model.stylus_radius_mm, p["depth"].required_number(0, 1e3, true),
          p["approach"].number(2.0, 0, 1e3), p["speed"].required_number(0, 1e4, true),
          p["hold"].number(0.5, 0, 1e3), mode);
    } else if (run.kind == "sweep") {
      p.expect_keys({"kind", "mode", "start", "end", "normal", "depth", "approach", "speed"});
      run.trajectory = haptics::surface_sweep(
          p["start"].vec3_within(kMaxCoordinateMm), p["end"].vec3_within(kMaxCoordinateMm),
          p["normal"].vec3_within(kMaxCoordinateMm), run.model.stylus_radius_mm,
          p["depth"].required_number(0, 1e3, true), p["approach"].number(2.0, 0, 1e3),
          p["speed"].required_number(0, 1e4, true), mode);
    } else if (run.kind == "keyframes") {
      p.expect_keys({"kind", "mode", "keyframes"});
      const Field list = p["keyframes"];
      std::vector<interaction::Keyframe> keys;
      for (std::size_t i = 0; i < list.size(); ++i) {
        const Field k = list.at(i);
        k.expect_keys({"time", "position"});
        interaction::Keyframe f;
        f.time_s = k["time"].required_number(0, 1e5);
        f.pose.position = k["position"].vec3_within(kMaxCoordinateMm);
        f.mode = mode;
        if (!keys.empty() && !(f.time_s > keys.back().time_s))
          k["time"].fail("expected times to increase strictly");
        keys.push_back(f);
      }
      if (keys.size() < 2) list.fail("expected at least 2 keyframes");
      run.trajectory = interaction::Trajectory(std::move(keys));
    } else {
      p["kind"].fail("expected straight, press-and-hold, sweep or keyframes, got '" + run.kind +
                     "'");
    }
  } catch (const Error& e) {
    const std::string what = e.what();
    if (what.rfind(run.file, 0) == 0) throw;
    throw Error(run.file + ": path: " + what);
  }
  return run;
}

// ---- tissue --------------------------------------------------------------------------------

double chamfered_cube_distance(const Vec3d& q, double h, double c) {
  double d = box_distance_local({h, h, h}, q);
  const double ax = std::fabs(q.x), ay = std::fabs(q.y), az = std::fabs(q.z);
  const double s = 1.0 / std::sqrt(2.0);
  d = std::max(d, (ax + ay - (2 * h - c)) * s);
  d = std::max(d, (ay + az - (2 * h - c)) * s);
  return std::max(d, (ax + az - (2 * h - c)) * s);
}

/// A rigid analytic target: size = sphere radius or cube half-size, with room for the stylus.
VoxelVolume target_volume(const RigidTarget& t, double stylus_radius) {
  const double half = t.size_mm + 2.0 * stylus_radius + 2.0 * t.voxel_mm;
  const int n = static_cast<int>(std::ceil(2.0 * half / t.voxel_mm));
  VolumeGeometry g = cube_geometry({n, n, n}, t.voxel_mm);
  g.origin = t.centre_mm - Vec3d{0.5 * (n - 1) * t.voxel_mm, 0.5 * (n - 1) * t.voxel_mm,
                                 0.5 * (n - 1) * t.voxel_mm};
  const RigidTarget target = t;
  return make_sdf_volume(
      g,
      [target](const Vec3d& p) {
        const Vec3d q = p - target.centre_mm;
        return target.shape == "sphere"
                   ? length(q) - target.size_mm
                   : chamfered_cube_distance(q, target.size_mm, target.chamfer_mm);
      },
      0.5 * t.voxel_mm);
}

// ---- outputs -------------------------------------------------------------------------------

std::string fmt(double v) {
  if (!std::isfinite(v)) return "nan";
  char b[32];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

/// Angle between the force and the stylus's direction of motion (180° = against it), per
/// sample; NaN where there is no force. Motion is the last non-zero displacement.
std::vector<double> angles_to_motion(const std::vector<haptics::HapticSample>& s) {
  std::vector<double> a(s.size(), std::nan(""));
  Vec3d motion{0, 0, 0};
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (i > 0) {
      const Vec3d v = s[i].position_mm - s[i - 1].position_mm;
      if (length(v) > 1e-12) motion = v / length(v);
    }
    const double f = length(s[i].force_un);
    if (f > 0 && length(motion) > 0.5) {
      const double c = std::clamp(dot(s[i].force_un, motion) / f, -1.0, 1.0);
      a[i] = std::acos(c) * 180.0 / 3.14159265358979323846;
    }
  }
  return a;
}

std::string samples_csv(const std::vector<haptics::HapticSample>& s) {
  const std::vector<double> angle = angles_to_motion(s);
  std::ostringstream o;
  o << "time_s,x_mm,y_mm,z_mm,raw_fx_un,raw_fy_un,raw_fz_un,fx_un,fy_un,fz_un,force_un,"
       "raw_force_un,angle_to_motion_deg,intersection_mm3,contacts,frame_age_ms,compute_us\n";
  for (std::size_t i = 0; i < s.size(); ++i) {
    const haptics::HapticSample& x = s[i];
    o << fmt(x.time_s) << ',' << fmt(x.position_mm.x) << ',' << fmt(x.position_mm.y) << ','
      << fmt(x.position_mm.z) << ',' << fmt(x.raw_force_un.x) << ',' << fmt(x.raw_force_un.y) << ','
      << fmt(x.raw_force_un.z) << ',' << fmt(x.force_un.x) << ',' << fmt(x.force_un.y) << ','
      << fmt(x.force_un.z) << ',' << fmt(length(x.force_un)) << ',' << fmt(length(x.raw_force_un))
      << ',' << fmt(angle[i]) << ',' << fmt(x.intersection_mm3) << ',' << x.contacts << ','
      << fmt(x.frame_age_s * 1e3) << ',' << fmt(x.compute_us) << '\n';
  }
  return o.str();
}

json metrics_json(const haptics::HapticMetrics& m) {
  return {{"samples", m.samples},
          {"contact_samples", m.contact_samples},
          {"peak_force_un", m.peak_force_un},
          {"mean_contact_force_un", m.mean_contact_force_un},
          {"jitter_un", m.jitter_un},
          {"jitter_relative", m.jitter_relative},
          {"kick_un_per_s", m.kick_un_per_s},
          {"kick_relative_per_ms", m.kick_relative_per_ms},
          {"pop_through_un", m.pop_through_un},
          {"pop_through_relative", m.pop_through_relative},
          {"filter_delay_ms", m.filter_delay_ms},
          {"mean_frame_age_ms", m.mean_frame_age_ms},
          {"max_frame_age_ms", m.max_frame_age_ms},
          {"latency_ms", m.latency_ms},
          {"bounce_prone", m.bounce_prone},
          {"compute_p50_us", m.compute_p50_us},
          {"compute_p99_us", m.compute_p99_us},
          {"compute_max_us", m.compute_max_us}};
}

/// gnuplot single-quoted string literal.
std::string quoted(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += c == '\'' ? std::string("''") : std::string(1, c);
  return o + "'";
}

void write_plot(const std::filesystem::path& csv, const std::filesystem::path& png,
                const std::string& title, bool filtered, bool any_direction, double duration_ms) {
  write_file_atomically(png, [&](const std::filesystem::path& temp) {
    std::ostringstream g;
    g << "set terminal pngcairo size 1100,760 font 'Sans,10'\n"
      << "set output " << quoted(temp.string()) << "\n"
      << "set datafile separator ','\nset datafile missing 'nan'\n"
      << "set key top center\nset grid\nset xrange [0:" << fmt(std::max(1.0, duration_ms)) << "]\n"
      << "set multiplot layout 2,1 title " << quoted(title) << "\n"
      << "set lmargin 10\nset ylabel 'force on the stylus (mN)'\nset format x ''\n"
      << "plot " << quoted(csv.string())
      << " using ($1*1e3):($11*1e-3) skip 1 with lines lw 2 lc rgb '#1f5fa8' title 'rendered'";
    if (filtered)
      g << ", '' using ($1*1e3):($12*1e-3) skip 1 with lines lw 1 lc rgb '#b0b0b0' title "
           "'unfiltered'";
    g << "\nset format x '%g'\nset xlabel 'time (ms)'\n"
      << "set ylabel 'angle to the motion (deg)'\nset yrange [0:180]\nset ytics 0,45,180\n"
      << "set key bottom center\n";
    if (any_direction)
      g << "plot " << quoted(csv.string())
        << " using ($1*1e3):13 skip 1 with points pt 7 ps 0.3 lc rgb '#c0392b' "
           "title 'angle between force and motion: 180 = against it, 0 = along it'\n";
    else
      g << "plot 1/0 title 'no force, no direction'\n";
    g << "unset multiplot\n";
    const std::filesystem::path script = temp.string() + ".gp";
    {
      std::ofstream f(script);
      f << g.str();
      if (!f) throw Error(script.string() + ": cannot write the gnuplot script");
    }
    const std::string cmd = "gnuplot " + quoted(script.string()) + " 2>&1";
    std::string output;
    FILE* pipe = popen(cmd.c_str(), "r");
    if (!pipe) throw Error("cannot run gnuplot (install gnuplot-nox)");
    char buffer[512];
    while (std::fgets(buffer, sizeof buffer, pipe)) output += buffer;
    const int status = pclose(pipe);
    std::error_code ec;
    std::filesystem::remove(script, ec);
    if (status != 0 || !std::filesystem::exists(temp))
      throw Error("gnuplot failed to draw " + png.string() +
                  " (is gnuplot-nox installed?): " + output);
  });
}

struct HapticsArguments {
  std::string scene, trajectory, model = "voxel", out;
  std::optional<int> resolution, filter;
  std::optional<double> rate;
  std::optional<double> live;  ///< seconds of wall-clock loop
  std::string device = "scripted";
  bool no_plot = false, quiet = false, force = false;
};

/// What a live run measured besides the samples.
struct LiveRun {
  haptics::LoopStatistics loop;
  std::int64_t sim_steps = 0;
  double sim_max_step_us = 0;
  std::string device;
  bool interrupted = false;
};

/// `--live SECONDS`: the haptic loop on its own thread in wall-clock time, the device named by
/// --device driving the stylus, the simulation pumped on another thread at loop.sim_rate, for
/// SECONDS of wall time (Ctrl-C stops it early).
LiveRun play_live(const HapticsArguments& args, const HapticRunFile& run,
                  haptics::FrameSource& source, const haptics::ForceModel& model,
                  const VolumeGeometry* patient_frame,
                  std::vector<haptics::HapticSample>& samples) {
  DeviceContext context;
  context.trajectory = &run.trajectory;
  std::unique_ptr<haptics::HapticDevice> device =
      haptic_devices(context).create(haptics::parse_device_request(args.device));
  const double seconds = *args.live;
  haptics::HapticLoopOptions lo;
  lo.rate_hz = run.playback.haptic_rate_hz;
  lo.filter_window = run.playback.filter_window;
  lo.max_force_un = run.playback.max_force_un;
  lo.record_samples = true;
  lo.max_ticks = static_cast<std::size_t>(std::ceil(seconds * lo.rate_hz)) + 1000;
  if (patient_frame) lo.frame = haptics::DeviceFrame(*patient_frame);
  lo.on_thread_start = request_haptic_thread_priority;
  haptics::TripleBuffer<haptics::HapticFrame> frames;
  haptics::HapticLoop loop(*device, model, frames, lo);
  haptics::SimulationPump pump(source, frames, loop, run.playback.sim_rate_hz,
                               [] { lower_thread_priority(); });
  LiveRun r;
  r.device = device->describe();
  Progress progress("haptics live", 1000, !args.quiet && Progress::stderr_is_terminal());
  InterruptScope interrupts;
  Stopwatch clock;
  loop.start();
  pump.start();
  while (clock.seconds() < seconds) {
    if (interrupted()) {
      r.interrupted = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    progress.set_fraction(std::min(1.0, clock.seconds() / seconds));
  }
  pump.stop();
  loop.stop();
  progress.finish();
  r.loop = loop.statistics();
  r.sim_steps = pump.steps();
  r.sim_max_step_us = pump.max_step_us();
  samples = loop.samples();
  return r;
}

void run_haptics(const HapticsArguments& args) {
  Stopwatch clock;
  HapticRunFile run = read_trajectory_file(args.trajectory);
  const haptics::ForceModelKind kind = haptics::force_model_from_string(args.model);
  if (args.resolution) {
    if (kind == haptics::ForceModelKind::kMesh)
      run.model.sphere_resolution = *args.resolution;
    else
      run.model.voxel_resolution = *args.resolution;
  }
  if (args.filter) run.playback.filter_window = *args.filter;
  if (args.rate) {
    run.playback.haptic_rate_hz = *args.rate;
    if (run.playback.sim_rate_hz > *args.rate) run.playback.sim_rate_hz = *args.rate;
  }
  try {
    haptics::playback_ticks(run.trajectory, run.playback);
  } catch (const Error& e) {
    throw Error(run.file + ": path.speed, loop.rate: " + e.what() +
                " (raise path.speed or shorten the path)");
  }
  const Scene scene = read_scene(args.scene);
  check_scene_for_command(scene, SceneCommand::kHaptics);
  const OutputFolder folder = OutputFolder::prepare(args.out, args.force, "--out");
  const std::unique_ptr<haptics::ForceModel> model = haptics::make_force_model(kind, run.model);

  // The tissue: the scene's (deforming, TissueModel) or a rigid analytic target.
  const haptics::CaptureOptions capture{run.model.stylus_radius_mm, 3.0};
  std::unique_ptr<interaction::TissueModel> tissue;
  json session_summary = nullptr;
  std::optional<VoxelVolume> rigid;
  std::optional<imt::SurfaceMesh> rigid_mesh;
  std::unique_ptr<haptics::FrameSource> source;
  VolumeGeometry patient_frame;
  if (run.target) {
    if (kind == haptics::ForceModelKind::kLattice)
      throw Error(run.file + ": target: a rigid target has no lattice; use --model voxel or mesh");
    rigid = target_volume(*run.target, run.model.stylus_radius_mm);
    if (kind == haptics::ForceModelKind::kMesh) rigid_mesh = imt::extract_surface(*rigid);
    source = std::make_unique<haptics::StaticFrameSource>(
        *rigid, rigid_mesh ? &*rigid_mesh : nullptr, capture);
  } else {
    TissueInstance built = build_tissue_instance(scene, 0);
    session_summary = built.summary;
    patient_frame = built.patient_frame;
    tissue = std::move(built.model);
    source = std::make_unique<haptics::TissueFrameSource>(*tissue, capture);
  }
  const double setup_s = clock.seconds();

  std::vector<haptics::HapticSample> samples;
  std::optional<LiveRun> live;
  if (args.live) {
    live = play_live(args, run, *source, *model, tissue ? &patient_frame : nullptr, samples);
  } else {
    Progress progress("haptics " + std::string(haptics::to_string(kind)), 1000,
                      !args.quiet && Progress::stderr_is_terminal());
    samples = haptics::play_trajectory(run.trajectory, *source, *model, run.playback,
                                       [&](double f) { progress.set_fraction(f); });
    progress.finish();
  }
  const double play_s = clock.seconds() - setup_s;
  haptics::MetricOptions mo;
  mo.tick_s = 1.0 / run.playback.haptic_rate_hz;
  mo.filter_window = run.playback.filter_window;
  const haptics::HapticMetrics metrics = haptics::compute_metrics(samples, mo);

  const std::filesystem::path out = folder.path();
  const std::filesystem::path csv = out / "samples.csv";
  write_text_atomically(csv, samples_csv(samples));
  const std::string title =
      (run.target ? "rigid " + run.target->shape : scene.name) + " · " +
      std::filesystem::path(args.trajectory).stem().string() + " · " + haptics::to_string(kind) +
      " model · " + fmt(run.playback.haptic_rate_hz) + " Hz, filter " +
      std::to_string(run.playback.filter_window) + (live ? " · live, wall clock" : "");
  bool any_direction = false;
  for (double a : angles_to_motion(samples)) any_direction = any_direction || std::isfinite(a);
  const double duration_ms =
      samples.empty() ? 0.0 : (samples.back().time_s - samples.front().time_s) * 1e3;
  if (!args.no_plot)
    write_plot(csv, out / "force.png", title, run.playback.filter_window > 1, any_direction,
               duration_ms);
  json report = {
      {"tsf_version", TSF_VERSION_STRING},
      {"scene", absolute_path(args.scene).string()},
      {"frame", "patient (LPS), mm"},
      {"session", session_summary},
      {"trajectory", absolute_path(args.trajectory).string()},
      {"path_kind", run.kind},
      {"model", haptics::to_string(kind)},
      {"target", run.target ? json{{"shape", run.target->shape},
                                   {"size_mm", run.target->size_mm},
                                   {"voxel_mm", run.target->voxel_mm}}
                            : json("scene tissue")},
      {"stylus",
       {{"radius_mm", run.model.stylus_radius_mm},
        {"voxel_resolution", run.model.voxel_resolution},
        {"sphere_resolution", run.model.sphere_resolution}}},
      {"force_law",
       {{"c1", run.model.law.c1},
        {"c2", run.model.law.c2},
        {"cutoff", run.model.law.cutoff_fraction},
        {"taper", run.model.law.taper_fraction}}},
      {"loop",
       {{"rate_hz", run.playback.haptic_rate_hz},
        {"sim_rate_hz", run.playback.sim_rate_hz},
        {"filter_window", run.playback.filter_window},
        {"max_force_un", run.playback.max_force_un}}},
      {"metrics", metrics_json(metrics)},
      {"mode", live ? "live (wall clock)" : "playback (simulated time)"},
      {"timing", {{"setup_s", setup_s}, {"playback_s", play_s}}},
      {"outputs",
       {{"samples", csv.string()}, {"plot", args.no_plot ? "" : (out / "force.png").string()}}}};
  // The deforming tissue's verdict (a rigid target has none).
  if (live) {
    nlohmann::json l = loop_statistics_json(live->loop);
    l["device"] = live->device;
    l["requested_seconds"] = *args.live;
    l["interrupted"] = live->interrupted;
    l["simulation"] = {
        {"steps", live->sim_steps},
        {"rate_hz", live->loop.elapsed_s > 0 ? live->sim_steps / live->loop.elapsed_s : 0.0},
        {"rate_hz_target", run.playback.sim_rate_hz},
        {"max_step_us", live->sim_max_step_us}};
    report["live"] = l;
  }
  std::optional<crms::StabilitySummary> stability;
  if (tissue) stability = tissue->stability();
  report["stability"] = stability ? stability_json(*stability) : json(nullptr);
  write_text_atomically(out / "metrics.json", report.dump(2) + "\n");
  if (!args.quiet && stability) std::printf("%s\n", stability->headline().c_str());
  if (!args.quiet && live) {
    const haptics::LoopStatistics& st = live->loop;
    std::printf(
        "live: %lld ticks in %.2f s = %.1f Hz of %.0f Hz (%.1f%%), %lld missed, %lld late; tick "
        "latency p50 %.0f µs, p99 %.0f µs, p99.9 %.0f µs, max %.0f µs; compute p50 %.1f µs; "
        "simulation %lld steps (%.0f Hz of %.0f Hz); %s\n",
        static_cast<long long>(st.ticks), st.elapsed_s, st.rate_hz, st.target_rate_hz,
        st.target_rate_hz > 0 ? 100.0 * st.rate_hz / st.target_rate_hz : 0.0,
        static_cast<long long>(st.missed_ticks), static_cast<long long>(st.late_ticks),
        st.latency_p50_us, st.latency_p99_us, st.latency_p999_us, st.latency_max_us,
        st.compute_p50_us, static_cast<long long>(live->sim_steps),
        st.elapsed_s > 0 ? live->sim_steps / st.elapsed_s : 0.0, run.playback.sim_rate_hz,
        st.scheduling.c_str());
  }
  if (!args.quiet)
    std::printf(
        "%zu ticks · peak %.3g mN · jitter %.3g%% · kick %.3g%%/ms · pop-through %.3g%% · "
        "latency %.2f ms%s · eval p50 %.1f µs\nwrote %s\n",
        metrics.samples, metrics.peak_force_un * 1e-3, metrics.jitter_relative * 100,
        metrics.kick_relative_per_ms * 100, metrics.pop_through_relative * 100, metrics.latency_ms,
        metrics.bounce_prone ? " (bounce-prone)" : "", metrics.compute_p50_us,
        out.string().c_str());
  if (stability) require_stable_enough(*stability, scene.name);
  if (live && live->interrupted) throw Error("interrupted: the live loop stopped early (Ctrl-C)");
}

}  // namespace

void add_haptics_command(CLI::App& app) {
  CLI::App* sub = app.add_subcommand(
      "haptics",
      "Drive a virtual stylus along a scripted trajectory through a scene's tissue and record the "
      "haptic force a device would render (voxel, lattice or mesh model): samples CSV, metrics "
      "JSON (jitter, kicks, pop-through, latency) and a force plot (docs/haptics.md)");
  auto args = std::make_shared<HapticsArguments>();
  sub->add_option("scene", args->scene, "Scene file (YAML), e.g. scenes/haptics-block.yaml")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--trajectory,-t", args->trajectory,
                  "Trajectory file (YAML), e.g. scenes/trajectories/haptics-press-hold.yaml")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--model,-m", args->model, "Force model: voxel, lattice or mesh (default voxel)")
      ->check(CLI::IsMember({"voxel", "lattice", "mesh"}));
  sub->add_option("--out,-o", args->out, "Output folder (samples.csv, metrics.json, force.png)")
      ->required();
  sub->add_option("--resolution", args->resolution,
                  "Override the stylus resolution (voxel model: cells across, 2..128; mesh: "
                  "spheres across, 1..32)")
      ->check(CLI::Range(1, 128));
  sub->add_option("--filter", args->filter, "Override the moving-average window (ticks, 1..1000)")
      ->check(CLI::Range(1, 1000));
  sub->add_option("--rate", args->rate, "Override the haptic rate (Hz, up to 20000)")
      ->check(CLI::Range(1.0, 20000.0));
  sub->add_option("--live", args->live,
                  "Run the haptic loop live for SECONDS of wall time (its own thread, the "
                  "simulation on another) instead of the reproducible playback; reports the "
                  "achieved rate and tick latency")
      ->check(CLI::Range(0.01, 3600.0));
  sub->add_option("--device", args->device,
                  "--live: the device driving the stylus, NAME[:KEY=VALUE,…] (default scripted: "
                  "the trajectory in wall-clock time)");
  sub->add_flag("--no-plot", args->no_plot, "Skip the PNG plot (no gnuplot needed)");
  sub->add_flag("--force", args->force,
                "Replace the files of an earlier tsf run in the --out folder");
  sub->add_flag("--quiet,-q", args->quiet, "No summary or progress on the terminal");
  sub->callback([args] {
    if (args->resolution && args->model != "mesh" && *args->resolution < 2)
      throw Error("--resolution: the voxel stylus needs at least 2 cells across, got " +
                  std::to_string(*args->resolution));
    if (args->resolution && args->model == "mesh" && *args->resolution > 32)
      throw Error("--resolution: the mesh stylus takes at most 32 spheres across, got " +
                  std::to_string(*args->resolution));
    run_haptics(*args);
  });
}

}  // namespace tsf::app

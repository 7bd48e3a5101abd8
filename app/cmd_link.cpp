// `tsf link SCENE`: a live session without a window (docs/live.md). The scene's tissue runs in
// real time; its tools follow OpenIGTLink TRANSFORMs from a tracker or a haptic bridge (device
// name ↔ tool name), the deformed, cut surface is served as POLYDATA at the display rate (what 3D
// Slicer's OpenIGTLinkIF shows as a model), and each driven tool's force goes back as SENSOR.
// The scene's script plays at its times too. It runs until --seconds or Ctrl-C, then writes the
// scene's outputs and link-report.json.
//
//   tsf link scenes/link-block.yaml                        # Slicer: connect a client to :18944
//   tsf link scenes/cut-cranium.yaml --igtl-tool wand=StylusTipToReference:ablate
//            --igtl-connect 127.0.0.1:18944 --igtl-port -1  # a PlusServer's stylus drives the wand
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "commands.h"
#include "link/link_session.h"
#include "output/interrupt.h"
#include "output/output_folder.h"
#include "scene/interaction_run.h"
#include "scene/scene.h"
#include "scene/scene_outputs.h"
#include "scene/scene_session.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/version.h"

namespace tsf::app {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct LinkArguments {
  std::string scene;
  std::string out;
  std::string backend;
  double seconds = -1;
  bool force = false;
  bool quiet = false;
  link::LinkOptions link;
};

/// What the session's callbacks share across frames.
struct LiveState {
  link::LinkSession* session = nullptr;
  const Scene* scene = nullptr;
  Clock::time_point start;
  bool started = false;
  bool quiet = false;
  std::vector<VolumeGeometry> frames;  ///< each instance's patient frame
  std::vector<link::LinkSession::Drive> drives;
  std::vector<bool> was_held;
  std::vector<Vec3d> force_sum;  ///< per binding, over the instances of this frame
  double behind_s = 0;           ///< how far the simulation ran behind the wall clock, at most
  double time_s = 0;             ///< the frame's session time
  std::vector<std::size_t> served_triangles;  ///< per instance, of the last surface served
};

/// Before each instance's advance: wait for the wall clock (frame start = session time), then
/// move the tools the link drives.
std::vector<EditRecord> drive_tools(LiveState& s, double t, std::size_t instance,
                                    interaction::TissueModel& model, const VolumeGeometry& frame) {
  if (!s.started) {
    s.started = true;
    s.start = Clock::now();
    if (!s.quiet) {
      std::printf("tsf link: running (session time 0; Ctrl-C stops)\n");
      std::fflush(stdout);
    }
  }
  if (instance == 0) {
    const auto due =
        s.start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t));
    const auto now = Clock::now();
    if (now < due)
      std::this_thread::sleep_until(due);
    else
      s.behind_s = std::max(s.behind_s, std::chrono::duration<double>(now - due).count());
  }
  s.time_s = t;
  if (s.frames.size() <= instance) s.frames.resize(instance + 1);
  s.frames[instance] = frame;
  s.drives = s.session->drives(frame, t);
  if (s.was_held.size() != s.drives.size()) s.was_held.assign(s.drives.size(), false);
  std::vector<EditRecord> edits;
  const std::vector<link::ToolBinding>& bindings = s.session->bindings();
  for (const link::LinkSession::Drive& d : s.drives) {
    // Each tool acts in its own slot (the hand the scene's script gives it too).
    const SceneTool& tool = s.scene->tools.at(d.tool);
    const int slot = scene_tool_slot(*s.scene, tool.name);
    if (d.held && d.mode != interaction::ToolMode::kIdle) {
      interaction::EditReport e = model.apply_tool(slot, tool.tool, d.pose, d.mode);
      if (e.edited) edits.push_back({t, bindings[d.binding].tool, e});
    } else if (s.was_held[d.binding]) {
      model.release_tool(slot);
    }
  }
  if (instance + 1 == s.scene->instances.size())
    for (const link::LinkSession::Drive& d : s.drives) s.was_held[d.binding] = d.held;
  return edits;
}

/// After each instance's advance: its surface when one is due, and the driven tools' forces
/// (summed over the instances; sent after the last).
void serve_frame(LiveState& s, std::size_t instance, const interaction::TissueModel& model,
                 bool surface_due) {
  const VolumeGeometry& frame = s.frames.at(instance);
  if (surface_due) {
    const imt::SurfaceMesh& mesh = model.deformed_mesh();
    s.session->publish_surface(mesh_in_patient_frame(mesh, frame),
                               s.scene->multi_instance ? s.scene->instances[instance].name : "");
    // A cut or an ablation reaches the served surface: say so (a peer's model changes now).
    if (s.served_triangles.size() <= instance) s.served_triangles.resize(instance + 1, 0);
    std::size_t& before = s.served_triangles[instance];
    if (before != 0 && before != mesh.triangles.size() && !s.quiet) {
      std::printf("tsf link: %.3f s: served surface %s%zu -> %zu triangles\n", s.time_s,
                  s.scene->multi_instance ? (s.scene->instances[instance].name + ": ").c_str() : "",
                  before, mesh.triangles.size());
      std::fflush(stdout);
    }
    before = mesh.triangles.size();
  }
  if (instance == 0) s.force_sum.assign(s.drives.size(), Vec3d{0, 0, 0});
  for (const link::LinkSession::Drive& d : s.drives)
    if (d.held)
      s.force_sum[d.binding] +=
          model.tool_contact(scene_tool_slot(*s.scene, s.scene->tools.at(d.tool).name)).force_un;
  if (instance + 1 == s.scene->instances.size())
    for (const link::LinkSession::Drive& d : s.drives)
      if (d.held && d.fresh) s.session->send_force(d.binding, s.force_sum[d.binding], frame);
}

void run_link(const LinkArguments& args) {
  Scene scene = read_scene(args.scene);
  check_scene_for_command(scene, SceneCommand::kLink);
  override_backend(scene, args.backend);
  const OutputFolder folder =
      OutputFolder::prepare(args.out.empty() ? std::filesystem::path("out") / (scene.name + "-link")
                                             : std::filesystem::path(args.out),
                            args.force, "--out");
  if (!args.link.enabled())
    throw Error(
        "--igtl-port -1 and no --igtl-connect: nothing to link (listen on a port, or "
        "connect to a server with --igtl-connect HOST:PORT)");
  std::vector<link::LinkSession::NamedTool> tools;
  for (const SceneTool& t : scene.tools) tools.push_back({t.name, t.tool});
  // The link first (a port in use or a bad --igtl-tool is said before the slow model build).
  link::LinkSession session(args.link, tools, scene.name);
  if (!args.quiet) {
    std::printf("tsf link: %s\n", session.describe().c_str());
    std::fflush(stdout);
  }

  InteractionRunOptions run;
  run.duration_s = args.seconds >= 0 ? args.seconds : 1e5;
  run.quiet = args.quiet;
  run.progress = false;
  InteractionOutputs& out = run.outputs;
  out.states_every = scene.outputs.states_every;
  out.mesh = folder.file(scene.outputs.mesh.empty() ? std::filesystem::path("final.ply")
                                                    : scene.outputs.mesh);
  out.rest_mesh = folder.file(scene.outputs.rest_mesh);
  out.states = folder.file(scene.outputs.states);
  LiveState live;
  live.session = &session;
  live.scene = &scene;
  live.quiet = args.quiet;
  bool surface_due = false;
  run.before_advance = [&](double t, std::size_t i, interaction::TissueModel& model,
                           const VolumeGeometry& frame) {
    if (i == 0) surface_due = false;
    return drive_tools(live, t, i, model, frame);
  };
  run.on_frame = [&](double, std::size_t i, const interaction::TissueModel& model) {
    if (i == 0) surface_due = session.surface_due();
    serve_frame(live, i, model, surface_due);
  };
  InterruptScope interrupts;
  const InteractionResult result = run_interaction_scene(scene, run);
  const double session_s =
      live.started ? std::chrono::duration<double>(Clock::now() - live.start).count() : 0.0;

  json report = interaction_report_json(scene, result);
  json link = session.report_json(session_s);
  link["session_s"] = session_s;
  link["stopped_by"] = result.interrupted   ? "signal"
                       : result.instability ? "instability"
                                            : "--seconds";
  link["simulated_s"] = static_cast<double>(result.frames) / scene.script.frame_rate_hz;
  link["max_behind_wall_clock_s"] = live.behind_s;
  report["link"] = link;
  write_text_atomically(folder.file("link-report.json"), report.dump(2) + "\n");
  if (!args.quiet) {
    const link::LinkStatistics st = session.server().statistics();
    std::printf(
        "tsf link: %.1f s: %lld peers, %lld TRANSFORM in, %lld POLYDATA out (%.1f/s, %zu "
        "bytes each), %lld SENSOR out; the simulation ran behind the wall clock by %.3f s at "
        "most\n",
        session_s, static_cast<long long>(st.peers_connected),
        static_cast<long long>(st.transforms_in), static_cast<long long>(st.polydata_sent),
        link["surface"]["rate_hz"].get<double>(), st.last_polydata_bytes,
        static_cast<long long>(st.sensors_sent), live.behind_s);
    std::printf("wrote %s\n", folder.file("link-report.json").c_str());
  }
  if (result.instability) throw Error("unstable: " + *result.instability);
  if (const InstanceResult* worst = result.least_stable())
    require_stable_enough(worst->stability,
                          scene.multi_instance ? scene.name + "/" + worst->name : scene.name);
}

}  // namespace

void add_link_command(CLI::App& app) {
  CLI::App* sub = app.add_subcommand(
      "link",
      "Live session without a window, linked over OpenIGTLink (3D Slicer, PLUS, haptic "
      "bridges): the scene's tissue runs in real time, its tools follow TRANSFORM messages, the "
      "deformed, cut surface is served as POLYDATA and each driven tool's force is sent back as "
      "SENSOR; the scene's script plays too. Runs until --seconds or Ctrl-C (docs/live.md)");
  auto args = std::make_shared<LinkArguments>();
  sub->add_option("scene", args->scene,
                  "Scene file (YAML) with tissue and tools, e.g. scenes/link-block.yaml")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--seconds", args->seconds,
                  "Stop after this many seconds of session time (default: run until Ctrl-C)")
      ->check(CLI::Range(0.0, 1e5));
  sub->add_option("--out,-o", args->out,
                  "Output folder for link-report.json and the scene's outputs (default "
                  "out/<scene name>-link; new or empty, see --force)");
  sub->add_flag("--force", args->force,
                "Replace the files of an earlier tsf run in the --out folder");
  sub->add_option("--backend", args->backend, "Override the scene's backend: cpu, cuda or auto")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}));
  sub->add_flag("--quiet,-q", args->quiet, "No summary on the terminal");
  link::add_link_options(*sub, args->link, 18944, true);
  sub->callback([args] { run_link(*args); });
}

}  // namespace tsf::app

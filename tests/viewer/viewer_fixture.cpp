#include "viewer_fixture.h"

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <mutex>

#include <sys/prctl.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::test {
namespace {

pid_t g_xvfb = -1;

void stop_xvfb() {
  if (g_xvfb > 0) {
    kill(g_xvfb, SIGTERM);
    int status = 0;
    waitpid(g_xvfb, &status, 0);
    g_xvfb = -1;
  }
}

bool on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return false;
  std::string p = path;
  std::size_t start = 0;
  while (start <= p.size()) {
    const std::size_t end = p.find(':', start);
    const std::string dir =
        p.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!dir.empty() && access((dir + "/" + program).c_str(), X_OK) == 0) return true;
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return false;
}

/// Starts `Xvfb -displayfd` and sets DISPLAY to the display it picked; empty string on success.
std::string start_xvfb() {
  if (!on_path("Xvfb"))
    return "no X server: DISPLAY is unset and Xvfb is not installed (apt-get install xvfb xauth)";
  int fds[2];
  if (pipe(fds) != 0) return "cannot create a pipe to start Xvfb";
  const pid_t pid = fork();
  if (pid < 0) return "cannot fork to start Xvfb";
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGTERM);  // Xvfb goes when the tests go, even if they crash
    close(fds[0]);
    const std::string fd = std::to_string(fds[1]);
    // Only the display-number pipe stays open: an inherited stdout would keep a reader of this
    // process's output (a pipe) waiting for as long as Xvfb lives.
    std::freopen("/dev/null", "w", stdout);
    std::freopen("/dev/null", "w", stderr);
    execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "1280x1024x24", "-nolisten",
           "tcp", static_cast<char*>(nullptr));
    _exit(127);
  }
  close(fds[1]);
  std::string number;
  char c;
  while (read(fds[0], &c, 1) == 1 && c != '\n') number += c;
  close(fds[0]);
  if (number.empty()) {
    kill(pid, SIGTERM);
    waitpid(pid, nullptr, 0);
    return "Xvfb is installed but did not start (no display number on -displayfd)";
  }
  g_xvfb = pid;
  std::atexit(stop_xvfb);
  setenv("DISPLAY", (":" + number).c_str(), 1);
  return {};
}

}  // namespace

std::string x_display_unavailable_reason() {
  static std::once_flag once;
  static std::string reason;
  std::call_once(once, [] {
    const char* d = std::getenv("DISPLAY");
    if (d == nullptr || *d == '\0') reason = start_xvfb();
    if (reason.empty()) {
      const viewer::DisplayStatus s = viewer::x_display_status();
      if (!s.available) reason = s.reason;
    }
  });
  return reason;
}

std::unique_ptr<viewer::SimulationSession> make_block_session() {
  // 1 mm voxels with a 2-voxel empty rim: the block spans [0, 40] × [0, 16] × [0, 12] mm.
  VolumeGeometry g;
  g.dims = {44, 20, 16};
  g.spacing = {1, 1, 1};
  g.origin = {-1.5, -1.5, -1.5};
  const Vec3d half{20, 8, 6}, centre{20, 8, 6};
  VoxelVolume volume = make_sdf_volume(
      g, [&](const Vec3d& p) { return box_distance_local(half, p - centre); }, 0.5);
  interaction::TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.backend = crms::Backend::kCpu;
  o.solver.materials.at(0).youngs_modulus_pa = 50000;
  o.solver.materials.at(0).viscosity_pa_s = 5;
  o.solver.stability.kinetic_damping = 0.01;
  o.anchor = [](crms::Lattice& l) { crms::fix_nodes_in_box(l, {-5, -5, -5}, {2, 25, 25}); };
  auto model = std::make_unique<interaction::TissueModel>(std::move(volume), o);
  std::vector<viewer::NamedTool> tools(3);
  tools[0].name = "ball";
  tools[0].tool.shape = collision::ToolShape::kSphere;
  tools[0].tool.radius_mm = 3;
  tools[1].name = "wand";
  tools[1].tool.shape = collision::ToolShape::kCapsule;
  tools[1].tool.radius_mm = 1.5;
  tools[1].tool.half_length_mm = 2;
  tools[2].name = "scalpel";
  tools[2].tool.shape = collision::ToolShape::kBlade;
  tools[2].tool.half_extents_mm = {10, 10, 0.5};
  return std::make_unique<viewer::SimulationSession>(std::move(model), std::move(tools));
}

viewer::ViewOptions bare_offscreen_options() {
  viewer::ViewOptions o;
  o.width = 480;
  o.height = 320;
  o.offscreen = true;
  o.show_hud = false;
  o.show_plot = false;
  o.show_tool = false;
  o.slices.show = false;
  o.frame_s = 1e-3;
  o.camera.azimuth_deg = 20;
  o.camera.elevation_deg = 35;
  o.camera.zoom = 1.6;
  return o;
}

}  // namespace tsf::test

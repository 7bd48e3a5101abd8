// bench_viewer: what the viewer pays per frame to show the deformed surface, updating only the
// changed vertex ranges (SurfaceUploader::apply) against re-uploading everything (apply_full),
// on the same recorded frames, in the same run.
//
//   xvfb-run -a build/bench/bench_viewer [--frames N] [--json FILE]
//
// The tissue: a 60 × 40 × 20 mm slab (0.5 mm voxels, nodes every 2 mm), no gravity; a 3 mm ball
// presses into its top and moves along it. Two cases: anchored underneath only (the poke sets the
// whole slab moving a little, so nearly every vertex changes every frame), and also held outside
// 6 mm of the ball's path (motion stays local, as in tissue held by its surroundings). The frames
// are simulated once and recorded (buffers + deltas); each method then replays them into its own
// offscreen window, timing (a) the CPU-side update alone and (b) update + draw (Render, llvmpipe
// under Xvfb here). Figures are means over the frames; the machine may be shared (noisy).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <vtkActor.h>
#include <vtkNew.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>

#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/viewer/simulation_session.h"
#include "tsf/viewer/surface_uploader.h"
#include "tsf/viewer/viewer.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/tool_shapes.h"

namespace {

using namespace tsf;
using Clock = std::chrono::steady_clock;

struct Recorded {
  viewer::SurfaceBuffers buffers;
  viewer::SurfaceDelta delta;
};

/// `free_radius_mm` < 0: only the bottom is anchored (the poke moves the whole slab a little);
/// else every node farther than that from the poke's line (y = 20, z up) is anchored too, so
/// motion stays local (a tissue held by its surroundings).
std::unique_ptr<viewer::SimulationSession> make_slab(double free_radius_mm) {
  VolumeGeometry g;
  g.spacing = {0.5, 0.5, 0.5};
  g.dims = {128, 88, 48};
  g.origin = {-1.75, -1.75, -1.75};
  const Vec3d half{30, 20, 10}, centre{30, 20, 10};
  VoxelVolume v = make_sdf_volume(
      g, [&](const Vec3d& p) { return box_distance_local(half, p - centre); }, 0.25);
  interaction::TissueModelOptions o;
  o.lattice.node_spacing_voxels = 4;
  o.solver.backend = crms::Backend::kCpu;
  o.solver.materials.at(0).youngs_modulus_pa = 30000;
  o.solver.materials.at(0).viscosity_pa_s = 5;
  o.solver.stability.kinetic_damping = 0.01;
  o.anchor = [free_radius_mm](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-5, -5, -5}, {65, 45, 2});
    if (free_radius_mm < 0) return;
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      const Vec3d p = l.geometry().rest_position(n);
      const double dx = p.x < 15 ? 15 - p.x : (p.x > 45 ? p.x - 45 : 0.0);
      if (std::hypot(dx, p.y - 20) > free_radius_mm) l.set_fixed(n, true);
    }
  };
  auto model = std::make_unique<interaction::TissueModel>(std::move(v), o);
  std::vector<viewer::NamedTool> tools(1);
  tools[0].name = "ball";
  tools[0].tool.radius_mm = 3;
  return std::make_unique<viewer::SimulationSession>(std::move(model), std::move(tools));
}

struct Timing {
  double update_ms = 0, total_ms = 0;
  std::size_t copied = 0;
};

Timing replay(const std::vector<Recorded>& frames, bool ranges) {
  viewer::SurfaceUploader up;
  up.apply_full(frames.front().buffers);
  vtkNew<vtkRenderer> renderer;
  vtkNew<vtkRenderWindow> window;
  window->SetOffScreenRendering(1);
  window->SetSize(1024, 768);
  window->AddRenderer(renderer);
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(up.poly_data());
  mapper->SetColorModeToDirectScalars();
  vtkNew<vtkActor> actor;
  actor->SetMapper(mapper);
  renderer->AddActor(actor);
  renderer->ResetCamera();
  window->Render();
  Timing t;
  for (std::size_t f = 1; f < frames.size(); ++f) {
    const Clock::time_point a = Clock::now();
    t.copied +=
        ranges ? up.apply(frames[f].buffers, frames[f].delta) : up.apply_full(frames[f].buffers);
    const Clock::time_point b = Clock::now();
    window->Render();
    const Clock::time_point c = Clock::now();
    t.update_ms += std::chrono::duration<double, std::milli>(b - a).count();
    t.total_ms += std::chrono::duration<double, std::milli>(c - a).count();
  }
  const double n = static_cast<double>(frames.size() - 1);
  t.update_ms /= n;
  t.total_ms /= n;
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    int frames = 60;
    std::string json;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--frames" && i + 1 < argc) {
        frames = std::stoi(argv[++i]);
      } else if (a == "--json" && i + 1 < argc) {
        json = argv[++i];
      } else {
        std::fprintf(stderr, "usage: bench_viewer [--frames N (>= 2)] [--json FILE]\n");
        return a == "--help" || a == "-h" ? 0 : 2;
      }
    }
    require(frames >= 2, "--frames: expected at least 2");
    const viewer::DisplayStatus display = viewer::x_display_status();
    if (!display.available) throw Error("bench_viewer: " + display.reason);

    std::string json_rows;
    for (const double free_radius : {-1.0, 6.0}) {
      auto session = make_slab(free_radius);
      session->publish_initial();
      std::vector<Recorded> rec;
      auto record = [&] {
        session->exchange().consume(
            [&](const viewer::SurfaceBuffers& b, const viewer::SurfaceDelta& d) {
              rec.push_back({b, d});
            });
      };
      record();
      viewer::ToolCommand ball;
      ball.mode = interaction::ToolMode::kPress;
      for (int f = 1; f < frames; ++f) {
        const double s = static_cast<double>(f) / frames;
        ball.pose.position = {15 + 30 * s, 20, 20 + 3 - std::min(2.5, 0.25 * f)};
        session->step(1e-3, ball);
        record();
      }
      require(session->stats().error.empty(), "bench_viewer: " + session->stats().error);
      const std::size_t slots = rec.back().buffers.positions.size();
      std::size_t changed = 0;
      for (std::size_t f = 1; f < rec.size(); ++f)
        for (const auto& r : rec[f].delta.ranges) changed += r.second - r.first;
      const double fraction =
          static_cast<double>(changed) / static_cast<double>(slots * (rec.size() - 1));
      const Timing ranged = replay(rec, true);
      const Timing full = replay(rec, false);
      const char* name = free_radius < 0 ? "slab anchored below (global motion)"
                                         : "slab held 6 mm around the path (local motion)";
      std::printf(
          "\n%s: %zu vertex slots, %zu live triangles, %d frames; changed ranges cover "
          "%.1f%% of the slots per frame\n",
          name, slots, rec.back().buffers.live_triangles, frames, 100.0 * fraction);
      std::printf("%-28s %12s %14s\n", "", "update ms", "update+draw ms");
      std::printf("%-28s %12.3f %14.3f\n", "changed ranges (apply)", ranged.update_ms,
                  ranged.total_ms);
      std::printf("%-28s %12.3f %14.3f\n", "full re-upload (apply_full)", full.update_ms,
                  full.total_ms);
      std::printf("ratio full / ranges: update %.1fx, update+draw %.2fx\n",
                  full.update_ms / ranged.update_ms, full.total_ms / ranged.total_ms);
      char row[512];
      std::snprintf(row, sizeof row,
                    "%s    {\"case\": \"%s\", \"vertex_slots\": %zu, \"changed_fraction\": %.4f, "
                    "\"ranges_update_ms\": %.4f, \"ranges_update_draw_ms\": %.4f, "
                    "\"full_update_ms\": %.4f, \"full_update_draw_ms\": %.4f}",
                    json_rows.empty() ? "" : ",\n", name, slots, fraction, ranged.update_ms,
                    ranged.total_ms, full.update_ms, full.total_ms);
      json_rows += row;
    }
    if (!json.empty())
      write_text_atomically(json, "{\n  \"frames\": " + std::to_string(frames) +
                                      ",\n  \"cases\": [\n" + json_rows + "\n  ]\n}\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_viewer: error: %s\n", e.what());
    return 1;
  }
}

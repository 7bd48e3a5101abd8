#include "tsf/haptics/frame_capture.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "tsf/common/error.h"
#include "tsf/haptics/local_warp.h"

namespace tsf::haptics {
namespace {

/// `v` clamped to [lo, hi] while still a double (a point far from the grid, or NaN, would
/// overflow the conversion to int).
int clamped_index(double v, int lo, int hi) {
  if (!(v >= lo)) return lo;
  return v > hi ? hi : static_cast<int>(v);
}

/// Index range [lo, hi] of grid points origin + i·h (i in [0, n)) within [c − e, c + e]; empty
/// (hi < lo) when the box misses the grid.
void grid_range(double origin, double h, int n, double c, double e, int& lo, int& hi) {
  lo = clamped_index(std::floor((c - e - origin) / h), 0, n);
  hi = clamped_index(std::ceil((c + e - origin) / h), -1, n - 1);
}

/// Bounds of a density window (capture_density): its corner lies within this many voxels of the
/// volume, and it holds at most this many voxels.
constexpr double kMaxWindowOffsetVoxels = 1 << 24;
constexpr double kMaxWindowVoxels = 1 << 26;

}  // namespace

void capture_density(const VoxelVolume& volume, const Vec3d& centre, double half_extent_mm,
                     HapticFrame& frame) {
  // The window is the whole requested box, one voxel beyond it on each side, whether or not the
  // volume reaches that far (outside it the density is 0): a stylus within the reach then always
  // lies strictly inside the window and takes the sampler without bounds tests.
  // The index range is checked while still in doubles: a stylus far from the volume or a window
  // too large to hold is an error, never an integer overflow or a huge allocation.
  const VolumeGeometry& g = volume.geometry();
  int lo[3], n[3];
  double voxels = 1;
  for (int a = 0; a < 3; ++a) {
    const double l = std::floor((centre[a] - half_extent_mm - g.origin[a]) / g.spacing[a]) - 1;
    const double h = std::ceil((centre[a] + half_extent_mm - g.origin[a]) / g.spacing[a]) + 1;
    if (!(l >= -kMaxWindowOffsetVoxels && h <= g.dims[a] + kMaxWindowOffsetVoxels)) {
      std::ostringstream s;
      s << "haptic frame: the stylus at (" << centre.x << ", " << centre.y << ", " << centre.z
        << ") mm is more than " << kMaxWindowOffsetVoxels << " voxels outside the tissue volume";
      throw Error(s.str());
    }
    lo[a] = static_cast<int>(l);
    n[a] = static_cast<int>(h - l) + 1;
    voxels *= n[a];
  }
  if (voxels > kMaxWindowVoxels) {
    std::ostringstream s;
    s << "haptic frame: a window reaching " << half_extent_mm << " mm at "
      << std::min({g.spacing.x, g.spacing.y, g.spacing.z}) << " mm voxels holds " << voxels
      << " voxels; expected at most " << kMaxWindowVoxels << " (a stylus radius too large for the"
      << " voxel size)";
    throw Error(s.str());
  }
  const Int3 dims{n[0], n[1], n[2]};
  frame.density.assign(static_cast<std::size_t>(dims.volume()), 0.0f);
  frame.density_dims = dims;
  frame.density_origin = g.index_to_tissue({double(lo[0]), double(lo[1]), double(lo[2])});
  frame.density_spacing = g.spacing;
  // The part of the window inside the volume, copied row by row.
  const int i0 = std::max(0, lo[0]), i1 = std::min(g.dims.x - 1, lo[0] + n[0] - 1);
  const std::vector<float>& src = volume.density_data();
  if (i0 <= i1)
    for (int k = std::max(0, lo[2]); k <= std::min(g.dims.z - 1, lo[2] + n[2] - 1); ++k)
      for (int j = std::max(0, lo[1]); j <= std::min(g.dims.y - 1, lo[1] + n[1] - 1); ++j) {
        const float* row = src.data() + volume.index(i0, j, k);
        float* dst = frame.density.data() + (i0 - lo[0]) +
                     static_cast<std::size_t>(n[0]) *
                         ((j - lo[1]) + static_cast<std::size_t>(n[1]) * (k - lo[2]));
        std::copy(row, row + (i1 - i0 + 1), dst);
      }
  // Classify the cubes between voxel centres once per capture, so the per-tick trilinear reads
  // skip the eight loads where the tissue is uniformly empty or full.
  frame.density_cells.resize(frame.density.size());
  const float* d = frame.density.data();
  const std::size_t sy = static_cast<std::size_t>(dims.x),
                    sz = sy * static_cast<std::size_t>(dims.y);
  for (int k = 0; k < dims.z; ++k)
    for (int j = 0; j < dims.y; ++j)
      for (int i = 0; i < dims.x; ++i) {
        const std::size_t v = i + sy * j + sz * k;
        std::uint8_t c = kCellMixed;
        if (i + 1 < dims.x && j + 1 < dims.y && k + 1 < dims.z) {
          const float corners[8] = {d[v],      d[v + 1],      d[v + sy],      d[v + 1 + sy],
                                    d[v + sz], d[v + 1 + sz], d[v + sy + sz], d[v + 1 + sy + sz]};
          bool empty = true, full = true;
          for (float x : corners) {
            empty = empty && x == 0.0f;
            full = full && x == 1.0f;
          }
          c = empty ? kCellEmpty : (full ? kCellFull : kCellMixed);
        }
        frame.density_cells[v] = c;
      }
}

void capture_lattice(const crms::Lattice& lattice, const float* positions, const Vec3d& centre,
                     double half_extent_mm, HapticFrame& frame) {
  const crms::LatticeGeometry& g = lattice.geometry();
  int lo[3], hi[3];
  for (int a = 0; a < 3; ++a)
    grid_range(g.origin[a], g.spacing[a], g.dims[a], centre[a], half_extent_mm + g.spacing[a],
               lo[a], hi[a]);
  if (hi[0] - lo[0] < 1 || hi[1] - lo[1] < 1 || hi[2] - lo[2] < 1) {
    frame.displacement.clear();
    frame.alive.clear();
    frame.lattice_dims = {0, 0, 0};
    return;
  }
  const Int3 dims{hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1};
  const std::size_t count = static_cast<std::size_t>(dims.volume());
  frame.displacement.resize(count);
  frame.alive.resize(count);
  frame.lattice_dims = dims;
  frame.lattice_origin = g.rest_position(lo[0], lo[1], lo[2]);
  frame.lattice_spacing = g.spacing;
  std::size_t w = 0;
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i, ++w) {
        const std::int64_t n = g.index(i, j, k);
        const Vec3d rest = g.rest_position(i, j, k);
        const float* p = positions + 3 * n;
        frame.displacement[w] = to_float(Vec3d{double(p[0]), double(p[1]), double(p[2])} - rest);
        frame.alive[w] = lattice.alive(n) ? 1 : 0;
      }
}

void capture_triangles(const std::vector<Vec3f>& positions, const std::vector<Vec3f>& normals,
                       const std::vector<std::array<std::uint32_t, 3>>& triangles,
                       const std::vector<std::uint8_t>* triangle_live, const Vec3d& centre,
                       double reach_mm, HapticFrame& frame) {
  frame.corners.clear();
  frame.normals.clear();
  const Vec3f c = to_float(centre);
  const float reach = static_cast<float>(reach_mm);
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    if (triangle_live && !(*triangle_live)[t]) continue;
    const auto& tri = triangles[t];
    const Vec3f a = positions[tri[0]], b = positions[tri[1]], d = positions[tri[2]];
    const Vec3f mid = (a + b + d) / 3.0f;
    const float r = std::sqrt(std::max(length_squared(a - mid),
                                       std::max(length_squared(b - mid), length_squared(d - mid))));
    const float limit = reach + r;
    if (length_squared(mid - c) > limit * limit) continue;
    // Zero-area triangles (IMT keeps some where snapped vertices coincide) add nothing that their
    // neighbours' edges do not: leave them out of the patch.
    if (!(length_squared(cross(b - a, d - a)) > 1e-18f)) continue;
    for (int k = 0; k < 3; ++k) {
      frame.corners.push_back(positions[tri[k]]);
      frame.normals.push_back(normals[tri[k]]);
    }
  }
}

// ---- static --------------------------------------------------------------------------------

StaticFrameSource::StaticFrameSource(const VoxelVolume& volume, const imt::SurfaceMesh* mesh,
                                     const CaptureOptions& options)
    : volume_(volume), mesh_(mesh), options_(options) {
  require(options.reach_mm > 0 && options.margin_mm >= 0,
          "frame capture: expected reach > 0 and margin ≥ 0 mm");
}

void StaticFrameSource::step(double dt_s, const StylusPose& pose, bool, HapticFrame& out) {
  time_s_ += dt_s;
  const double extent = options_.reach_mm + options_.margin_mm;
  capture_density(volume_, pose.position, extent, out);
  out.displacement.clear();
  out.alive.clear();
  out.lattice_dims = {0, 0, 0};
  if (mesh_)
    capture_triangles(mesh_->positions, mesh_->normals, mesh_->triangles, nullptr, pose.position,
                      extent, out);
  else {
    out.corners.clear();
    out.normals.clear();
  }
  out.contact_force_un = {0, 0, 0};
  out.contact_nodes = 0;
  out.time_s = time_s_;
  out.sequence = ++sequence_;
}

TissueFrameCapture::TissueFrameCapture(const CaptureOptions& options) : options_(options) {
  require(options.reach_mm > 0 && options.margin_mm >= 0,
          "frame capture: expected reach > 0 and margin ≥ 0 mm");
}

void TissueFrameCapture::capture(interaction::TissueModel& model, const StylusPose& pose,
                                 const Vec3d& contact_force_un, std::int64_t contact_nodes,
                                 double time_s, HapticFrame& out) {
  const double extent = options_.reach_mm + options_.margin_mm;
  const FrameParts& parts = parts_;
  crms::Solver& solver = model.solver();
  out.displacement.clear();
  out.alive.clear();
  out.lattice_dims = {0, 0, 0};
  out.density.clear();
  out.density_cells.clear();
  out.density_dims = {0, 0, 0};
  bool warped = false;
  if (parts.lattice) {
    solver.request_snapshot();
    solver.poll_snapshot();
    solver.snapshots().copy_latest(snapshot_);
  }
  const crms::Lattice& lattice = solver.lattice();
  if (parts.lattice && snapshot_.size() == static_cast<std::size_t>(lattice.node_count()) * 3) {
    // The window is centred on the rest point of the stylus centre (through the lattice as it is
    // now), so a tissue displaced by more than the margin is still found.
    const interaction::RestPoint rest = model.map_to_rest(pose.position, extent);
    const Vec3d rest_centre = rest.found ? rest.rest : pose.position;
    capture_lattice(lattice, snapshot_.data(), rest_centre, extent + lattice.geometry().spacing.x,
                    out);
    if (parts.density) {
      const LocalWarp warp = inverse_warp(out.view().lattice, pose.position);
      // A stretched neighbourhood needs a larger rest window: scale by the largest |F⁻¹| row sum.
      double stretch = 1.0;
      for (int r = 0; r < 3; ++r)
        stretch =
            std::max(stretch, std::fabs(warp.F_inv[3 * r]) + std::fabs(warp.F_inv[3 * r + 1]) +
                                  std::fabs(warp.F_inv[3 * r + 2]));
      capture_density(model.volume(), warp.rest_centre, extent * std::min(stretch, 3.0), out);
      warped = true;
    }
  }
  if (parts.density && !warped) capture_density(model.volume(), pose.position, extent, out);
  out.corners.clear();
  out.normals.clear();
  if (parts.triangles) {
    const imt::ImtSurface& surface = model.surface();
    const std::uint32_t tri_slots = surface.triangle_slot_count();
    triangle_live_.resize(surface.triangles().size());
    for (std::size_t t = 0; t < triangle_live_.size(); ++t)
      triangle_live_[t] =
          t < tri_slots && surface.triangle_live(static_cast<std::uint32_t>(t)) ? 1 : 0;
    capture_triangles(model.coupler().positions(), model.coupler().normals(), surface.triangles(),
                      &triangle_live_, pose.position, extent, out);
  }
  out.contact_force_un = contact_force_un;
  out.contact_nodes = contact_nodes;
  out.time_s = time_s;
  out.sequence = ++sequence_;
  out.published_ns = 0;
}

// ---- tissue --------------------------------------------------------------------------------

TissueFrameSource::TissueFrameSource(interaction::TissueModel& model, const CaptureOptions& options)
    : model_(model), capture_(options) {
  tool_.shape = collision::ToolShape::kSphere;
  tool_.radius_mm = options.reach_mm;
}

void TissueFrameSource::step(double dt_s, const StylusPose& pose, bool press, HapticFrame& out) {
  if (press) {
    // A stylus that has not moved keeps its contact: advance() re-resolves it between steps.
    const bool moved = !pressing_ || length(pose.position - last_pose_.position) > 0.0 ||
                       pose.orientation.angle_to(last_pose_.orientation) > 0.0;
    if (moved) model_.apply_tool(tool_, pose, interaction::ToolMode::kPress);
    pressing_ = true;
    last_pose_ = pose;
  } else if (pressing_) {
    model_.release_tool();
    pressing_ = false;
  }
  if (dt_s > 0) model_.advance(dt_s);
  time_s_ += dt_s;
  const collision::ContactForce& contact = model_.contact();
  capture_.capture(model_, pose, pressing_ ? contact.force_un : Vec3d{0, 0, 0},
                   pressing_ ? static_cast<std::int64_t>(contact.nodes_held) : 0, time_s_, out);
}

}  // namespace tsf::haptics

#include "tsf/haptics/force_models.h"

#include <cmath>
#include <string>
#include <vector>

#include "tsf/common/error.h"
#include "tsf/haptics/local_warp.h"
#include "tsf/haptics/mesh_force.h"
#include "tsf/haptics/voxel_force.h"

namespace tsf::haptics {

const char* to_string(ForceModelKind kind) {
  switch (kind) {
    case ForceModelKind::kVoxel:
      return "voxel";
    case ForceModelKind::kLattice:
      return "lattice";
    case ForceModelKind::kMesh:
      return "mesh";
  }
  return "?";
}

ForceModelKind force_model_from_string(const std::string& text) {
  if (text == "voxel") return ForceModelKind::kVoxel;
  if (text == "lattice") return ForceModelKind::kLattice;
  if (text == "mesh") return ForceModelKind::kMesh;
  throw Error("force model: expected voxel, lattice or mesh, got '" + text + "'");
}

void ForceLaw::validate() const {
  require(std::isfinite(c1) && c1 > 0,
          "force law c1: expected a finite number > 0, got " + std::to_string(c1));
  require(std::isfinite(c2) && c2 > 0 && c2 <= 4,
          "force law c2: expected a number in (0, 4], got " + std::to_string(c2));
  require(
      cutoff_fraction > 0 && cutoff_fraction <= 1,
      "force law cutoff: expected a fraction in (0, 1], got " + std::to_string(cutoff_fraction));
  require(taper_fraction >= 0 && taper_fraction < 1,
          "force law taper: expected a fraction in [0, 1), got " + std::to_string(taper_fraction));
}

void ForceModelOptions::validate() const {
  require(
      std::isfinite(stylus_radius_mm) && stylus_radius_mm > 0,
      "stylus radius: expected a finite number > 0 mm, got " + std::to_string(stylus_radius_mm));
  require(voxel_resolution >= 2 && voxel_resolution <= 128,
          "stylus voxel resolution: expected 2..128, got " + std::to_string(voxel_resolution));
  require(sphere_resolution >= 1 && sphere_resolution <= 32,
          "stylus sphere resolution: expected 1..32, got " + std::to_string(sphere_resolution));
  require(std::isfinite(lattice_gain) && lattice_gain > 0,
          "lattice gain: expected a finite number > 0, got " + std::to_string(lattice_gain));
  law.validate();
}

// ---- voxel ---------------------------------------------------------------------------------

VoxelForceModel::VoxelForceModel(const ForceModelOptions& options)
    : stylus_(make_sphere_stylus(options.stylus_radius_mm, options.voxel_resolution)),
      law_(options.law),
      sampling_(options.sampling) {
  options.validate();
}

namespace {

/// The per-cell loop: cell offset δ (stylus-local) → grid coordinates g0 + G·δ of its rest point.
template <class Sample>
VoxelAccumulation accumulate_cells(const SphereStylus& stylus, const DensityWindowView& w,
                                   const float g0[3], const float G[9], Sample sample) {
  VoxelAccumulation acc;
  for (const Vec3f& d : stylus.offsets) {
    const float gx = g0[0] + G[0] * d.x + G[1] * d.y + G[2] * d.z;
    const float gy = g0[1] + G[3] * d.x + G[4] * d.y + G[5] * d.z;
    const float gz = g0[2] + G[6] * d.x + G[7] * d.y + G[8] * d.z;
    accumulate_voxel(d, sample(w, gx, gy, gz), acc);
  }
  return acc;
}

}  // namespace

HapticForce VoxelForceModel::evaluate(const HapticFrameView& frame, const StylusPose& pose) const {
  HapticForce out;
  const DensityWindowView& w = frame.density;
  if (w.empty()) return out;
  const LocalWarp warp = inverse_warp(frame.lattice, pose.position);
  out.warped = warp.in_window;
  // A cell's rest point is X + F⁻¹·R·δ (R the stylus orientation, F the local deformation);
  // in the window's grid units that is g0 + G·δ with G = diag(1/spacing)·F⁻¹·R. Composing once
  // leaves 9 multiply-adds per cell; float suffices in grid units (the window is small).
  double R[9];
  for (int c = 0; c < 3; ++c) {
    Vec3d e{0, 0, 0};
    e[c] = 1.0;
    const Vec3d col = pose.orientation.apply(e);
    R[0 * 3 + c] = col.x;
    R[1 * 3 + c] = col.y;
    R[2 * 3 + c] = col.z;
  }
  float G[9], g0[3];
  for (int r = 0; r < 3; ++r) {
    g0[r] = static_cast<float>((warp.rest_centre[r] - w.origin[r]) / w.spacing[r]);
    for (int c = 0; c < 3; ++c)
      G[r * 3 + c] = static_cast<float>((warp.F_inv[r * 3 + 0] * R[0 * 3 + c] +
                                         warp.F_inv[r * 3 + 1] * R[1 * 3 + c] +
                                         warp.F_inv[r * 3 + 2] * R[2 * 3 + c]) /
                                        w.spacing[r]);
  }
  // Inside the window with one voxel to spare on every side, the sampler needs no bounds tests.
  bool interior = true;
  for (int r = 0; r < 3; ++r) {
    const float reach = static_cast<float>(stylus_.radius_mm) *
                        (std::fabs(G[r * 3]) + std::fabs(G[r * 3 + 1]) + std::fabs(G[r * 3 + 2]));
    interior = interior && g0[r] - reach >= 0.0f &&
               g0[r] + reach < static_cast<float>(w.dims[r] - 1) - 1e-3f;
  }
  VoxelAccumulation acc;
  if (sampling_ == DensitySampling::kNearest)
    acc = accumulate_cells(stylus_, w, g0, G, sample_density_nearest);
  else if (interior && w.cells)
    acc = accumulate_cells(stylus_, w, g0, G, sample_density_classified);
  else if (interior)
    acc = accumulate_cells(stylus_, w, g0, G, sample_density_interior);
  else
    acc = accumulate_cells(stylus_, w, g0, G, sample_density_grid);
  // The centroid offset is in stylus-local axes; in the deformed world it is R·δ (the stylus is
  // rigid there; its rest image is what is warped).
  out.force_un = voxel_force(acc, pose.orientation, stylus_.cell_volume_mm3, stylus_.volume_mm3,
                             law_, out.intersection_mm3);
  out.contacts = acc.cells_touched;
  return out;
}

// ---- lattice -------------------------------------------------------------------------------

LatticeForceModel::LatticeForceModel(const ForceModelOptions& options)
    : gain_(options.lattice_gain) {
  options.validate();
}

HapticForce LatticeForceModel::evaluate(const HapticFrameView& frame, const StylusPose&) const {
  // The contact pass of the simulation moved the nodes the stylus displaces to its surface and
  // summed their spring forces (collision/tool_contact.h, thesis §8.5.2): the reaction is read.
  HapticForce out;
  out.force_un = frame.contact_force_un * gain_;
  out.contacts = static_cast<int>(frame.contact_nodes);
  return out;
}

// ---- mesh ----------------------------------------------------------------------------------

MeshForceModel::MeshForceModel(const ForceModelOptions& options)
    : stylus_(make_sphere_set(options.stylus_radius_mm, options.sphere_resolution)),
      law_(options.law) {
  options.validate();
  volume_scale_ = stylus_.volume_mm3 / (static_cast<double>(stylus_.offsets.size()) *
                                        sphere_volume(stylus_.sphere_radius_mm));
}

HapticForce MeshForceModel::evaluate(const HapticFrameView& frame, const StylusPose& pose) const {
  HapticForce out;
  const TrianglePatchView& tris = frame.triangles;
  if (tris.count == 0) return out;
  const double rs = stylus_.sphere_radius_mm;
  const double reach = stylus_.radius_mm;  // every sphere lies inside the stylus
  const std::size_t n_spheres = stylus_.offsets.size();
  // Per-sphere nearest triangle: scratch kept per thread, so evaluations allocate only the first
  // time a thread meets a stylus this large.
  thread_local std::vector<double> nearest;
  thread_local std::vector<std::uint8_t> behind;
  thread_local std::vector<Vec3d> centres;
  nearest.assign(n_spheres, rs);
  behind.assign(n_spheres, 0);
  centres.resize(n_spheres);
  for (std::size_t s = 0; s < n_spheres; ++s)
    centres[s] = pose.position + pose.orientation.apply(to_double(stylus_.offsets[s]));
  Vec3d normal_sum{0, 0, 0};
  for (std::int64_t t = 0; t < tris.count; ++t) {
    const Vec3f* c = tris.corners + 3 * t;
    // Reject the triangle once for the whole stylus: its bounding sphere against the stylus's.
    const Vec3d a = to_double(c[0]), b = to_double(c[1]), cc = to_double(c[2]);
    const Vec3d mid = (a + b + cc) / 3.0;
    const double tri_r = std::sqrt(std::fmax(
        length_squared(a - mid), std::fmax(length_squared(b - mid), length_squared(cc - mid))));
    const double limit = reach + tri_r;
    if (length_squared(mid - pose.position) > limit * limit) continue;
    for (std::size_t s = 0; s < n_spheres; ++s) {
      double d;
      Vec3d n;
      bool inside;
      if (!sphere_triangle_contact(centres[s], rs, c, tris.normals + 3 * t, d, n, inside)) continue;
      normal_sum += n * (rs - d);
      if (d < nearest[s]) {
        nearest[s] = d;
        behind[s] = inside ? 1 : 0;
      }
    }
  }
  double volume = 0;
  for (std::size_t s = 0; s < n_spheres; ++s)
    if (nearest[s] < rs) {
      volume += sphere_cap_volume(sphere_depth(rs, nearest[s], behind[s] != 0), rs);
      ++out.contacts;
    }
  out.intersection_mm3 = volume * volume_scale_;
  out.force_un = normalized_or_zero(normal_sum, 1e-12) *
                 law_.magnitude(out.intersection_mm3, stylus_.volume_mm3);
  return out;
}

std::unique_ptr<ForceModel> make_force_model(ForceModelKind kind,
                                             const ForceModelOptions& options) {
  switch (kind) {
    case ForceModelKind::kVoxel:
      return std::make_unique<VoxelForceModel>(options);
    case ForceModelKind::kLattice:
      return std::make_unique<LatticeForceModel>(options);
    case ForceModelKind::kMesh:
      return std::make_unique<MeshForceModel>(options);
  }
  throw Error("force model: unknown kind");
}

}  // namespace tsf::haptics

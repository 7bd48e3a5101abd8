// Hexahedral grids for the FEM reference (hex_mesh.h).
#include "tsf/reference/hex_mesh.h"

#include <cmath>
#include <sstream>

#include "tsf/common/error.h"

namespace tsf::reference {

std::int64_t HexMesh::active_count() const {
  std::int64_t n = 0;
  for (std::uint8_t a : active) n += a != 0;
  return n;
}

void HexMesh::validate() const {
  for (int a = 0; a < 3; ++a) {
    if (cells[a] < 1) throw Error("hex mesh: cells must be >= 1 along every axis");
    if (!(spacing[a] > 0.0 && std::isfinite(spacing[a])))
      throw Error("hex mesh: spacing must be finite and > 0 mm along every axis");
    if (!std::isfinite(origin[a])) throw Error("hex mesh: origin must be finite");
  }
  if (static_cast<std::int64_t>(active.size()) != cell_count() ||
      static_cast<std::int64_t>(material.size()) != cell_count()) {
    std::ostringstream s;
    s << "hex mesh: active/material arrays hold " << active.size() << "/" << material.size()
      << " entries, expected one per cell (" << cell_count() << ")";
    throw Error(s.str());
  }
}

HexMesh make_box_hex_mesh(const Int3& cells, const Vec3d& spacing_mm, const Vec3d& origin_mm) {
  HexMesh m;
  m.cells = cells;
  m.spacing = spacing_mm;
  m.origin = origin_mm;
  if (cells.x < 1 || cells.y < 1 || cells.z < 1)
    throw Error("hex mesh: cells must be >= 1 along every axis");
  m.active.assign(static_cast<std::size_t>(m.cell_count()), 1);
  m.material.assign(static_cast<std::size_t>(m.cell_count()), 0);
  m.validate();
  return m;
}

LatticeHexMesh hex_mesh_from_lattice(const crms::Lattice& lattice) {
  const crms::LatticeGeometry& g = lattice.geometry();
  LatticeHexMesh out;
  HexMesh& m = out.mesh;
  m.cells = g.dims;
  m.spacing = g.spacing;
  m.origin = g.origin - g.spacing * 0.5;
  m.active.assign(static_cast<std::size_t>(g.node_count()), 0);
  m.material.assign(static_cast<std::size_t>(g.node_count()), 0);
  // Lattice node index n = i + nx(j + ny k) is the cell index of the same (i,j,k).
  for (std::int64_t n = 0; n < g.node_count(); ++n) {
    if (!lattice.alive(n)) continue;
    m.active[static_cast<std::size_t>(n)] = 1;
    m.material[static_cast<std::size_t>(n)] =
        static_cast<std::uint8_t>(lattice.dominant_material(n));
    if (lattice.fixed(n)) out.anchored_cells.push_back(n);
  }
  m.validate();
  return out;
}

HexMesh hex_mesh_from_volume(const VoxelVolume& volume, float density_threshold) {
  if (!(density_threshold > 0.0f && density_threshold <= 1.0f))
    throw Error("hex mesh from volume: density threshold must be in (0, 1]");
  const VolumeGeometry& g = volume.geometry();
  HexMesh m;
  m.cells = g.dims;
  m.spacing = g.spacing;
  m.origin = g.origin - g.spacing * 0.5;
  m.active.assign(volume.voxel_count(), 0);
  m.material.assign(volume.voxel_count(), 0);
  for (int k = 0; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i)
        if (volume.density(i, j, k) >= density_threshold) m.active[volume.index(i, j, k)] = 1;
  m.validate();
  return m;
}

}  // namespace tsf::reference

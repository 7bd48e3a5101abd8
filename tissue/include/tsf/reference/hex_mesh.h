// A regular grid of hexahedral cells for the FEM reference (fem_hex.h): one element per active
// cell, nodes at the cell corners.
//
// Cell (i,j,k) spans origin + [i, i+1]·hx × [j, j+1]·hy × [k, k+1]·hz (mm); its linear index is
// i + cx·(j + cy·k). Node (i,j,k) sits at origin + (i·hx, j·hy, k·hz) with linear index
// i + (cx+1)·(j + (cy+1)·k). Corner c of a cell is node (i + (c&1), j + ((c>>1)&1),
// k + ((c>>2)&1)), the order of hex_element.h.
//
// The same grid as the CRMS lattice: a lattice node owns the dual cell of size h centred on it
// (lattice_geometry.h), so `hex_mesh_from_lattice` makes lattice node (a,b,c) into cell (a,b,c)
// with the mesh origin half a spacing below the lattice origin. The FEM body is then exactly the
// voxel body the lattice stands for.
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/lattice.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::reference {

struct HexMesh {
  Int3 cells;                          ///< cells along x, y, z
  Vec3d origin{0.0, 0.0, 0.0};         ///< mm, position of node (0,0,0)
  Vec3d spacing{1.0, 1.0, 1.0};        ///< mm, cell size
  std::vector<std::uint8_t> active;    ///< #cells, 1 where an element exists
  std::vector<std::uint8_t> material;  ///< #cells, index into the model's materials

  Int3 node_dims() const { return {cells.x + 1, cells.y + 1, cells.z + 1}; }
  std::int64_t cell_count() const { return cells.volume(); }
  std::int64_t node_count() const { return node_dims().volume(); }
  std::int64_t cell_index(int i, int j, int k) const {
    return i + static_cast<std::int64_t>(cells.x) * (j + static_cast<std::int64_t>(cells.y) * k);
  }
  std::int64_t node_index(int i, int j, int k) const {
    const Int3 n = node_dims();
    return i + static_cast<std::int64_t>(n.x) * (j + static_cast<std::int64_t>(n.y) * k);
  }
  Int3 cell_coordinates(std::int64_t c) const {
    return {static_cast<int>(c % cells.x), static_cast<int>((c / cells.x) % cells.y),
            static_cast<int>(c / (static_cast<std::int64_t>(cells.x) * cells.y))};
  }
  Int3 node_coordinates(std::int64_t n) const {
    const Int3 d = node_dims();
    return {static_cast<int>(n % d.x), static_cast<int>((n / d.x) % d.y),
            static_cast<int>(n / (static_cast<std::int64_t>(d.x) * d.y))};
  }
  /// Node index of corner `corner` (0..7) of cell (i,j,k).
  std::int64_t corner_node(const Int3& cell, int corner) const {
    return node_index(cell.x + (corner & 1), cell.y + ((corner >> 1) & 1),
                      cell.z + ((corner >> 2) & 1));
  }
  Vec3d node_position(std::int64_t n) const {
    const Int3 c = node_coordinates(n);
    return {origin.x + c.x * spacing.x, origin.y + c.y * spacing.y, origin.z + c.z * spacing.z};
  }
  Vec3d cell_centre(std::int64_t c) const {
    const Int3 ijk = cell_coordinates(c);
    return {origin.x + (ijk.x + 0.5) * spacing.x, origin.y + (ijk.y + 0.5) * spacing.y,
            origin.z + (ijk.z + 0.5) * spacing.z};
  }
  bool cell_active(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < cells.x && j < cells.y && k < cells.z &&
           active[static_cast<std::size_t>(cell_index(i, j, k))] != 0;
  }
  std::int64_t active_count() const;
  /// Checks dimensions, array sizes and spacings; throws tsf::Error naming the field.
  void validate() const;
};

/// A solid box of `cells` elements of size `spacing` from `origin` (all active, material 0).
HexMesh make_box_hex_mesh(const Int3& cells, const Vec3d& spacing_mm, const Vec3d& origin_mm);

/// The FEM twin of a CRMS lattice: cell (a,b,c) is active where lattice node (a,b,c) is alive,
/// with its material index; `anchored_cells` lists the cells of fixed (anchored) lattice nodes,
/// whose 8 corner nodes FemHexModel::fix_cell_nodes() holds (an anchored cell is rigid).
struct LatticeHexMesh {
  HexMesh mesh;
  std::vector<std::int64_t> anchored_cells;
};
LatticeHexMesh hex_mesh_from_lattice(const crms::Lattice& lattice);

/// One element per voxel whose density is ≥ threshold (voxel-based FEM; voxel centres are cell
/// centres, so the mesh origin is half a voxel below the volume origin). Material 0.
HexMesh hex_mesh_from_volume(const VoxelVolume& volume, float density_threshold = 0.5f);

}  // namespace tsf::reference

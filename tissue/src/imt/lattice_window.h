// A window of the BCC lattice around a block of owner cubes: raw values (volume samples and body
// centres, zero outside the volume), vertex-merging decisions, effective values and labels. The
// full surfacing and the incremental update both mesh blocks through this one class, so they make
// the same decisions bit for bit.
//
// Layout: corners and centres are two arrays with the same strides; the centre of cube c is stored
// at the index of its corner c. Local index of corner s: (s − lo) · (1, sy, sz).
//
// Private to tissue/src/imt.
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/imt/bcc_lattice.h"
#include "tsf/imt/surface_options.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::imt::detail {

enum PointFlags : std::uint8_t {
  kInside = 1,         ///< effective value >= iso
  kRawInside = 2,      ///< raw value >= iso
  kSnapped = 4,        ///< moved onto the iso-level (merges the vertices around it)
  kHasOutsideNbr = 8,  ///< some neighbour is outside (set where merging was considered)
  kHasInsideNbr = 16,  ///< some neighbour is inside (set where merging was considered)
};

constexpr int kCornerKind = 0;
constexpr int kCentreKind = 1;

/// A lattice point as (kind, index into that kind's arrays).
struct WindowPoint {
  int kind;
  std::int64_t index;
};

class LatticeWindow {
 public:
  /// Cubes around the block whose corners the window holds: one without merging (a tetrahedron
  /// reaches one cube below), three with it (decisions look two lattice steps further).
  static int margin(bool merging) { return merging ? 3 : 1; }

  /// Loads and decides everything needed to mesh owner cubes [c0, c1) of `volume` (cube
  /// coordinates, c ∈ [−1, n]), and lists the cubes that can hold surface. The volume must
  /// outlive the queries (labels are read from it).
  void compute(const VoxelVolume& volume, const SurfaceOptions& options, const Int3& c0,
               const Int3& c1);

  /// A merged point of a computed window, to replay the decision on a second pass over the same
  /// block without re-deciding (compute_replaying).
  struct MergedPoint {
    std::int64_t index;
    std::uint8_t kind, flags;
  };
  void merged_points(std::vector<MergedPoint>& out) const;
  /// compute() for the same block as an earlier compute() whose merged points are given.
  void compute_replaying(const VoxelVolume& volume, const SurfaceOptions& options, const Int3& c0,
                         const Int3& c1, const std::vector<MergedPoint>& merged);

  struct Cube {
    std::int64_t local;  ///< window-local index
    Int3 c;              ///< cube coordinates
  };
  /// Owner cubes of the block that can own triangles or vertices, x fastest; all others are
  /// skipped.
  const std::vector<Cube>& relevant_cubes() const { return relevant_; }
  std::int64_t local_index(const Int3& c) const {
    return (c.x - lo_.x) + sy_ * (c.y - lo_.y) + sz_ * (c.z - lo_.z);
  }

  /// Bit `slot` set when the vertex in that slot of the cube at `local` is used by a triangle
  /// (edge: crosses and its inside end is not merged; point: merged with inside and outside
  /// neighbours).
  std::uint16_t referenced_slots(std::int64_t local) const;

  /// Position (index space, voxels) and label of the vertex in `slot` of cube c at `local`.
  void vertex(const Int3& c, std::int64_t local, int slot, Vec3d& index_position,
              std::uint8_t& label) const;

  /// Every triangle of the cube at `local` that does not collapse: emit(keys), keys[3] being
  /// LatticeRefs relative to the cube.
  template <typename Emit>
  void mesh_cube(std::int64_t local, Emit&& emit) const;
  /// What mesh_cube's output depends on: the inside and merged bits of the cube's 12 points
  /// (24 bits). Two cubes with the same signature emit the same triangles (as lattice keys).
  std::uint32_t signature(std::int64_t local) const {
    const CubeSides cs = sides(local);
    return cs.inside | (cs.merged << kCubePoints);
  }
  /// Number of triangles mesh_cube would emit.
  int count_triangles(std::int64_t local) const;

  /// The 12 points a cube's slots and tetrahedra use: corners c + d (index d = dx + 2dy + 4dz),
  /// then the centres of c, c − e_x, c − e_y, c − e_z (indices 8..11).
  static constexpr int kCubePoints = 12;
  /// Triangles of one face's 4 tetrahedra for a 6-bit inside mask of the face's points (its 4
  /// corners, then the two centres), without merged points.
  struct FaceCase {
    std::uint8_t count;
    LatticeRef keys[8][3];
  };
  struct CubeTables {
    std::uint8_t face_point[3][6];  // cube point index of each face point
    std::uint16_t face_points[3];   // the same as a 12-bit mask
    FaceCase face_case[3][64];
    std::uint16_t crossing[1 << kCubePoints];      // inside mask -> edge slots whose ends differ
    std::uint8_t slot_point[kSlotCornerPoint][2];  // cube points at each edge slot's ends
    std::uint8_t tet_point[kTetsPerCube][4];       // cube points of each tetrahedron
  };
  static const CubeTables& tables();

 private:
  struct PointOffset {
    int kind;
    std::int64_t delta;  // from the cube's local index
  };
  void set_layout(const Int3& c0, const Int3& c1, bool merging);
  bool load_and_classify(const Int3& c0, const Int3& c1);
  void decide_merges(float eps);
  void find_relevant(const Int3& c0, const Int3& c1);
  /// The point's smallest crossing fraction if below eps and merging keeps a disc, else +inf.
  float candidate_fraction(int kind, std::int64_t index, float eps, std::uint8_t& nbr_flags) const;
  std::int64_t global_point_id(int kind, std::int64_t index) const;
  std::uint8_t corner_label(std::int64_t index) const;
  std::uint8_t label_at(const Int3& sample) const;
  std::uint8_t point_label_at(int px, int py, int pz) const;  // doubled coordinates
  std::uint8_t point_label(int kind, std::int64_t index) const;
  std::uint8_t vertex_label_at_point(int kind, std::int64_t index) const;

  const VoxelVolume* volume_ = nullptr;
  Int3 lo_;    // corner sample index at local (0,0,0)
  Int3 dims_;  // corners per axis; cube (and centre) m exists for local m ∈ [0, dims − 1)
  std::int64_t sy_ = 0, sz_ = 0;
  float iso_ = 0.5f;
  // Raw values of every corner and every centre. Merging changes flags only (a merged point is
  // on the iso-level): no edge that makes a vertex has a merged end, so interpolation reads raw.
  std::vector<float> raw_[2];
  std::vector<std::uint8_t> flags_[2];
  std::vector<std::uint8_t> cube_mixed_;  // raw corners straddle; later effective, near the block
  std::vector<std::uint8_t> near_mixed_;  // per cube: it or a face neighbour straddles
  std::vector<std::uint8_t> pass_[2];     // merge pre-filter per point
  std::vector<std::int64_t> candidates_[2];
  std::vector<float> candidate_t_[2];
  std::vector<Cube> relevant_;
  Int3 layout_dims_{-1, -1, -1};
  PointOffset nbr_[2][14] = {};
  PointOffset tet_[kTetsPerCube][4] = {};
  PointOffset slot_[kSlotsPerCube][2] = {};
  PointOffset cube_point_[kCubePoints] = {};
  const CubeTables* tables_ = &tables();

  /// Inside and merged bits of the cube's 12 points.
  struct CubeSides {
    unsigned inside, merged;
  };
  CubeSides sides(std::int64_t local) const {
    unsigned in = 0, merged = 0;
    for (int p = 0; p < kCubePoints; ++p) {
      const std::uint8_t f =
          flags_[cube_point_[p].kind][static_cast<std::size_t>(local + cube_point_[p].delta)];
      in |= static_cast<unsigned>(f & kInside) << p;
      merged |= static_cast<unsigned>((f >> 2) & 1u) << p;  // kSnapped
    }
    return {in, merged};
  }
  static unsigned face_mask(const CubeTables& t, unsigned inside, int face) {
    unsigned m = 0;
    for (int k = 0; k < 6; ++k) m |= ((inside >> t.face_point[face][k]) & 1u) << k;
    return m;
  }
  Vec3d slot_p0_[kSlotsPerCube], slot_p1_[kSlotsPerCube];  // doubled, relative to 2c
};

template <typename Emit>
inline void LatticeWindow::mesh_cube(std::int64_t local, Emit&& emit) const {
  const CubeTables& tb = *tables_;
  const CubeSides cs = sides(local);
  for (int face = 0; face < 3; ++face) {
    const unsigned fm = face_mask(tb, cs.inside, face);
    if (fm == 0 || fm == 63) continue;
    if ((cs.merged & tb.face_points[face]) == 0) {  // common case: straight from the table
      const FaceCase& fc = tb.face_case[face][fm];
      for (int t = 0; t < fc.count; ++t) emit(fc.keys[t]);
      continue;
    }
    // A merged point on the face: edges whose inside end merged become that point, and
    // triangles that collapse are dropped.
    for (int t = 4 * face; t < 4 * face + 4; ++t) {
      int mask = 0, merged = 0;
      for (int v = 0; v < 4; ++v) {
        mask |= static_cast<int>((cs.inside >> tb.tet_point[t][v]) & 1u) << v;
        merged |= static_cast<int>((cs.merged >> tb.tet_point[t][v]) & 1u) << v;
      }
      if (mask == 0 || mask == 15) continue;
      const TetTemplate& tt = kCubeTets.tet[t];
      const TetCase& tc = kTetCases.c[mask];
      for (int tri = 0; tri < tc.triangle_count; ++tri) {
        LatticeRef keys[3];
        for (int k = 0; k < 3; ++k) {
          const int e = tc.triangle[tri][k];
          const int a = kTetEdgeA[e], b = kTetEdgeB[e];
          const int in = ((mask >> a) & 1) ? a : b;
          keys[k] = ((merged >> in) & 1) ? tt.point_ref[in] : tt.edge_ref[e];
        }
        auto same = [](const LatticeRef& x, const LatticeRef& y) {
          return x.slot == y.slot && x.offset[0] == y.offset[0] && x.offset[1] == y.offset[1] &&
                 x.offset[2] == y.offset[2];
        };
        if (same(keys[0], keys[1]) || same(keys[1], keys[2]) || same(keys[0], keys[2])) continue;
        emit(keys);
      }
    }
  }
}

}  // namespace tsf::imt::detail

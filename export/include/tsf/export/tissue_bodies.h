// Closed per-tissue bodies from a label volume (`tsf export --bodies`): every tissue its own
// closed, manifold mesh, and where two tissues meet both bodies share one interface (the same
// vertices, the triangles reversed), as 3D printing and Slicer's segment models expect.
//
// Method: multi-material marching tetrahedra on the voxel centres, each cube of 8 samples split
// into the 6 tetrahedra of the Kuhn (Freudenthal) triangulation around its main diagonal, which
// fits between neighbouring cubes. Every sample has a region: its label where density ≥ iso,
// else air (samples outside the volume are air, so bodies touching the border are closed).
//   * an edge between two regions gets a vertex: at the density iso-crossing when one side is
//     air (linear interpolation, kept 2 % of the edge away from its ends so vertices never
//     coincide), at its midpoint between two tissues (labels carry no sub-voxel position);
//   * a tetrahedron with two regions gets the usual marching-tetrahedra triangle or quad;
//   * a tetrahedron with three or four regions gets a centre vertex (the mean of its edge
//     vertices), each of its faces with three regions a face vertex (the mean of that face's
//     three edge vertices), and the walls of the barycentric subdivision: per face with three
//     regions, a triangle (edge vertex, face vertex, centre) for each of its edges, separating the
//     regions of that edge's ends; per face with two regions, the triangle (its two edge vertices,
//     centre). Faces with two regions need no face vertex, so a tetrahedron with two regions
//     meets its neighbours edge to edge.
// The result is a partition of space into regions whose boundaries are unions of these
// triangles: each region's boundary is closed, and, because every vertex's neighbourhood in the
// subdivision is split into regions that are each connected (an edge vertex sees two regions, a
// face vertex two or three sectors on each side, a centre four cells), a 2-manifold. Each
// triangle is stored once with the region behind it and the region it faces (its normal points
// from `behind` to `front`); a body takes the triangles it is behind as they are and the ones it
// faces reversed.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/export/mesh_decimation.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::exporter {

/// Region number of air (density below the iso-level, or outside the volume); tissues are their
/// label (0–255).
constexpr std::uint16_t kAirRegion = 256;

struct InterfaceComplex {
  std::vector<Vec3f> positions;                         ///< tissue space, mm
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< each interface triangle once
  /// Per triangle: the regions it separates, behind < front (air, 256, is always in front).
  std::vector<std::uint16_t> behind, front;

  /// Tissue labels with a body, ascending (air excluded).
  std::vector<std::uint8_t> tissues() const;
};

/// The interfaces of every region of `volume` (density and labels) at `iso`.
InterfaceComplex tissue_interfaces(const VoxelVolume& volume, float iso);

/// The part number of each triangle for decimate_parts: one part per interface (pair of
/// regions), behind × 257 + front.
std::vector<std::uint32_t> interface_parts(const InterfaceComplex& complex);

/// The complex a decimation of `complex` made (decimate_parts with interface_parts and
/// one_surface false; triple lines never move, so neighbours keep sharing their interfaces):
/// triangles through d.origin into complex.positions. Where decimation squeezed a tissue to
/// nothing (an A|B and a B|C triangle on the same three vertices, facing the same way) the pair
/// becomes one A|C triangle (nothing when C is A), so B keeps no zero-volume fin; `squeezed`
/// (optional) receives how many pairs.
InterfaceComplex decimated_complex(const InterfaceComplex& complex, const DecimatedMesh& d,
                                   std::size_t* squeezed = nullptr);

/// Decimates the complex (decimate_parts, one part per interface) and returns the decimated
/// complex; where a body came out with an edge of more than two triangles, a pinched vertex or a
/// zero-area triangle, the decimation runs again with those vertices and two rings of neighbours
/// locked (at most eight runs). `d` (optional) receives the last decimation's report.
InterfaceComplex decimate_interfaces(const InterfaceComplex& complex,
                                     const DecimationOptions& options, DecimatedMesh* d = nullptr);

/// Vertices (of the complex's numbering) on edges of more than two triangles of some body, or
/// where a body's triangles form more than one fan (pinched).
std::vector<std::uint32_t> body_nonmanifold_vertices(const InterfaceComplex& complex);

/// The closed body of `tissue`: its triangles (those it faces reversed), its vertices shared and
/// compact; labels = `tissue`; no normals.
imt::SurfaceMesh body_mesh(const InterfaceComplex& complex, std::uint8_t tissue);

}  // namespace tsf::exporter

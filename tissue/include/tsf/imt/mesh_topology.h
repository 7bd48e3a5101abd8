// Topology of a triangle mesh: is it a closed, consistently oriented 2-manifold, and of what genus?
// Used by tests here and downstream (cutting must never leave dangling or non-manifold geometry).
#pragma once

#include <cstddef>
#include <vector>

#include "tsf/imt/surface_mesh.h"

namespace tsf::imt {

struct MeshTopology {
  std::size_t vertices = 0;  ///< referenced vertices
  std::size_t triangles = 0;
  std::size_t edges = 0;                  ///< distinct undirected edges
  std::size_t boundary_edges = 0;         ///< in exactly one triangle
  std::size_t nonmanifold_edges = 0;      ///< in more than two triangles
  std::size_t misoriented_edges = 0;      ///< in two triangles that run it the same way
  std::size_t degenerate_triangles = 0;   ///< repeat a vertex index
  std::size_t unreferenced_vertices = 0;  ///< in no triangle
  std::size_t nonmanifold_vertices = 0;   ///< their triangles form more than one fan
  std::size_t components = 0;             ///< connected through edges
  std::vector<long> component_euler;      ///< V − E + F per component, largest component first
  std::vector<std::size_t> component_triangles;  ///< triangles per component, same order

  /// Every edge in exactly two oppositely oriented triangles, every vertex a single fan, nothing
  /// degenerate or unused.
  bool closed_oriented_manifold() const {
    return boundary_edges == 0 && nonmanifold_edges == 0 && misoriented_edges == 0 &&
           degenerate_triangles == 0 && unreferenced_vertices == 0 && nonmanifold_vertices == 0;
  }
};

MeshTopology analyse_topology(const SurfaceMesh& mesh);

}  // namespace tsf::imt

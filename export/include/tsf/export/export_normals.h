// Unit normals on every exported vertex.
//
// glTF requires NORMAL to be unit length (the validator rejects zero vectors), and every other
// format's readers shade with them. IMT gives a vertex whose triangles have no area a zero
// normal (surface_mesh.h); such vertices get the area-weighted mean of their neighbours' normals
// (the vertices they share a triangle with), else the mean of their triangles' unnormalised
// normals, else +Z. A mesh without normals gets area-weighted vertex normals first.
#pragma once

#include <cstddef>

#include "tsf/imt/surface_mesh.h"

namespace tsf::exporter {

/// Makes every normal of `mesh` a finite unit vector; returns how many vertices needed a
/// replacement (not counting a mesh that had no normals at all).
std::size_t complete_normals(imt::SurfaceMesh& mesh);

}  // namespace tsf::exporter

// Unit normals on every exported vertex.
//
// glTF requires NORMAL to be unit length (the validator rejects zero vectors), and every other
// format's readers shade with them. Exported normals are area-weighted: the sum of the
// (unnormalised) face normals around a vertex, normalised; copies of one vertex (a tissue border
// split for decimation, mesh_decimation.h) sum over all their triangles, so the border shades
// smoothly. A vertex without area around it takes the mean of its neighbours' normals, else +Z.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::exporter {

/// Area-weighted unit vertex normals of `triangles`, summed over vertices that share a `group`
/// value (empty: every vertex its own group). `without_area` (optional) receives how many
/// vertices had no area around them and took their neighbours' normals instead.
std::vector<Vec3f> area_weighted_normals(const std::vector<Vec3f>& positions,
                                         const std::vector<std::array<std::uint32_t, 3>>& triangles,
                                         const std::vector<std::uint32_t>& group = {},
                                         std::size_t* without_area = nullptr);

}  // namespace tsf::exporter

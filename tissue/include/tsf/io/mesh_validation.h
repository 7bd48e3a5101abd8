// imt::validate_mesh for large meshes on the save/export path: the same checks and the same
// messages (it defers to imt::validate_mesh once something is wrong), but no message is built
// while everything is fine, so a million-vertex mesh takes milliseconds instead of a second.
#pragma once

#include "tsf/imt/surface_mesh.h"

namespace tsf::io {

/// Throws tsf::Error naming the first bad element (see imt::validate_mesh).
void validate_mesh_quickly(const imt::SurfaceMesh& mesh);

}  // namespace tsf::io

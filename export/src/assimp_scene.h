// Surface meshes (already in the file's frame) -> an assimp scene: a root node with one child node
// and mesh per part (one part for the whole surface, or one per tissue), one material per part,
// per-vertex normals and colours, and morph targets (aiAnimMesh) for animated sequences.
#pragma once

#include <assimp/scene.h>

#include <memory>
#include <string>
#include <vector>

#include "tsf/export/label_partition.h"
#include "tsf/imt/surface_mesh.h"

namespace tsf::exporter {

struct SceneInput {
  const imt::SurfaceMesh* base = nullptr;  ///< file frame, unit normals
  std::vector<LabelPart> parts;            ///< partition of base's triangles
  bool split_labels = false;               ///< parts are tissues (else one part, "surface")
  /// Morph targets: whole meshes with base's topology (file frame), with their names.
  std::vector<const imt::SurfaceMesh*> targets;
  std::vector<std::string> target_names;
  bool linear_colours = false;  ///< glTF: colours are linear; other formats get sRGB values
  std::string root_name = "tissue";
};

/// The material (and node, and mesh) name of part `part`.
std::string part_name(const SceneInput& input, std::size_t part);

/// Builds the scene; the caller owns it (aiScene's destructor frees its meshes and materials).
std::unique_ptr<aiScene> build_assimp_scene(const SceneInput& input);

}  // namespace tsf::exporter

// Surface meshes (already in the file's frame) -> an assimp scene.
//
//   root ── group ── one mesh per tissue             (the default: one node, a mesh per tissue
//        │                                            that glTF merges into primitives)
//        └─ group ── tissue node ── mesh              (split: a node per tissue)
// A group is the whole surface, one level of detail, one tissue body or one run of states of a
// sequence that share a topology (its later states morph targets, aiAnimMesh). With one group
// and split tissues the tissue nodes hang from the root directly. One material per tissue label
// (shared by every group); per-vertex colours only when asked for.
#pragma once

#include <assimp/scene.h>

#include <memory>
#include <string>
#include <vector>

#include "tsf/export/label_partition.h"
#include "tsf/imt/surface_mesh.h"

namespace tsf::exporter {

struct SceneGroup {
  std::string name;                        ///< node name
  std::string mesh_suffix;                 ///< appended to its mesh (and tissue node) names
  const imt::SurfaceMesh* base = nullptr;  ///< file frame, unit normals
  std::vector<LabelPart> parts;            ///< partition of base's triangles by tissue
  /// Morph targets: whole meshes with base's topology (file frame), with their names.
  std::vector<const imt::SurfaceMesh*> targets;
  std::vector<std::string> target_names;
};

struct SceneInput {
  std::vector<SceneGroup> groups;
  bool split_labels = false;    ///< a node per tissue (else the group node holds the meshes)
  bool vertex_colours = false;  ///< per-vertex tissue colours
  bool linear_colours = false;  ///< glTF: colours are linear; other formats get sRGB values
  std::string root_name = "tissue";
};

/// The scene's materials in order: the tissue label of each.
std::vector<std::uint8_t> scene_material_labels(const SceneInput& input);

/// Builds the scene; the caller owns it (aiScene's destructor frees its meshes and materials).
std::unique_ptr<aiScene> build_assimp_scene(const SceneInput& input);

}  // namespace tsf::exporter

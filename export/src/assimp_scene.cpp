#include "assimp_scene.h"

#include <assimp/material.h>
#include <assimp/mesh.h>

#include <algorithm>

#include "tsf/common/error.h"
#include "tsf/export/tissue_palette.h"

namespace tsf::exporter {

namespace {

aiColor4D vertex_colour(std::uint8_t label, bool linear) {
  if (linear) {
    const auto c = tissue_colour_linear(label);
    return {c[0], c[1], c[2], 1.0f};
  }
  const auto c = tissue_colour_srgb(label);
  return {c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f, 1.0f};
}

aiMaterial* make_material(std::uint8_t label) {
  auto* m = new aiMaterial();
  const aiString ai_name(tissue_material_name(label));
  m->AddProperty(&ai_name, AI_MATKEY_NAME);
  // The diffuse colour is what OBJ (.mtl Kd) and FBX (DiffuseColor) carry; glTF materials are
  // completed after export (glTF finishing: baseColorFactor, roughness, metallic).
  const auto c = tissue_colour_srgb(label);
  const aiColor3D diffuse(c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f);
  m->AddProperty(&diffuse, 1, AI_MATKEY_COLOR_DIFFUSE);
  const int shading = aiShadingMode_Phong;
  m->AddProperty(&shading, 1, AI_MATKEY_SHADING_MODEL);
  return m;
}

aiMesh* make_mesh(const SceneInput& input, const SceneGroup& group, const LabelPart& part,
                  unsigned material) {
  const imt::SurfaceMesh& base = *group.base;
  auto* mesh = new aiMesh();
  mesh->mName = tissue_material_name(part.label) + group.mesh_suffix;
  mesh->mMaterialIndex = material;
  mesh->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  const auto nv = static_cast<unsigned>(part.vertices.size());
  mesh->mNumVertices = nv;
  mesh->mVertices = new aiVector3D[nv];
  mesh->mNormals = new aiVector3D[nv];
  if (input.vertex_colours) mesh->mColors[0] = new aiColor4D[nv];
  for (unsigned i = 0; i < nv; ++i) {
    const std::uint32_t v = part.vertices[i];
    const Vec3f& x = base.positions[v];
    const Vec3f& n = base.normals[v];
    mesh->mVertices[i] = aiVector3D(x.x, x.y, x.z);
    mesh->mNormals[i] = aiVector3D(n.x, n.y, n.z);
    if (input.vertex_colours)
      mesh->mColors[0][i] = vertex_colour(base.labels[v], input.linear_colours);
  }
  const auto nf = static_cast<unsigned>(part.triangles.size());
  mesh->mNumFaces = nf;
  mesh->mFaces = new aiFace[nf];
  for (unsigned f = 0; f < nf; ++f) {
    aiFace& face = mesh->mFaces[f];
    face.mNumIndices = 3;
    face.mIndices =
        new unsigned[3]{part.triangles[f][0], part.triangles[f][1], part.triangles[f][2]};
  }
  if (!group.targets.empty()) {
    const auto nt = static_cast<unsigned>(group.targets.size());
    mesh->mNumAnimMeshes = nt;
    mesh->mAnimMeshes = new aiAnimMesh*[nt];
    for (unsigned t = 0; t < nt; ++t) {
      const imt::SurfaceMesh& target = *group.targets[t];
      auto* anim = new aiAnimMesh();
      anim->mName = group.target_names[t];
      anim->mNumVertices = nv;
      anim->mVertices = new aiVector3D[nv];
      anim->mNormals = new aiVector3D[nv];
      anim->mWeight = 0.0f;
      for (unsigned i = 0; i < nv; ++i) {
        const Vec3f& x = target.positions[part.vertices[i]];
        const Vec3f& n = target.normals[part.vertices[i]];
        anim->mVertices[i] = aiVector3D(x.x, x.y, x.z);
        anim->mNormals[i] = aiVector3D(n.x, n.y, n.z);
      }
      mesh->mAnimMeshes[t] = anim;
    }
  }
  return mesh;
}

aiNode* make_node(const std::string& name, aiNode* parent) {
  auto* node = new aiNode(name);
  node->mParent = parent;
  return node;
}

void set_children(aiNode* node, const std::vector<aiNode*>& children) {
  node->mNumChildren = static_cast<unsigned>(children.size());
  node->mChildren = new aiNode*[children.size()];
  std::copy(children.begin(), children.end(), node->mChildren);
}

void set_meshes(aiNode* node, const std::vector<unsigned>& meshes) {
  node->mNumMeshes = static_cast<unsigned>(meshes.size());
  node->mMeshes = new unsigned[meshes.size()];
  std::copy(meshes.begin(), meshes.end(), node->mMeshes);
}

}  // namespace

std::vector<std::uint8_t> scene_material_labels(const SceneInput& input) {
  std::vector<std::uint8_t> labels;
  for (const SceneGroup& g : input.groups)
    for (const LabelPart& p : g.parts) labels.push_back(p.label);
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  return labels;
}

std::unique_ptr<aiScene> build_assimp_scene(const SceneInput& input) {
  require(!input.groups.empty(), "assimp scene: nothing to build");
  std::size_t mesh_count = 0;
  for (const SceneGroup& g : input.groups) {
    require(g.base && !g.parts.empty(), "assimp scene: a group without triangles");
    require(g.targets.size() == g.target_names.size(),
            "assimp scene: a name for every morph target");
    for (const imt::SurfaceMesh* t : g.targets)
      require(t && t->positions.size() == g.base->positions.size() &&
                  t->normals.size() == g.base->normals.size(),
              "assimp scene: a morph target differs from the base mesh in vertex count");
    mesh_count += g.parts.size();
  }
  const std::vector<std::uint8_t> labels = scene_material_labels(input);

  auto scene = std::make_unique<aiScene>();
  scene->mRootNode = new aiNode(input.root_name);
  scene->mNumMaterials = static_cast<unsigned>(labels.size());
  scene->mMaterials = new aiMaterial*[labels.size()];
  for (std::size_t m = 0; m < labels.size(); ++m) scene->mMaterials[m] = make_material(labels[m]);
  scene->mNumMeshes = static_cast<unsigned>(mesh_count);
  scene->mMeshes = new aiMesh*[mesh_count];
  std::fill(scene->mMeshes, scene->mMeshes + mesh_count, nullptr);

  unsigned next_mesh = 0;
  std::vector<aiNode*> root_children;
  const bool flat = input.split_labels && input.groups.size() == 1;
  for (const SceneGroup& g : input.groups) {
    aiNode* group_node = flat ? scene->mRootNode : make_node(g.name, scene->mRootNode);
    std::vector<aiNode*> tissue_nodes;
    std::vector<unsigned> group_meshes;
    for (const LabelPart& part : g.parts) {
      const auto material = static_cast<unsigned>(
          std::lower_bound(labels.begin(), labels.end(), part.label) - labels.begin());
      scene->mMeshes[next_mesh] = make_mesh(input, g, part, material);
      if (input.split_labels) {
        aiNode* node = make_node(tissue_material_name(part.label) + g.mesh_suffix, group_node);
        set_meshes(node, {next_mesh});
        tissue_nodes.push_back(node);
      } else {
        group_meshes.push_back(next_mesh);
      }
      ++next_mesh;
    }
    if (flat) {
      root_children = tissue_nodes;
    } else {
      if (input.split_labels)
        set_children(group_node, tissue_nodes);
      else
        set_meshes(group_node, group_meshes);
      root_children.push_back(group_node);
    }
  }
  set_children(scene->mRootNode, root_children);
  return scene;
}

}  // namespace tsf::exporter

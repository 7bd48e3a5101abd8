#include "assimp_scene.h"

#include <assimp/material.h>
#include <assimp/mesh.h>

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

aiMaterial* make_material(const std::string& name, std::uint8_t label, bool tissue) {
  auto* m = new aiMaterial();
  const aiString ai_name(name);
  m->AddProperty(&ai_name, AI_MATKEY_NAME);
  // The diffuse colour is what OBJ (.mtl Kd) and FBX (DiffuseColor) carry; glTF materials are
  // rewritten after export (gltf finishing) because glTF multiplies COLOR_0 by the base colour.
  aiColor3D diffuse(0.8f, 0.8f, 0.8f);
  if (tissue) {
    const auto c = tissue_colour_srgb(label);
    diffuse = aiColor3D(c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f);
  }
  m->AddProperty(&diffuse, 1, AI_MATKEY_COLOR_DIFFUSE);
  const int shading = aiShadingMode_Phong;
  m->AddProperty(&shading, 1, AI_MATKEY_SHADING_MODEL);
  return m;
}

}  // namespace

std::string part_name(const SceneInput& input, std::size_t part) {
  return input.split_labels ? tissue_material_name(input.parts[part].label) : "surface";
}

std::unique_ptr<aiScene> build_assimp_scene(const SceneInput& input) {
  require(input.base && !input.parts.empty(), "assimp scene: nothing to build");
  require(input.targets.size() == input.target_names.size(),
          "assimp scene: a name for every morph target");
  const imt::SurfaceMesh& base = *input.base;
  for (const imt::SurfaceMesh* t : input.targets)
    require(t && t->positions.size() == base.positions.size() &&
                t->normals.size() == base.normals.size(),
            "assimp scene: a morph target differs from the base mesh in vertex count");

  auto scene = std::make_unique<aiScene>();
  const auto parts = static_cast<unsigned>(input.parts.size());
  scene->mRootNode = new aiNode(input.root_name);
  scene->mRootNode->mChildren = new aiNode*[parts];
  scene->mRootNode->mNumChildren = parts;
  scene->mMaterials = new aiMaterial*[parts];
  scene->mNumMaterials = parts;
  scene->mMeshes = new aiMesh*[parts];
  scene->mNumMeshes = parts;
  for (unsigned p = 0; p < parts; ++p) {
    scene->mMaterials[p] = nullptr;
    scene->mMeshes[p] = nullptr;
    scene->mRootNode->mChildren[p] = nullptr;
  }

  for (unsigned p = 0; p < parts; ++p) {
    const LabelPart& part = input.parts[p];
    const std::string name = part_name(input, p);
    scene->mMaterials[p] = make_material(name, part.label, input.split_labels);

    auto* mesh = new aiMesh();
    scene->mMeshes[p] = mesh;
    mesh->mName = name;
    mesh->mMaterialIndex = p;
    mesh->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
    const auto nv = static_cast<unsigned>(part.vertices.size());
    mesh->mNumVertices = nv;
    mesh->mVertices = new aiVector3D[nv];
    mesh->mNormals = new aiVector3D[nv];
    mesh->mColors[0] = new aiColor4D[nv];
    for (unsigned i = 0; i < nv; ++i) {
      const std::uint32_t v = part.vertices[i];
      const Vec3f& x = base.positions[v];
      const Vec3f& n = base.normals[v];
      mesh->mVertices[i] = aiVector3D(x.x, x.y, x.z);
      mesh->mNormals[i] = aiVector3D(n.x, n.y, n.z);
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

    if (!input.targets.empty()) {
      const auto nt = static_cast<unsigned>(input.targets.size());
      mesh->mNumAnimMeshes = nt;
      mesh->mAnimMeshes = new aiAnimMesh*[nt];
      for (unsigned t = 0; t < nt; ++t) {
        const imt::SurfaceMesh& target = *input.targets[t];
        auto* anim = new aiAnimMesh();
        anim->mName = input.target_names[t];
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

    auto* node = new aiNode(name);
    node->mParent = scene->mRootNode;
    node->mNumMeshes = 1;
    node->mMeshes = new unsigned[1]{p};
    scene->mRootNode->mChildren[p] = node;
  }
  return scene;
}

}  // namespace tsf::exporter

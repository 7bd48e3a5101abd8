// A glTF 2.0 asset held in memory as its JSON and its one binary buffer, so that what assimp's
// glTF writer does not do can be added: morph-target animation, tsf metadata, material colours,
// a self-contained .gltf (buffer embedded as a base64 data URI).
//
// GLB container (glTF 2.0 spec, "Binary glTF Layout"): 12-byte header (magic "glTF", version 2,
// total length), a JSON chunk (type 0x4E4F534A, padded with spaces to 4 bytes), an optional BIN
// chunk (type 0x004E4942, padded with zeros to 4 bytes). All little endian.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace tsf::exporter {

struct GltfDocument {
  nlohmann::json json;
  std::string bin;  ///< buffer 0's bytes (empty when the asset has no buffer)
};

/// Parses a GLB container. Throws tsf::Error naming the field when it is not one.
GltfDocument parse_glb(std::string_view bytes);
/// Writes a GLB container (buffer 0 = the BIN chunk; its byteLength is set).
std::string write_glb(const GltfDocument& document);

/// A .gltf JSON text and the bytes of its one external buffer.
GltfDocument parse_gltf(std::string_view json_text, std::string_view buffer);
/// Writes .gltf JSON with buffer 0 embedded as "data:application/octet-stream;base64,...".
std::string write_embedded_gltf(const GltfDocument& document);
/// Decodes buffer 0 of a self-contained .gltf (data URI) into `bin`.
GltfDocument parse_embedded_gltf(std::string_view json_text);

/// Appends `count` elements of `components` floats each (SCALAR 1, VEC3 3, ...) as a new buffer
/// view and accessor with min/max; returns the accessor index.
int append_float_accessor(GltfDocument& document, const std::vector<float>& values, int components);

/// Removes extensionsUsed / extensionsRequired entries that no object of the asset uses (assimp
/// 5.2 lists KHR_materials_volume and FB_ngon_encoding on every asset).
void drop_unused_extensions(GltfDocument& document);

/// Adds one animation named `name` that plays the morph targets of every mesh that has N of them
/// as N + 1 keyframes at `times_s`: keyframe 0 all weights 0 (the base mesh), keyframe k weight
/// k−1 = 1 and the others 0, linear in between. Every node whose mesh has morph targets gets a
/// "weights" channel. Throws tsf::Error unless times are strictly increasing and N + 1 of them.
void add_morph_animation(GltfDocument& document, const std::vector<float>& times_s,
                         const std::string& name);

std::string base64_encode(std::string_view bytes);
std::string base64_decode(std::string_view text);  ///< throws tsf::Error on a bad character

}  // namespace tsf::exporter

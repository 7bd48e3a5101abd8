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

/// One node of an animated sequence: a run of states that share one topology (its base mesh and
/// morph targets, one per later state) shown from `visible_from` until `visible_until`.
struct AnimatedGroup {
  std::string node;          ///< node name (unique in the asset)
  std::vector<float> times;  ///< keyframe time of each state of the run (base first), s
  float visible_from = 0.0f;
  float visible_until = -1.0f;  ///< < 0: to the end
};

/// Adds one animation named `name` that plays a sequence of state runs:
///  * morph weights: every node in a run's subtree whose mesh has N morph targets gets a weights
///    channel with the run's N + 1 keyframes (keyframe 0 all weights 0, keyframe k weight k−1 =
///    1), LINEAR, so playback blends from state to state;
///  * visibility, when there are several runs: the run's node gets a scale channel, STEP, 1 while
///    it is shown and 0 otherwise (and a static scale of 0 when it is not shown at time 0), so
///    exactly one run is visible at any time: a cut that changes the topology switches meshes.
/// Throws tsf::Error naming the node when it is missing, times do not increase strictly, or the
/// target counts disagree with the times.
void add_state_animation(GltfDocument& document, const std::vector<AnimatedGroup>& groups,
                         const std::string& name);

/// Levels of detail (MSFT_lod, node level): `levels[0]` is the node shown by default, every
/// further name a node of fewer triangles. The level-0 node gets the MSFT_lod extension listing
/// the others in order and extras.MSFT_screencoverage = `coverage` (one per level); the other
/// levels leave the default scene's hierarchy and each becomes the root of a scene of its own
/// ("LOD k"), so viewers without MSFT_lod show level 0 and can still pick any level. Throws
/// tsf::Error naming a missing node.
void add_lods(GltfDocument& document, const std::vector<std::string>& levels,
              const std::vector<float>& coverage);

/// Index of the node named `name`; throws tsf::Error when there is none.
std::size_t node_named(const GltfDocument& document, const std::string& name);

std::string base64_encode(std::string_view bytes);
std::string base64_decode(std::string_view text);  ///< throws tsf::Error on a bad character

}  // namespace tsf::exporter

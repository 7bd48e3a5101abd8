#include "tsf/export/gltf_document.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <set>

#include "tsf/common/error.h"

namespace tsf::exporter {

namespace {

constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A;
constexpr std::uint32_t kChunkBin = 0x004E4942;
constexpr int kFloat = 5126;  // GL_FLOAT
constexpr const char* kDataUriPrefix = "data:application/octet-stream;base64,";

std::uint32_t read_u32(std::string_view b, std::size_t at) {
  std::uint32_t v = 0;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

void put_u32(std::string& out, std::uint32_t v) {
  out.append(reinterpret_cast<const char*>(&v), 4);
}

const char* type_name(int components) {
  switch (components) {
    case 1:
      return "SCALAR";
    case 2:
      return "VEC2";
    case 3:
      return "VEC3";
    case 4:
      return "VEC4";
    default:
      throw Error("glTF accessor with " + std::to_string(components) + " components");
  }
}

void collect_extension_names(const nlohmann::json& j, std::set<std::string>& names) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (it.key() == "extensions" && it->is_object())
        for (auto e = it->begin(); e != it->end(); ++e) names.insert(e.key());
      if (it.key() != "extensionsUsed" && it.key() != "extensionsRequired")
        collect_extension_names(*it, names);
    }
  } else if (j.is_array()) {
    for (const auto& e : j) collect_extension_names(e, names);
  }
}

nlohmann::json parse_json(std::string_view text, const char* what) {
  try {
    return nlohmann::json::parse(text.begin(), text.end());
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string(what) + ": invalid JSON: " + e.what());
  }
}

}  // namespace

GltfDocument parse_glb(std::string_view b) {
  require(b.size() >= 20, "GLB: " + std::to_string(b.size()) + " bytes, too short for a header");
  require(read_u32(b, 0) == kGlbMagic, "GLB: field 'magic' is not 'glTF'");
  require(read_u32(b, 4) == 2,
          "GLB: field 'version' = " + std::to_string(read_u32(b, 4)) + ", expected 2");
  require(read_u32(b, 8) == b.size(), "GLB: field 'length' = " + std::to_string(read_u32(b, 8)) +
                                          " but the data has " + std::to_string(b.size()) +
                                          " bytes");
  GltfDocument d;
  std::size_t at = 12;
  bool have_json = false;
  while (at < b.size()) {
    require(at + 8 <= b.size(), "GLB: chunk header truncated at byte " + std::to_string(at));
    const std::uint32_t length = read_u32(b, at), type = read_u32(b, at + 4);
    require(length <= b.size() - at - 8,
            "GLB: chunk at byte " + std::to_string(at) + " runs past the end");
    const std::string_view data = b.substr(at + 8, length);
    if (type == kChunkJson) {
      d.json = parse_json(data, "GLB JSON chunk");
      have_json = true;
    } else if (type == kChunkBin) {
      d.bin.assign(data.data(), data.size());
    }
    at += 8 + length;
  }
  require(have_json, "GLB: no JSON chunk");
  if (d.json.contains("buffers") && !d.json["buffers"].empty()) {
    const auto declared = d.json["buffers"][0].value("byteLength", std::size_t{0});
    require(declared <= d.bin.size(), "GLB: buffer 0 declares " + std::to_string(declared) +
                                          " bytes, the BIN chunk has " +
                                          std::to_string(d.bin.size()));
    d.bin.resize(declared);
  }
  return d;
}

std::string write_glb(const GltfDocument& document) {
  GltfDocument d = document;
  std::string bin = d.bin;
  bin.append((4 - bin.size() % 4) % 4, '\0');
  if (!bin.empty()) {
    require(d.json.contains("buffers") && !d.json["buffers"].empty(),
            "glTF: binary data without a buffer");
    d.json["buffers"][0]["byteLength"] = bin.size();
    d.json["buffers"][0].erase("uri");
  }
  std::string json = d.json.dump();
  json.append((4 - json.size() % 4) % 4, ' ');
  const std::size_t total = 12 + 8 + json.size() + (bin.empty() ? 0 : 8 + bin.size());
  require(total <= std::numeric_limits<std::uint32_t>::max(),
          "GLB: " + std::to_string(total) + " bytes exceed the 4 GiB limit of the container");
  std::string out;
  out.reserve(total);
  put_u32(out, kGlbMagic);
  put_u32(out, 2);
  put_u32(out, static_cast<std::uint32_t>(total));
  put_u32(out, static_cast<std::uint32_t>(json.size()));
  put_u32(out, kChunkJson);
  out += json;
  if (!bin.empty()) {
    put_u32(out, static_cast<std::uint32_t>(bin.size()));
    put_u32(out, kChunkBin);
    out += bin;
  }
  return out;
}

GltfDocument parse_gltf(std::string_view json_text, std::string_view buffer) {
  GltfDocument d;
  d.json = parse_json(json_text, "glTF");
  d.bin.assign(buffer.data(), buffer.size());
  return d;
}

std::string write_embedded_gltf(const GltfDocument& document) {
  GltfDocument d = document;
  if (!d.bin.empty()) {
    require(d.json.contains("buffers") && !d.json["buffers"].empty(),
            "glTF: binary data without a buffer");
    d.json["buffers"][0]["byteLength"] = d.bin.size();
    d.json["buffers"][0]["uri"] = kDataUriPrefix + base64_encode(d.bin);
  }
  return d.json.dump();
}

GltfDocument parse_embedded_gltf(std::string_view json_text) {
  GltfDocument d;
  d.json = parse_json(json_text, "glTF");
  if (d.json.contains("buffers") && !d.json["buffers"].empty()) {
    const std::string uri = d.json["buffers"][0].value("uri", std::string());
    require(uri.rfind(kDataUriPrefix, 0) == 0, "glTF: buffer 0 is not an embedded data URI");
    d.bin = base64_decode(std::string_view(uri).substr(std::strlen(kDataUriPrefix)));
  }
  return d;
}

int append_float_accessor(GltfDocument& d, const std::vector<float>& values, int components) {
  require(components > 0 && values.size() % static_cast<std::size_t>(components) == 0,
          "glTF accessor: value count is not a multiple of the component count");
  const std::size_t count = values.size() / static_cast<std::size_t>(components);
  require(count > 0, "glTF accessor: no values");
  d.bin.append((4 - d.bin.size() % 4) % 4, '\0');
  const std::size_t offset = d.bin.size();
  d.bin.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
  if (!d.json.contains("buffers") || d.json["buffers"].empty())
    d.json["buffers"] = nlohmann::json::array({nlohmann::json::object()});
  d.json["buffers"][0]["byteLength"] = d.bin.size();

  auto& views = d.json["bufferViews"];
  if (views.is_null()) views = nlohmann::json::array();
  views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", values.size() * 4}});

  std::vector<float> lo(static_cast<std::size_t>(components), std::numeric_limits<float>::max());
  std::vector<float> hi(static_cast<std::size_t>(components), std::numeric_limits<float>::lowest());
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::size_t c = i % static_cast<std::size_t>(components);
    lo[c] = std::min(lo[c], values[i]);
    hi[c] = std::max(hi[c], values[i]);
  }
  auto& accessors = d.json["accessors"];
  if (accessors.is_null()) accessors = nlohmann::json::array();
  accessors.push_back({{"bufferView", views.size() - 1},
                       {"componentType", kFloat},
                       {"count", count},
                       {"type", type_name(components)},
                       {"min", lo},
                       {"max", hi}});
  return static_cast<int>(accessors.size() - 1);
}

void drop_unused_extensions(GltfDocument& d) {
  std::set<std::string> used;
  collect_extension_names(d.json, used);
  for (const char* list : {"extensionsUsed", "extensionsRequired"}) {
    if (!d.json.contains(list)) continue;
    nlohmann::json kept = nlohmann::json::array();
    for (const auto& name : d.json[list])
      if (name.is_string() && used.count(name.get<std::string>())) kept.push_back(name);
    if (kept.empty())
      d.json.erase(list);
    else
      d.json[list] = kept;
  }
}

std::size_t node_named(const GltfDocument& d, const std::string& name) {
  const auto& nodes = d.json.value("nodes", nlohmann::json::array());
  for (std::size_t n = 0; n < nodes.size(); ++n)
    if (nodes[n].value("name", std::string()) == name) return n;
  throw Error("glTF: no node named '" + name + "'");
}

namespace {

/// `node` and every node below it.
void subtree(const nlohmann::json& nodes, std::size_t node, std::vector<std::size_t>& out) {
  out.push_back(node);
  for (const auto& c : nodes[node].value("children", nlohmann::json::array()))
    subtree(nodes, c.get<std::size_t>(), out);
}

void add_sampler(nlohmann::json& animation, int input, int output, const char* interpolation,
                 std::size_t node, const char* path) {
  auto& samplers = animation["samplers"];
  samplers.push_back({{"input", input}, {"output", output}, {"interpolation", interpolation}});
  animation["channels"].push_back(
      {{"sampler", samplers.size() - 1}, {"target", {{"node", node}, {"path", path}}}});
}

}  // namespace

void add_state_animation(GltfDocument& d, const std::vector<AnimatedGroup>& groups,
                         const std::string& name) {
  require(!groups.empty(), "state animation: no states");
  nlohmann::json animation = {
      {"name", name}, {"samplers", nlohmann::json::array()}, {"channels", nlohmann::json::array()}};
  auto& nodes = d.json["nodes"];
  auto& meshes = d.json["meshes"];
  for (const AnimatedGroup& g : groups) {
    const std::size_t root = node_named(d, g.node);
    for (std::size_t k = 1; k < g.times.size(); ++k)
      require(g.times[k] > g.times[k - 1],
              "state animation of '" + g.node + "': keyframe times must increase strictly");
    const std::size_t targets = g.times.empty() ? 0 : g.times.size() - 1;
    if (targets > 0) {
      std::vector<float> weights((targets + 1) * targets, 0.0f);
      for (std::size_t k = 1; k <= targets; ++k) weights[k * targets + (k - 1)] = 1.0f;
      int input = -1, output = -1;
      std::vector<std::size_t> below;
      subtree(nodes, root, below);
      for (std::size_t n : below) {
        if (!nodes[n].contains("mesh")) continue;
        auto& mesh = meshes[nodes[n]["mesh"].get<std::size_t>()];
        for (const auto& p : mesh["primitives"])
          require(p.value("targets", nlohmann::json::array()).size() == targets,
                  "state animation of '" + g.node + "': a primitive has " +
                      std::to_string(p.value("targets", nlohmann::json::array()).size()) +
                      " morph targets, the run " + std::to_string(targets) + " later states");
        mesh["weights"] = std::vector<float>(targets, 0.0f);
        if (input < 0) {
          input = append_float_accessor(d, g.times, 1);
          output = append_float_accessor(d, weights, 1);
        }
        add_sampler(animation, input, output, "LINEAR", n, "weights");
      }
      require(input >= 0, "state animation of '" + g.node + "': no mesh with morph targets");
    }
    if (groups.size() > 1) {
      std::vector<float> times, scales;
      const auto key = [&](float t, float s) {
        times.push_back(t);
        scales.insert(scales.end(), {s, s, s});
      };
      if (g.visible_from > 0.0f) key(0.0f, 0.0f);
      key(g.visible_from, 1.0f);
      if (g.visible_until >= 0.0f) {
        require(g.visible_until > g.visible_from,
                "state animation of '" + g.node + "': shown for no time");
        key(g.visible_until, 0.0f);
      }
      if (g.visible_from > 0.0f) nodes[root]["scale"] = {0.0, 0.0, 0.0};
      add_sampler(animation, append_float_accessor(d, times, 1),
                  append_float_accessor(d, scales, 3), "STEP", root, "scale");
    }
  }
  require(!animation["channels"].empty(), "state animation: nothing moves or switches");
  if (!d.json.contains("animations")) d.json["animations"] = nlohmann::json::array();
  d.json["animations"].push_back(animation);
}

void add_lods(GltfDocument& d, const std::vector<std::string>& levels,
              const std::vector<float>& coverage) {
  require(levels.size() >= 2 && coverage.size() == levels.size(),
          "glTF levels of detail: two or more levels, a screen coverage for each");
  std::vector<std::size_t> ids;
  for (const std::string& name : levels) ids.push_back(node_named(d, name));
  // Lower levels leave every node's children and the default scene.
  auto& nodes = d.json["nodes"];
  for (auto& node : nodes) {
    if (!node.contains("children")) continue;
    nlohmann::json kept = nlohmann::json::array();
    for (const auto& c : node["children"])
      if (std::find(ids.begin() + 1, ids.end(), c.get<std::size_t>()) == ids.end())
        kept.push_back(c);
    if (kept.empty())
      node.erase("children");  // glTF: children has at least one item
    else
      node["children"] = kept;
  }
  for (auto& scene : d.json["scenes"]) {
    nlohmann::json kept = nlohmann::json::array();
    for (const auto& c : scene["nodes"])
      if (std::find(ids.begin() + 1, ids.end(), c.get<std::size_t>()) == ids.end())
        kept.push_back(c);
    scene["nodes"] = kept;
  }
  auto& top = nodes[ids[0]];
  top["extensions"]["MSFT_lod"] = {{"ids", std::vector<std::size_t>(ids.begin() + 1, ids.end())}};
  top["extras"]["MSFT_screencoverage"] = coverage;
  for (std::size_t k = 1; k < ids.size(); ++k)
    d.json["scenes"].push_back({{"name", "LOD " + std::to_string(k)}, {"nodes", {ids[k]}}});
  auto& used = d.json["extensionsUsed"];
  if (used.is_null()) used = nlohmann::json::array();
  if (std::find(used.begin(), used.end(), "MSFT_lod") == used.end()) used.push_back("MSFT_lod");
}

std::string base64_encode(std::string_view bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  const auto byte = [&](std::size_t k) {
    return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[k]));
  };
  for (; i + 3 <= bytes.size(); i += 3) {
    const std::uint32_t v = (byte(i) << 16) | (byte(i + 1) << 8) | byte(i + 2);
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (const std::size_t rest = bytes.size() - i; rest > 0) {
    const std::uint32_t v = (byte(i) << 16) | (rest == 2 ? byte(i + 1) << 8 : 0u);
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += rest == 2 ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string base64_decode(std::string_view text) {
  std::string out;
  out.reserve(text.size() / 4 * 3);
  std::uint32_t v = 0;
  int bits = 0;
  for (char c : text) {
    int x;
    if (c >= 'A' && c <= 'Z')
      x = c - 'A';
    else if (c >= 'a' && c <= 'z')
      x = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      x = c - '0' + 52;
    else if (c == '+')
      x = 62;
    else if (c == '/')
      x = 63;
    else if (c == '=')
      break;
    else
      throw Error(std::string("base64: unexpected character '") + c + "'");
    v = (v << 6) | static_cast<std::uint32_t>(x);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((v >> bits) & 0xffu);
    }
  }
  return out;
}

}  // namespace tsf::exporter

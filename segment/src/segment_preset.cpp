#include "tsf/segment/segment_preset.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "tsf/common/error.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {
namespace fs = std::filesystem;

namespace {

// Value ranges (inclusive). HU: CT stores -1024..3071 (12 bit) and more with extended scales.
constexpr double kMinHu = -1100.0, kMaxHu = 4000.0;
constexpr double kMaxLengthMm = 200.0;

std::string format_number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// A YAML mapping read strictly: every key must be consumed, so unknown keys are reported.
class StrictMap {
 public:
  StrictMap(const YAML::Node& node, std::string path, const std::string& source)
      : node_(node), path_(std::move(path)), source_(source) {
    if (!node_.IsMap()) fail(node_, path_.empty() ? "(top level)" : path_, "expected a mapping");
  }

  bool has(const char* key) const { return static_cast<bool>(node_[key]); }

  YAML::Node take(const char* key) {
    used_.insert(key);
    return node_[key];
  }

  std::string key_path(const std::string& key) const {
    return path_.empty() ? key : path_ + "." + key;
  }
  const std::string& path() const { return path_; }
  const std::string& source() const { return source_; }

  double number(const char* key, double fallback, double min, double max, const char* unit = "") {
    const YAML::Node n = take(key);
    if (!n) return fallback;
    return to_number(n, key_path(key), min, max, unit);
  }

  bool boolean(const char* key, bool fallback) {
    const YAML::Node n = take(key);
    if (!n) return fallback;
    bool v = false;
    if (!n.IsScalar() || !YAML::convert<bool>::decode(n, v))
      fail(n, key_path(key), "expected true or false");
    return v;
  }

  std::string text(const char* key, const std::string& fallback) {
    const YAML::Node n = take(key);
    if (!n) return fallback;
    if (!n.IsScalar()) fail(n, key_path(key), "expected a string");
    return n.as<std::string>();
  }

  StrictMap child(const char* key) {
    const YAML::Node n = take(key);
    return StrictMap(n ? n : YAML::Node(YAML::NodeType::Map), key_path(key), source_);
  }

  /// Throws naming the first key that was never consumed.
  void finish() const {
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      const std::string key = it->first.as<std::string>();
      if (!used_.count(key)) {
        std::string expected;
        for (const auto& k : used_) expected += (expected.empty() ? "" : ", ") + k;
        fail(it->first, key_path(key),
             "unknown key" +
                 (expected.empty() ? std::string() : " (expected one of: " + expected + ")"));
      }
    }
  }

  double to_number(const YAML::Node& n, const std::string& path, double min, double max,
                   const char* unit) const {
    double v = 0.0;
    if (!n.IsScalar() || !YAML::convert<double>::decode(n, v) || !std::isfinite(v))
      fail(n, path, "expected a number" + std::string(*unit ? " in " : "") + unit);
    if (v < min || v > max)
      fail(n, path,
           "value " + format_number(v) + " is out of range, expected " + format_number(min) +
               " .. " + format_number(max) + (*unit ? std::string(" ") + unit : ""));
    return v;
  }

  Vec3d vec3(const YAML::Node& n, const std::string& path, double min, double max) const {
    if (!n.IsSequence() || n.size() != 3)
      fail(n, path, "expected a list of 3 numbers [x, y, z] in mm");
    return {to_number(n[0], path + "[0]", min, max, "mm"),
            to_number(n[1], path + "[1]", min, max, "mm"),
            to_number(n[2], path + "[2]", min, max, "mm")};
  }

  [[noreturn]] void fail(const YAML::Node& n, const std::string& path,
                         const std::string& what) const {
    std::string where = "preset '" + source_ + "': key '" + path + "'";
    if (n && n.Mark().line >= 0) where += " (line " + std::to_string(n.Mark().line + 1) + ")";
    throw Error(where + ": " + what);
  }

 private:
  YAML::Node node_;
  std::string path_;
  const std::string& source_;
  std::set<std::string> used_;
};

/// Label by name ("soft-tissue", "vessel", …) or number; `allow` restricts to 1..127.
std::uint8_t parse_label(const StrictMap& m, const YAML::Node& n, const std::string& path) {
  if (!n.IsScalar()) m.fail(n, path, "expected a tissue label name or number");
  const std::string text = n.as<std::string>();
  for (int l = 1; l < kLabelFirstUser; ++l)
    if (text == tissue_label_name(static_cast<std::uint8_t>(l)) ||
        text == std::string("overlay-") + std::to_string(l))
      return static_cast<std::uint8_t>(l);
  int value = 0;
  if (YAML::convert<int>::decode(n, value)) {
    if (value < 1 || value >= kLabelFirstUser)
      m.fail(n, path,
             "label " + std::to_string(value) +
                 " is out of range, expected 1 .. 63 (tissue) or 64 .. 127 (overlay)");
    return static_cast<std::uint8_t>(value);
  }
  m.fail(n, path,
         "unknown tissue label '" + text +
             "' (expected soft-tissue, mucosa, fat, cartilage, cancellous-bone, cortical-bone, "
             "tumour, vessel, nerve, or a number 1 .. 127)");
}

std::string label_key(std::uint8_t l) {
  const std::string name = tissue_label_name(l);
  if (name == "overlay" || name == "tissue") return "overlay-" + std::to_string(l);
  return name;
}

DensityBoundary parse_boundary(StrictMap m) {
  DensityBoundary b;
  b.threshold_hu = m.number("threshold_hu", b.threshold_hu, kMinHu, kMaxHu, "HU");
  b.ramp_hu = m.number("ramp_hu", b.ramp_hu, 0.0, 4000.0, "HU");
  m.finish();
  return b;
}

void parse_materials(StrictMap m, MaterialSettings& out) {
  if (m.has("channels")) {
    const YAML::Node n = m.take("channels");
    const std::string path = m.key_path("channels");
    if (!n.IsSequence() || n.size() != kMaterialChannels)
      m.fail(n, path, "expected a list of 4 channel (material) names");
    for (std::size_t c = 0; c < kMaterialChannels; ++c) {
      if (!n[c].IsScalar() || n[c].as<std::string>().empty())
        m.fail(n[c], path + "[" + std::to_string(c) + "]", "expected a non-empty name");
      out.channels[c] = n[c].as<std::string>();
    }
    std::set<std::string> unique(out.channels.begin(), out.channels.end());
    if (unique.size() != kMaterialChannels) m.fail(n, path, "channel names must be distinct");
  }
  out.blend_sigma_mm = m.number("blend_sigma_mm", out.blend_sigma_mm, 0.0, 20.0, "mm");
  if (m.has("classes")) {
    const YAML::Node n = m.take("classes");
    const std::string path = m.key_path("classes");
    if (!n.IsMap())
      m.fail(n, path, "expected a mapping label: channel or label: {channel: fraction}");
    out.class_fractions.clear();  // the file's mapping replaces the default one entirely
    for (auto it = n.begin(); it != n.end(); ++it) {
      const std::string key = it->first.as<std::string>();
      const std::string kpath = path + "." + key;
      const std::uint8_t label = parse_label(m, it->first, kpath);
      std::array<double, kMaterialChannels> fractions{};
      auto channel_index = [&](const YAML::Node& node, const std::string& p) -> std::size_t {
        const std::string name = node.as<std::string>();
        for (std::size_t c = 0; c < kMaterialChannels; ++c)
          if (out.channels[c] == name) return c;
        std::string names;
        for (const auto& c : out.channels) names += (names.empty() ? "" : ", ") + c;
        m.fail(node, p, "unknown material channel '" + name + "' (channels are: " + names + ")");
      };
      const YAML::Node v = it->second;
      if (v.IsScalar()) {
        fractions[channel_index(v, kpath)] = 1.0;
      } else if (v.IsMap()) {
        double sum = 0.0;
        for (auto f = v.begin(); f != v.end(); ++f) {
          const std::string fpath = kpath + "." + f->first.as<std::string>();
          const std::size_t c = channel_index(f->first, fpath);
          fractions[c] = m.to_number(f->second, fpath, 0.0, 1.0, "");
          sum += fractions[c];
        }
        if (std::abs(sum - 1.0) > 1e-3)
          m.fail(v, kpath, "channel fractions sum to " + format_number(sum) + ", expected 1");
      } else {
        m.fail(v, kpath, "expected a channel name or a mapping {channel: fraction}");
      }
      out.class_fractions[label] = fractions;
    }
  }
  m.finish();
}

RegionSettings parse_region(StrictMap m) {
  RegionSettings r;
  r.name = m.text("name", "");
  if (r.name.empty()) m.fail(m.take("name"), m.key_path("name"), "every region needs a name");
  {
    const YAML::Node n = m.take("label");
    if (!n) m.fail(n, m.key_path("label"), "missing; expected a tissue label name or number");
    r.label = parse_label(m, n, m.key_path("label"));
  }
  {
    const YAML::Node n = m.take("seeds_mm");
    const std::string path = m.key_path("seeds_mm");
    if (!n || !n.IsSequence() || n.size() == 0)
      m.fail(n, path, "expected a non-empty list of [x, y, z] positions in mm");
    for (std::size_t i = 0; i < n.size(); ++i)
      r.seeds_mm.push_back(m.vec3(n[i], path + "[" + std::to_string(i) + "]", -1e5, 1e5));
  }
  r.min_hu = m.number("min_hu", kMinHu, kMinHu, kMaxHu, "HU");
  r.max_hu = m.number("max_hu", kMaxHu, kMinHu, kMaxHu, "HU");
  r.max_volume_ml = m.number("max_volume_ml", 100.0, 1e-6, 1e5, "ml");
  m.finish();
  return r;
}

std::array<double, kMaterialChannels> one_hot(std::size_t c) {
  std::array<double, kMaterialChannels> f{};
  f[c] = 1.0;
  return f;
}

}  // namespace

SegmentPreset parse_segment_preset(const std::string& yaml_text, const std::string& source_name) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw Error("preset '" + source_name + "': not valid YAML (line " +
                std::to_string(e.mark.line + 1) + "): " + e.msg);
  }
  if (!root || root.IsNull()) throw Error("preset '" + source_name + "' is empty");
  StrictMap top(root, "", source_name);

  SegmentPreset p;
  p.source = source_name;
  p.name = top.text("name", fs::path(source_name).stem().string());
  p.description = top.text("description", "");

  {
    StrictMap m = top.child("resample");
    p.resample.voxel_mm = m.number("voxel_mm", p.resample.voxel_mm, 0.0, 10.0, "mm");
    p.resample.antialias = m.boolean("antialias", p.resample.antialias);
    if (p.resample.voxel_mm > 0.0 && p.resample.voxel_mm < 0.05)
      m.fail(m.take("voxel_mm"), m.key_path("voxel_mm"),
             "value is out of range, expected 0 (finest input spacing) or 0.05 .. 10 mm");
    m.finish();
  }
  {
    StrictMap m = top.child("roi");
    const std::string mode = m.text("mode", "body");
    if (mode == "body") {
      p.roi.mode = RoiMode::kBody;
    } else if (mode == "box") {
      p.roi.mode = RoiMode::kBox;
    } else {
      m.fail(m.take("mode"), m.key_path("mode"),
             "unknown value '" + mode + "', expected body or box");
    }
    p.roi.margin_mm = m.number("margin_mm", p.roi.margin_mm, 0.0, kMaxLengthMm, "mm");
    const bool has_min = m.has("box_min_mm"), has_max = m.has("box_max_mm");
    if (has_min)
      p.roi.box_min_mm = m.vec3(m.take("box_min_mm"), m.key_path("box_min_mm"), -1e5, 1e5);
    if (has_max)
      p.roi.box_max_mm = m.vec3(m.take("box_max_mm"), m.key_path("box_max_mm"), -1e5, 1e5);
    if (p.roi.mode == RoiMode::kBox && !(has_min && has_max))
      m.fail(m.take(has_min ? "box_max_mm" : "box_min_mm"),
             m.key_path(has_min ? "box_max_mm" : "box_min_mm"),
             "missing; mode: box needs box_min_mm and box_max_mm");
    m.finish();
  }
  {
    StrictMap m = top.child("body");
    auto& b = p.body;
    b.threshold_hu = m.number("threshold_hu", b.threshold_hu, kMinHu, kMaxHu, "HU");
    b.opening_radius_mm = m.number("opening_radius_mm", b.opening_radius_mm, 0.0, 50.0, "mm");
    b.closing_radius_mm = m.number("closing_radius_mm", b.closing_radius_mm, 0.0, 50.0, "mm");
    b.fill_holes = m.boolean("fill_holes", b.fill_holes);
    b.margin_mm = m.number("margin_mm", b.margin_mm, 0.0, 50.0, "mm");
    m.finish();
  }
  {
    StrictMap m = top.child("smoothing");
    p.smoothing.sigma_mm = m.number("sigma_mm", p.smoothing.sigma_mm, 0.0, 10.0, "mm");
    m.finish();
  }
  {
    StrictMap m = top.child("density");
    if (m.has("lower")) p.density.lower = parse_boundary(m.child("lower"));
    if (m.has("upper")) p.density.upper = parse_boundary(m.child("upper"));
    m.finish();
  }
  {
    StrictMap classes = top.child("classes");
    {
      StrictMap m = classes.child("bone");
      auto& b = p.bone;
      b.enabled = m.boolean("enabled", b.enabled);
      b.weak_hu = m.number("weak_hu", b.weak_hu, kMinHu, kMaxHu, "HU");
      b.strong_hu = m.number("strong_hu", b.strong_hu, kMinHu, kMaxHu, "HU");
      b.cortical_hu = m.number("cortical_hu", b.cortical_hu, kMinHu, kMaxHu, "HU");
      m.finish();
    }
    {
      StrictMap m = classes.child("fat");
      auto& f = p.fat;
      f.enabled = m.boolean("enabled", f.enabled);
      f.min_hu = m.number("min_hu", f.min_hu, kMinHu, kMaxHu, "HU");
      f.max_hu = m.number("max_hu", f.max_hu, kMinHu, kMaxHu, "HU");
      f.opening_radius_mm = m.number("opening_radius_mm", f.opening_radius_mm, 0.0, 20.0, "mm");
      m.finish();
    }
    {
      StrictMap m = classes.child("mucosa");
      p.mucosa.enabled = m.boolean("enabled", p.mucosa.enabled);
      p.mucosa.lining_mm = m.number("lining_mm", p.mucosa.lining_mm, 0.0, 20.0, "mm");
      m.finish();
    }
    classes.finish();
  }
  {
    StrictMap m = top.child("air_spaces");
    p.air_spaces.max_hu = m.number("max_hu", p.air_spaces.max_hu, kMinHu, kMaxHu, "HU");
    p.air_spaces.min_depth_mm =
        m.number("min_depth_mm", p.air_spaces.min_depth_mm, 0.0, kMaxLengthMm, "mm");
    m.finish();
  }
  if (top.has("regions")) {
    const YAML::Node n = top.take("regions");
    if (!n.IsSequence()) top.fail(n, "regions", "expected a list of regions");
    for (std::size_t i = 0; i < n.size(); ++i)
      p.regions.push_back(
          parse_region(StrictMap(n[i], "regions[" + std::to_string(i) + "]", source_name)));
  }

  // Default palette: channel 0 soft, 1 mucosa, 2 cartilage, 3 bone. A materials.classes mapping
  // in the file replaces the default mapping (so renamed channels never inherit stale entries).
  p.materials.channels = {"soft", "mucosa", "cartilage", "bone"};
  p.materials.class_fractions = {
      {kLabelSoftTissue, one_hot(0)},
      {kLabelMucosa, one_hot(1)},
      {kLabelFat, one_hot(0)},
      {kLabelCartilage, one_hot(2)},
      {kLabelCancellousBone, one_hot(3)},
      {kLabelCorticalBone, one_hot(3)},
      {kLabelTumour, one_hot(0)},
      {kLabelVessel, one_hot(0)},
      {kLabelNerve, one_hot(0)},
  };
  parse_materials(top.child("materials"), p.materials);
  top.finish();

  p.validate();
  return p;
}

void SegmentPreset::validate() const {
  const std::string where = "preset '" + (source.empty() ? name : source.string()) + "': key '";
  auto fail = [&](const std::string& path, const std::string& what) {
    throw Error(where + path + "': " + what);
  };
  if (roi.mode == RoiMode::kBox)
    for (int a = 0; a < 3; ++a)
      if (!(roi.box_min_mm[a] < roi.box_max_mm[a]))
        fail("roi.box_max_mm", "must be greater than roi.box_min_mm on every axis (axis " +
                                   std::to_string(a) + ": " + format_number(roi.box_min_mm[a]) +
                                   " .. " + format_number(roi.box_max_mm[a]) + ")");
  if (density.upper && !(density.upper->threshold_hu > density.lower.threshold_hu))
    fail("density.upper.threshold_hu", "must be above density.lower.threshold_hu (" +
                                           format_number(density.lower.threshold_hu) + " HU)");
  if (bone.enabled) {
    if (!(bone.weak_hu <= bone.strong_hu))
      fail("classes.bone.weak_hu",
           "must not exceed classes.bone.strong_hu (" + format_number(bone.strong_hu) + " HU)");
    if (!(bone.cortical_hu >= bone.weak_hu))
      fail("classes.bone.cortical_hu",
           "must not be below classes.bone.weak_hu (" + format_number(bone.weak_hu) + " HU)");
  }
  if (fat.enabled && !(fat.min_hu < fat.max_hu))
    fail("classes.fat.max_hu",
         "must be above classes.fat.min_hu (" + format_number(fat.min_hu) + " HU)");
  std::set<std::string> names;
  for (std::size_t i = 0; i < regions.size(); ++i) {
    const auto& r = regions[i];
    const std::string path = "regions[" + std::to_string(i) + "]";
    if (!names.insert(r.name).second)
      fail(path + ".name", "duplicate region name '" + r.name + "'");
    if (!(r.min_hu <= r.max_hu))
      fail(path + ".max_hu",
           "must not be below " + path + ".min_hu (" + format_number(r.min_hu) + " HU)");
    if (r.label == 0 || r.label >= kLabelFirstUser)
      fail(path + ".label", "expected a tissue (1..63) or overlay (64..127) label");
  }
  // Every label the pipeline can write needs a material mapping.
  std::vector<std::uint8_t> used{kLabelSoftTissue};
  if (mucosa.enabled) used.push_back(kLabelMucosa);
  if (fat.enabled) used.push_back(kLabelFat);
  if (bone.enabled) {
    used.push_back(kLabelCancellousBone);
    used.push_back(kLabelCorticalBone);
  }
  for (const auto& r : regions) used.push_back(r.label);
  for (std::uint8_t l : used)
    if (!materials.class_fractions.count(l))
      fail("materials.classes." + label_key(l),
           "missing: the label " + std::to_string(l) + " can occur and needs material channels");
}

nlohmann::json SegmentPreset::to_json() const {
  using nlohmann::json;
  auto vec = [](const Vec3d& v) { return json::array({v.x, v.y, v.z}); };
  auto boundary = [](const DensityBoundary& b) {
    return json{{"threshold_hu", b.threshold_hu}, {"ramp_hu", b.ramp_hu}};
  };
  json j;
  j["name"] = name;
  j["description"] = description;
  j["source"] = source.string();
  j["resample"] = {{"voxel_mm", resample.voxel_mm}, {"antialias", resample.antialias}};
  j["roi"] = {{"mode", roi.mode == RoiMode::kBody ? "body" : "box"}, {"margin_mm", roi.margin_mm}};
  if (roi.mode == RoiMode::kBox) {
    j["roi"]["box_min_mm"] = vec(roi.box_min_mm);
    j["roi"]["box_max_mm"] = vec(roi.box_max_mm);
  }
  j["body"] = {{"threshold_hu", body.threshold_hu},
               {"opening_radius_mm", body.opening_radius_mm},
               {"closing_radius_mm", body.closing_radius_mm},
               {"fill_holes", body.fill_holes},
               {"margin_mm", body.margin_mm}};
  j["smoothing"] = {{"sigma_mm", smoothing.sigma_mm}};
  j["density"] = {{"lower", boundary(density.lower)}};
  if (density.upper) j["density"]["upper"] = boundary(*density.upper);
  j["classes"]["bone"] = {{"enabled", bone.enabled},
                          {"weak_hu", bone.weak_hu},
                          {"strong_hu", bone.strong_hu},
                          {"cortical_hu", bone.cortical_hu}};
  j["classes"]["fat"] = {{"enabled", fat.enabled},
                         {"min_hu", fat.min_hu},
                         {"max_hu", fat.max_hu},
                         {"opening_radius_mm", fat.opening_radius_mm}};
  j["classes"]["mucosa"] = {{"enabled", mucosa.enabled}, {"lining_mm", mucosa.lining_mm}};
  j["air_spaces"] = {{"max_hu", air_spaces.max_hu}, {"min_depth_mm", air_spaces.min_depth_mm}};
  j["regions"] = json::array();
  for (const auto& r : regions) {
    json seeds = json::array();
    for (const auto& s : r.seeds_mm) seeds.push_back(vec(s));
    j["regions"].push_back({{"name", r.name},
                            {"label", label_key(r.label)},
                            {"seeds_mm", seeds},
                            {"min_hu", r.min_hu},
                            {"max_hu", r.max_hu},
                            {"max_volume_ml", r.max_volume_ml}});
  }
  j["materials"]["channels"] = materials.channels;
  j["materials"]["blend_sigma_mm"] = materials.blend_sigma_mm;
  for (const auto& [label, fractions] : materials.class_fractions) {
    json f = json::object();
    for (std::size_t c = 0; c < kMaterialChannels; ++c)
      if (fractions[c] > 0.0) f[materials.channels[c]] = fractions[c];
    j["materials"]["classes"][label_key(label)] = f;
  }
  return j;
}

std::vector<fs::path> segment_preset_dirs() {
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("TSF_PRESET_DIR"); env && *env) dirs.emplace_back(env);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec)
    dirs.push_back(exe.parent_path().parent_path() / "share" / "tsf" / "presets" / "segment");
  return dirs;
}

std::vector<std::string> available_segment_presets() {
  std::set<std::string> names;
  for (const auto& dir : segment_preset_dirs()) {
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
      if (it->path().extension() == ".yaml") names.insert(it->path().stem().string());
  }
  return {names.begin(), names.end()};
}

SegmentPreset load_segment_preset(const std::string& name_or_path) {
  if (name_or_path.empty())
    throw Error("preset: empty name; expected a preset name or a YAML file");
  const fs::path given(name_or_path);
  const bool is_path = name_or_path.find('/') != std::string::npos ||
                       given.extension() == ".yaml" || given.extension() == ".yml";
  fs::path file;
  if (is_path) {
    if (!fs::is_regular_file(given))
      throw Error("preset file '" + name_or_path + "' does not exist or is not a file");
    file = given;
  } else {
    for (const auto& dir : segment_preset_dirs()) {
      const fs::path candidate = dir / (name_or_path + ".yaml");
      if (fs::is_regular_file(candidate)) {
        file = candidate;
        break;
      }
    }
    if (file.empty()) {
      std::string searched, names;
      for (const auto& d : segment_preset_dirs()) searched += "\n  " + d.string();
      for (const auto& n : available_segment_presets()) names += (names.empty() ? "" : ", ") + n;
      throw Error("unknown preset '" + name_or_path +
                  "' (available: " + (names.empty() ? std::string("none found") : names) +
                  "); give a name or a path to a YAML file. Searched:" + searched);
    }
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error("cannot open preset file '" + file.string() + "'");
  std::stringstream text;
  text << in.rdbuf();
  SegmentPreset preset = parse_segment_preset(text.str(), file.string());
  preset.source = file;
  return preset;
}

}  // namespace tsf::segment

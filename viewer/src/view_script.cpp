#include "tsf/viewer/view_script.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <yaml-cpp/yaml.h>

#include "tsf/common/error.h"

namespace tsf::viewer {
namespace {

/// A node with its key path, for errors that name where the problem is.
class Node {
 public:
  Node(YAML::Node n, std::string path, const std::string* file)
      : n_(std::move(n)), path_(std::move(path)), file_(file) {}
  bool defined() const { return n_.IsDefined() && !n_.IsNull(); }
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(*file_ + ": " + (path_.empty() ? "" : path_ + ": ") + what);
  }
  Node operator[](const char* key) const {
    return Node(n_[key], path_.empty() ? key : path_ + "." + key, file_);
  }
  Node at(std::size_t i) const { return Node(n_[i], path_ + "[" + std::to_string(i) + "]", file_); }
  std::size_t size() const {
    if (!n_.IsSequence()) fail("expected a list");
    return n_.size();
  }
  void keys(std::initializer_list<const char*> allowed) const {
    if (!n_.IsMap()) fail("expected a mapping of keys");
    std::set<std::string> ok(allowed.begin(), allowed.end());
    for (const auto& kv : n_) {
      const std::string k = kv.first.as<std::string>();
      if (!ok.count(k)) {
        std::string list;
        for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
        throw Error(*file_ + ": " + (path_.empty() ? "" : path_ + ".") + k +
                    ": unknown key (expected one of: " + list + ")");
      }
    }
  }
  double number() const {
    try {
      const double v = n_.as<double>();
      if (!std::isfinite(v)) fail("expected a finite number");
      return v;
    } catch (const YAML::Exception&) {
      fail("expected a number, got '" + text() + "'");
    }
  }
  double number_in(double lo, double hi, bool open_lo = false) const {
    const double v = number();
    if (v < lo || v > hi || (open_lo && v == lo))
      fail("expected a number in " + std::string(open_lo ? "(" : "[") + fmt(lo) + ", " + fmt(hi) +
           "], got " + fmt(v));
    return v;
  }
  bool boolean() const {
    try {
      return n_.as<bool>();
    } catch (const YAML::Exception&) {
      fail("expected true or false, got '" + text() + "'");
    }
  }
  std::string text() const {
    try {
      return n_.as<std::string>();
    } catch (const YAML::Exception&) {
      return "(not a scalar)";
    }
  }
  Vec3d vec3() const {
    if (!n_.IsSequence() || n_.size() != 3) fail("expected a list of three numbers [x, y, z]");
    return {at(0).number(), at(1).number(), at(2).number()};
  }

 private:
  static std::string fmt(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
  }
  YAML::Node n_;
  std::string path_;
  const std::string* file_;
};

}  // namespace

ViewScript read_view_script(const std::filesystem::path& file, const std::vector<NamedTool>& tools,
                            const ViewOptions& defaults) {
  const std::string name = file.string();
  YAML::Node root;
  try {
    root = YAML::LoadFile(name);
  } catch (const YAML::BadFile&) {
    throw Error(name + ": cannot open the view script");
  } catch (const YAML::Exception& e) {
    throw Error(name + ": not valid YAML: " + e.what());
  }
  ViewScript s;
  s.options = defaults;
  ViewOptions& o = s.options;
  const Node top(root, "", &name);
  if (!top.defined()) top.fail("the view script is empty (expected a mapping of keys)");
  top.keys(
      {"frame_time", "width", "height", "camera", "slices", "hud", "plot", "tool", "keyframes"});
  if (top["frame_time"].defined()) o.frame_s = top["frame_time"].number_in(0, 1, true);
  if (top["width"].defined()) o.width = static_cast<int>(top["width"].number_in(64, 8192));
  if (top["height"].defined()) o.height = static_cast<int>(top["height"].number_in(64, 8192));
  if (const Node c = top["camera"]; c.defined()) {
    c.keys({"azimuth", "elevation", "zoom", "focus"});
    if (c["azimuth"].defined()) o.camera.azimuth_deg = c["azimuth"].number_in(-360, 360);
    if (c["elevation"].defined()) o.camera.elevation_deg = c["elevation"].number_in(-89, 89);
    if (c["zoom"].defined()) o.camera.zoom = c["zoom"].number_in(0, 100, true);
    if (c["focus"].defined()) o.camera.focus_mm = c["focus"].vec3();
  }
  if (const Node sl = top["slices"]; sl.defined()) {
    sl.keys({"show", "axial", "coronal", "sagittal", "labels", "position", "opacity"});
    if (sl["show"].defined()) o.slices.show = sl["show"].boolean();
    if (sl["axial"].defined()) o.slices.axial = sl["axial"].boolean();
    if (sl["coronal"].defined()) o.slices.coronal = sl["coronal"].boolean();
    if (sl["sagittal"].defined()) o.slices.sagittal = sl["sagittal"].boolean();
    if (sl["labels"].defined()) o.slices.labels = sl["labels"].boolean();
    if (sl["position"].defined()) o.slices.position_mm = sl["position"].vec3();
    if (sl["opacity"].defined()) o.slices.opacity = sl["opacity"].number_in(0, 1, true);
  }
  if (top["hud"].defined()) o.show_hud = top["hud"].boolean();
  if (top["plot"].defined()) o.show_plot = top["plot"].boolean();
  if (top["tool"].defined()) o.show_tool = top["tool"].boolean();

  std::vector<std::vector<interaction::Keyframe>> keys(kMaxHands);
  std::vector<std::vector<int>> tools_of(kMaxHands);
  if (const Node k = top["keyframes"]; k.defined()) {
    std::vector<Rotation> rotations(kMaxHands);
    for (std::size_t i = 0; i < k.size(); ++i) {
      const Node kf = k.at(i);
      kf.keys({"frame", "hand", "tool", "position", "rotation", "mode"});
      if (!kf["frame"].defined()) kf.fail("needs `frame`");
      if (!kf["tool"].defined()) kf.fail("needs `tool`");
      if (!kf["position"].defined()) kf.fail("needs `position`");
      const int hand =
          kf["hand"].defined() ? static_cast<int>(kf["hand"].number_in(0, kMaxHands - 1)) : 0;
      if (kf["hand"].defined() && kf["hand"].number() != hand)
        kf["hand"].fail("expected a whole number in [0, " + std::to_string(kMaxHands - 1) + "]");
      Rotation& rotation = rotations[static_cast<std::size_t>(hand)];
      interaction::Keyframe key;
      key.time_s = kf["frame"].number_in(0, 1e7);
      if (!keys[hand].empty() && key.time_s <= keys[hand].back().time_s)
        kf["frame"].fail("frames must increase from keyframe to keyframe of one hand");
      const std::string tool = kf["tool"].text();
      int index = -1;
      std::string names;
      for (std::size_t t = 0; t < tools.size(); ++t) {
        if (tools[t].name == tool) index = static_cast<int>(t);
        names += (names.empty() ? "" : ", ") + tools[t].name;
      }
      if (index < 0)
        kf["tool"].fail("no tool named '" + tool + "' in the scene (it has: " + names + ")");
      key.pose.position = kf["position"].vec3();
      if (const Node r = kf["rotation"]; r.defined()) {
        r.keys({"axis", "angle_deg"});
        if (!r["axis"].defined() || !r["angle_deg"].defined())
          r.fail("needs `axis` and `angle_deg`");
        const Vec3d axis = r["axis"].vec3();
        if (length(axis) <= 0) r["axis"].fail("the axis must not be zero");
        rotation = Rotation::about_axis(axis, r["angle_deg"].number() * M_PI / 180.0);
      }
      key.pose.orientation = rotation;
      key.mode = interaction::ToolMode::kIdle;
      if (kf["mode"].defined()) {
        try {
          key.mode = interaction::tool_mode_from_string(kf["mode"].text());
        } catch (const Error& e) {
          kf["mode"].fail(e.what());
        }
      }
      if (!tools[static_cast<std::size_t>(index)].tool.supports(key.mode))
        kf["mode"].fail(std::string("tool '") + tool + "' (" +
                        interaction::to_string(tools[static_cast<std::size_t>(index)].tool.shape) +
                        ") cannot " + interaction::to_string(key.mode) +
                        " (ablate: sphere or capsule; cut: blade)");
      keys[hand].push_back(key);
      tools_of[hand].push_back(index);
    }
  }
  // Hands in order, up to the last one that has keyframes (an empty hand before it stays empty).
  int last = -1;
  for (int h = 0; h < kMaxHands; ++h)
    if (!keys[h].empty()) last = h;
  for (int h = 0; h <= last; ++h) {
    ViewHand hand;
    if (!keys[h].empty()) hand.path = interaction::Trajectory(keys[h]);
    hand.keyframe_tools = tools_of[h];
    s.hands.push_back(std::move(hand));
  }
  o.validate();
  return s;
}

bool ViewScript::holds_tool_at(int frame) const {
  return !hands.empty() && hands.front().holds_tool_at(frame);
}

ToolCommand ViewScript::command_at(int frame) const {
  return hands.empty() ? ToolCommand{} : hands.front().command_at(frame);
}

std::vector<ToolCommand> ViewScript::commands_at(int frame) const {
  std::vector<ToolCommand> c;
  for (const ViewHand& h : hands) {
    c.push_back(h.command_at(frame));
    if (!h.holds_tool_at(frame)) c.back().tool = -1;
  }
  return c;
}

double ViewScript::last_keyframe() const {
  double last = -1;
  for (const ViewHand& h : hands)
    if (!h.path.empty()) last = std::max(last, h.path.end_time());
  return last;
}

bool ViewHand::holds_tool_at(int frame) const {
  return !path.empty() && static_cast<double>(frame) >= path.start_time();
}

ToolCommand ViewHand::command_at(int frame) const {
  ToolCommand c;
  if (!holds_tool_at(frame)) return c;
  const interaction::TrajectorySample s = path.sample(static_cast<double>(frame));
  c.pose = s.pose;
  c.mode = s.mode;
  const auto& keys = path.keyframes();
  for (std::size_t i = 0; i < keys.size(); ++i)
    if (keys[i].time_s <= frame) c.tool = keyframe_tools[i];
  // A switch of tool lifts the previous one: the pose jumps, so the mode of the earlier keyframe
  // only holds while the same tool is in hand.
  for (std::size_t i = 0; i + 1 < keys.size(); ++i)
    if (keys[i].time_s <= frame && frame < keys[i + 1].time_s &&
        keyframe_tools[i] != keyframe_tools[i + 1]) {
      c.pose = keys[i].pose;
      c.mode = keys[i].mode;
    }
  return c;
}

}  // namespace tsf::viewer

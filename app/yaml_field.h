// A YAML node with its key path, for strict reading of every human-edited file of the app (scenes,
// pipeline specs, materials, haptic trajectories): every accessor checks type and range and names
// the file and key path on error,
//   tissues.yaml: materials.fat.youngs_modulus_pa: expected a number in [1, 1e+11], got -3 (line 9)
// yaml-cpp stays in app/: tissue/ never sees it.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "tsf/common/error.h"
#include "tsf/common/vec3.h"

namespace tsf::app {

class YamlField {
 public:
  YamlField(YAML::Node node, std::string path, std::string file)
      : node_(std::move(node)), path_(std::move(path)), file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& what) const {
    std::ostringstream s;
    s << file_ << ": " << (path_.empty() ? "(top level)" : path_) << ": " << what;
    if (node_.IsDefined() && node_.Mark().line >= 0) s << " (line " << node_.Mark().line + 1 << ")";
    throw Error(s.str());
  }
  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }
  const YAML::Node& node() const { return node_; }

  /// Child of a map (absent when this node is absent or not a map).
  YamlField operator[](const std::string& key) const {
    const std::string path = path_.empty() ? key : path_ + "." + key;
    if (!defined() || !node_.IsMap()) return YamlField(YAML::Node(), path, file_);
    return YamlField(node_[key], path, file_);
  }
  /// Fails on any key not in `allowed` (or when the node is not a map).
  void expect_keys(const std::vector<std::string>& allowed) const {
    if (!defined()) return;
    if (!node_.IsMap()) fail("expected a mapping of keys");
    const std::set<std::string> ok(allowed.begin(), allowed.end());
    for (const auto& kv : node_) {
      const std::string key = kv.first.as<std::string>();
      if (ok.count(key)) continue;
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      YamlField(kv.first, path_.empty() ? key : path_ + "." + key, file_)
          .fail("unknown key (expected one of: " + list + ")");
    }
  }
  /// Keys of a map in file order.
  std::vector<std::string> keys() const {
    if (!defined() || !node_.IsMap()) fail("expected a mapping of keys");
    std::vector<std::string> out;
    for (const auto& kv : node_) out.push_back(kv.first.as<std::string>());
    return out;
  }
  YamlField required() const {
    if (!defined()) fail("is required");
    return *this;
  }
  std::string text() const {
    if (!node_.IsScalar()) fail("expected a text value");
    return node_.Scalar();
  }
  std::string text(const std::string& fallback) const { return defined() ? text() : fallback; }
  double number() const {
    if (!node_.IsScalar()) fail("expected a number");
    double v = 0;
    try {
      v = node_.as<double>();
    } catch (const YAML::Exception&) {
      fail("expected a number, got '" + node_.Scalar() + "'");
    }
    if (!std::isfinite(v)) fail("expected a finite number, got '" + node_.Scalar() + "'");
    return v;
  }
  /// A number in [lo, hi] (or (lo, hi] with lo_open); `fallback` when absent.
  double number(double fallback, double lo, double hi, bool lo_open = false) const {
    if (!defined()) return fallback;
    const double v = number();
    if ((lo_open ? !(v > lo) : !(v >= lo)) || !(v <= hi)) {
      std::ostringstream s;
      s << "expected a number in " << (lo_open ? "(" : "[") << lo << ", " << hi << "], got " << v;
      fail(s.str());
    }
    return v;
  }
  std::int64_t integer(std::int64_t fallback, std::int64_t lo, std::int64_t hi) const {
    if (!defined()) return fallback;
    const double v = number();
    if (v != std::floor(v) || v < static_cast<double>(lo) || v > static_cast<double>(hi))
      fail("expected a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
           "], got " + node_.Scalar());
    return static_cast<std::int64_t>(v);
  }
  bool boolean(bool fallback) const {
    if (!defined()) return fallback;
    if (!node_.IsScalar()) fail("expected true or false");
    bool b = false;
    if (!YAML::convert<bool>::decode(node_, b))
      fail("expected true or false, got '" + node_.Scalar() + "'");
    return b;
  }
  template <typename T>
  T choice(T fallback, std::initializer_list<std::pair<const char*, T>> options) const {
    if (!defined()) return fallback;
    const std::string t = text();
    std::string list;
    for (const auto& o : options) {
      if (t == o.first) return o.second;
      list += std::string(list.empty() ? "" : ", ") + o.first;
    }
    fail("expected one of " + list + ", got '" + t + "'");
  }
  /// A required number in [lo, hi] (or (lo, hi] with lo_open).
  double required_number(double lo, double hi, bool lo_open = false) const {
    return required().number(0, lo, hi, lo_open);
  }
  /// A list of 3 numbers [x, y, z]; `fallback` when absent.
  Vec3d vec3(Vec3d fallback) const {
    if (!defined()) return fallback;
    return vec3();
  }
  /// A required list of 3 numbers [x, y, z].
  Vec3d vec3() const {
    if (!defined()) fail("is required");
    if (!node_.IsSequence() || node_.size() != 3) fail("expected a list of 3 numbers [x, y, z]");
    Vec3d v;
    for (int a = 0; a < 3; ++a) v[a] = at(static_cast<std::size_t>(a)).number();
    return v;
  }
  /// A required list of 3 numbers, each in [-limit, limit].
  Vec3d vec3_within(double limit) const {
    const Vec3d v = vec3();
    for (int a = 0; a < 3; ++a)
      if (!(std::fabs(v[a]) <= limit)) {
        std::ostringstream s;
        s << "expected a list of 3 numbers in [" << -limit << ", " << limit << "], got " << v[a];
        fail(s.str());
      }
    return v;
  }
  /// The scalar `auto` (a value the program derives).
  bool is_auto() const { return defined() && node_.IsScalar() && node_.Scalar() == "auto"; }
  std::size_t size() const {
    if (!defined() || !node_.IsSequence()) fail("expected a list");
    return node_.size();
  }
  YamlField at(std::size_t i) const {
    return YamlField(node_[i], path_ + "[" + std::to_string(i) + "]", file_);
  }

 private:
  YAML::Node node_;
  std::string path_;
  std::string file_;
};

/// Checks the shape of a loaded YAML file before any reader looks at it (load_yaml_file):
/// - a key written twice in one mapping is refused naming the key path and both lines (yaml-cpp
///   keeps both and node[key] answers the first, so the second would be ignored silently);
/// - a key that is not plain text (a list or a mapping used as a key) is refused;
/// - nesting deeper than 256 levels (a recursive alias nests without end) and more than 10^6
///   nodes in all (aliases can multiply a small file many times over) are refused.
inline void check_yaml_shape(const YAML::Node& node, const std::string& path,
                             const std::string& file, int depth, std::size_t& nodes) {
  const auto short_path = [&] { return path.size() > 80 ? path.substr(0, 80) + "..." : path; };
  if (depth > 256) YamlField(node, short_path(), file).fail("nested more than 256 levels deep");
  if (++nodes > 1000000)
    YamlField(node, short_path(), file).fail("the file holds more than 10^6 values (aliases?)");
  if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i)
      check_yaml_shape(node[i], path + "[" + std::to_string(i) + "]", file, depth + 1, nodes);
    return;
  }
  if (!node.IsMap()) return;
  std::map<std::string, int> seen;  // key -> line (1-based)
  for (const auto& kv : node) {
    if (!kv.first.IsScalar())
      YamlField(kv.first, short_path(), file).fail("expected a plain key, not a list or mapping");
    const std::string key = kv.first.Scalar();
    const std::string child = path.empty() ? key : path + "." + key;
    const auto [at, inserted] = seen.emplace(key, kv.first.Mark().line + 1);
    if (!inserted)
      YamlField(kv.first, child, file)
          .fail("the key is given twice, first at line " + std::to_string(at->second) +
                ": expected each key once");
    check_yaml_shape(kv.second, child, file, depth + 1, nodes);
  }
}

/// Loads a YAML file (every human-edited file of the app is read here); a missing file, a syntax
/// error or a duplicated key names the file (and line).
inline YAML::Node load_yaml_file(const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw Error(file + ": cannot read the file");
  } catch (const YAML::ParserException& e) {
    throw Error(file + ": YAML syntax error at line " + std::to_string(e.mark.line + 1) + ": " +
                e.msg);
  } catch (const YAML::Exception& e) {
    throw Error(file + ": not valid YAML: " + e.what());
  }
  std::size_t nodes = 0;
  check_yaml_shape(root, "", file, 0, nodes);
  return root;
}

}  // namespace tsf::app

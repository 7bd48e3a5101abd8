// Haptic devices picked by name. A command that drives a haptic loop builds a registry of the
// devices it can offer (app/scene/haptic_devices.h registers tsf's own: `scripted`, `mouse`) and a
// user picks one with `--device NAME[:KEY=VALUE,…]`; a driver (a haptic arm's SDK, a network
// link) adds itself with add() and is then offered by every command the same way.
//
//   DeviceRegistry r;
//   r.add("scripted", "a trajectory played in wall-clock time", [&](const DeviceRequest& q) {…});
//   std::unique_ptr<HapticDevice> d = r.create(parse_device_request("scripted"));
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "tsf/haptics/haptic_device.h"

namespace tsf::haptics {

/// `NAME[:KEY=VALUE,KEY=VALUE…]` as given on the command line.
struct DeviceRequest {
  std::string name;
  std::map<std::string, std::string> parameters;
  std::string text;  ///< as given, for messages

  /// The parameter `key`, or `fallback` when it was not given.
  std::string get(const std::string& key, const std::string& fallback = "") const;
  /// Throws tsf::Error naming the device and the first parameter not in `known`.
  void expect_only(const std::vector<std::string>& known) const;
};

/// Parses `NAME[:KEY=VALUE,…]` (names and keys: letters, digits, '-', '_'; values: anything but
/// ','); throws tsf::Error naming the text and what was expected.
DeviceRequest parse_device_request(const std::string& text);

class DeviceRegistry {
 public:
  using Factory = std::function<std::unique_ptr<HapticDevice>(const DeviceRequest&)>;

  /// Offers device `name` (replacing one of the same name).
  void add(const std::string& name, const std::string& description, Factory factory);
  bool has(const std::string& name) const { return devices_.count(name) != 0; }
  /// Makes the requested device; throws tsf::Error listing the known names for an unknown one.
  std::unique_ptr<HapticDevice> create(const DeviceRequest& request) const;
  /// (name, description) of every device offered, by name.
  std::vector<std::pair<std::string, std::string>> list() const;
  /// "scripted (…), mouse (…)" for help texts and errors.
  std::string describe() const;

 private:
  struct Entry {
    std::string description;
    Factory factory;
  };
  std::map<std::string, Entry> devices_;
};

}  // namespace tsf::haptics

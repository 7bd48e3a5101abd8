#include "tsf/haptics/device_registry.h"

#include <algorithm>
#include <cctype>

#include "tsf/common/error.h"

namespace tsf::haptics {
namespace {

bool word(const std::string& s) {
  return !s.empty() && s.size() <= 64 && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_';
  });
}

}  // namespace

std::string DeviceRequest::get(const std::string& key, const std::string& fallback) const {
  const auto it = parameters.find(key);
  return it == parameters.end() ? fallback : it->second;
}

void DeviceRequest::expect_only(const std::vector<std::string>& known) const {
  for (const auto& [key, value] : parameters)
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      throw Error("--device " + text + ": device '" + name + "' takes no parameter '" + key + "'" +
                  (known.empty() ? " (it takes none)" : " (it takes: " + list + ")"));
    }
}

DeviceRequest parse_device_request(const std::string& text) {
  DeviceRequest r;
  r.text = text;
  const std::size_t colon = text.find(':');
  r.name = text.substr(0, colon);
  if (!word(r.name))
    throw Error("--device " + text +
                ": expected NAME[:KEY=VALUE,…] with a name of letters, digits, '-' or '_'");
  if (colon == std::string::npos) return r;
  std::string rest = text.substr(colon + 1);
  std::size_t at = 0;
  while (at <= rest.size()) {
    const std::size_t comma = std::min(rest.find(',', at), rest.size());
    const std::string item = rest.substr(at, comma - at);
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos || !word(item.substr(0, eq)) || eq + 1 > item.size())
      throw Error("--device " + text + ": expected KEY=VALUE after the name, got '" + item + "'");
    const std::string key = item.substr(0, eq);
    if (r.parameters.count(key))
      throw Error("--device " + text + ": parameter '" + key + "' is given twice");
    r.parameters[key] = item.substr(eq + 1);
    at = comma + 1;
    if (comma == rest.size()) break;
  }
  return r;
}

void DeviceRegistry::add(const std::string& name, const std::string& description, Factory factory) {
  require(word(name), "device registry: bad device name '" + name + "'");
  require(static_cast<bool>(factory), "device registry: no factory for '" + name + "'");
  devices_[name] = {description, std::move(factory)};
}

std::unique_ptr<HapticDevice> DeviceRegistry::create(const DeviceRequest& request) const {
  const auto it = devices_.find(request.name);
  if (it == devices_.end())
    throw Error("--device " + request.text + ": no device named '" + request.name +
                "' here (known: " + describe() + ")");
  std::unique_ptr<HapticDevice> d = it->second.factory(request);
  require(d != nullptr, "--device " + request.text + ": the device could not be made");
  return d;
}

std::vector<std::pair<std::string, std::string>> DeviceRegistry::list() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& [name, e] : devices_) out.emplace_back(name, e.description);
  return out;
}

std::string DeviceRegistry::describe() const {
  std::string s;
  for (const auto& [name, e] : devices_) s += (s.empty() ? "" : "; ") + name + ": " + e.description;
  return s.empty() ? "none" : s;
}

}  // namespace tsf::haptics

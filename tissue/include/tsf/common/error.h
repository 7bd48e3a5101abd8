// Errors at module boundaries: one exception type whose message names the file, field or value
// and what was expected. Callers in the app print `what()` and exit non-zero.
#pragma once

#include <stdexcept>
#include <string>

namespace tsf {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// Throws tsf::Error(message) when `condition` is false. For broken inputs and invariants that
/// must never be ignored silently (not for hot loops).
inline void require(bool condition, const std::string& message) {
  if (!condition) throw Error(message);
}

}  // namespace tsf

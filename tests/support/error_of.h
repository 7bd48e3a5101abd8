// The message of the tsf::Error a call throws, for tests that check what an error says.
#pragma once

#include <functional>
#include <string>

#include "tsf/common/error.h"

namespace tsf::test {

/// What `f` throws as a tsf::Error; "" when it returns normally. Other exceptions propagate (the
/// test fails on them).
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace tsf::test

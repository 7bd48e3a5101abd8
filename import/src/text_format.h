// printf-style number formatting for messages and reports (checked by the compiler).
#pragma once

#include <cstdarg>
#include <cstdio>
#include <string>

namespace tsf::import {

[[gnu::format(printf, 1, 2)]] inline std::string fmt(const char* format, ...) {
  char buf[128];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buf, sizeof buf, format, args);
  va_end(args);
  return buf;
}

}  // namespace tsf::import

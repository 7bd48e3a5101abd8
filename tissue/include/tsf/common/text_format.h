// printf-style formatting into a std::string, for messages and report lines (checked formats).
#pragma once

#include <cstdarg>
#include <cstdio>
#include <string>

namespace tsf {

/// The formatted text (at most 1023 characters).
[[gnu::format(printf, 1, 2)]] inline std::string format_text(const char* format, ...) {
  char text[1024];
  va_list args;
  va_start(args, format);
  std::vsnprintf(text, sizeof text, format, args);
  va_end(args);
  return text;
}

}  // namespace tsf

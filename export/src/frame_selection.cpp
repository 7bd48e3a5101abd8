#include "tsf/export/frame_selection.h"

#include <cctype>

#include "tsf/common/error.h"

namespace tsf::exporter {

namespace {

bool parse_index(const std::string& s, std::size_t& out) {
  if (s.empty() || s.size() > 9) return false;
  for (char c : s)
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  out = static_cast<std::size_t>(std::stoul(s));
  return true;
}

}  // namespace

FrameSelection FrameSelection::parse(const std::string& text) {
  FrameSelection s;
  if (text == "all") {
    s.kind = Kind::all;
  } else if (text == "last") {
    s.kind = Kind::last;
  } else if (text == "rest") {
    s.kind = Kind::rest;
  } else {
    s.kind = Kind::range;
    const std::size_t colon = text.find(':');
    const bool ok = colon == std::string::npos
                        ? parse_index(text, s.first) && parse_index(text, s.last)
                        : parse_index(text.substr(0, colon), s.first) &&
                              parse_index(text.substr(colon + 1), s.last);
    require(ok, "--frames '" + text +
                    "': expected all, last, rest, a state number K or a range A:B (state 0 is "
                    "the rest mesh, 1..N the saved frames)");
    require(s.first <= s.last, "--frames '" + text + "': range start after its end");
  }
  return s;
}

std::vector<std::size_t> FrameSelection::states(std::size_t state_count) const {
  require(state_count > 0, "the mesh sequence has no states");
  std::vector<std::size_t> out;
  switch (kind) {
    case Kind::all:
      for (std::size_t k = 0; k < state_count; ++k) out.push_back(k);
      break;
    case Kind::last:
      out.push_back(state_count - 1);
      break;
    case Kind::rest:
      out.push_back(0);
      break;
    case Kind::range:
      require(last < state_count, "--frames " + describe() + ": the input has states 0.." +
                                      std::to_string(state_count - 1) +
                                      " (0 = rest mesh, then one per saved frame)");
      for (std::size_t k = first; k <= last; ++k) out.push_back(k);
      break;
  }
  return out;
}

std::string FrameSelection::describe() const {
  switch (kind) {
    case Kind::all:
      return "all";
    case Kind::last:
      return "last";
    case Kind::rest:
      return "rest";
    case Kind::range:
      return first == last ? std::to_string(first)
                           : std::to_string(first) + ":" + std::to_string(last);
  }
  return "?";
}

}  // namespace tsf::exporter

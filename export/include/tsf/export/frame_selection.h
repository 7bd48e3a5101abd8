// Which states of a mesh sequence to export (--frames).
//
// States are numbered 0..N: state 0 is the rest mesh, state k (1..N) the k-th saved frame.
//   all     every state, 0..N
//   last    state N (the final deformed, cut mesh; the rest mesh when nothing moved)
//   rest    state 0
//   K       state K
//   A:B     states A to B inclusive (A <= B)
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace tsf::exporter {

struct FrameSelection {
  enum class Kind { all, last, rest, range };
  Kind kind = Kind::last;
  std::size_t first = 0, last = 0;  ///< for Kind::range (a single state has first == last)

  /// Parses an --frames value; throws tsf::Error naming the value and the accepted forms.
  static FrameSelection parse(const std::string& text);
  /// The selected state numbers for a sequence of `state_count` states (rest + frames), in
  /// order. Throws tsf::Error when a state named does not exist.
  std::vector<std::size_t> states(std::size_t state_count) const;
  std::string describe() const;
};

}  // namespace tsf::exporter

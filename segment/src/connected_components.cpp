#include "tsf/segment/connected_components.h"

namespace tsf::segment {

std::uint32_t ComponentLabels::largest() const {
  std::uint32_t best = 0;
  for (std::size_t c = 1; c < sizes.size(); ++c)
    if (sizes[c] > (best ? sizes[best] : 0)) best = static_cast<std::uint32_t>(c);
  return best;
}

ComponentLabels label_connected_components(const unsigned char* mask,
                                           const std::array<std::size_t, 3>& dims,
                                           bool full_connectivity) {
  const long nx = static_cast<long>(dims[0]), ny = static_cast<long>(dims[1]),
             nz = static_cast<long>(dims[2]);
  const std::size_t n = dims[0] * dims[1] * dims[2];
  ComponentLabels out;
  out.labels.assign(n, 0);
  out.sizes.assign(1, 0);

  // Neighbour offsets (di, dj, dk): the 6 faces, or all 26.
  std::vector<std::array<long, 3>> offsets;
  for (long dk = -1; dk <= 1; ++dk)
    for (long dj = -1; dj <= 1; ++dj)
      for (long di = -1; di <= 1; ++di) {
        const long manhattan = (di != 0) + (dj != 0) + (dk != 0);
        if (manhattan == 0 || (!full_connectivity && manhattan > 1)) continue;
        offsets.push_back({di, dj, dk});
      }

  std::vector<std::size_t> stack;
  for (std::size_t seed = 0; seed < n; ++seed) {
    if (!mask[seed] || out.labels[seed]) continue;
    const auto label = static_cast<std::uint32_t>(out.sizes.size());
    std::size_t size = 0;
    out.labels[seed] = label;
    stack.push_back(seed);
    while (!stack.empty()) {
      const std::size_t v = stack.back();
      stack.pop_back();
      ++size;
      const long i = static_cast<long>(v % dims[0]);
      const long j = static_cast<long>((v / dims[0]) % dims[1]);
      const long k = static_cast<long>(v / (dims[0] * dims[1]));
      for (const auto& o : offsets) {
        const long a = i + o[0], b = j + o[1], c = k + o[2];
        if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz) continue;
        const std::size_t w = static_cast<std::size_t>(a + nx * (b + ny * c));
        if (mask[w] && !out.labels[w]) {
          out.labels[w] = label;
          stack.push_back(w);
        }
      }
    }
    out.sizes.push_back(size);
  }
  return out;
}

}  // namespace tsf::segment

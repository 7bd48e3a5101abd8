#include "tsf/export/surface_deviation.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"

namespace tsf::exporter {

namespace {

using Tri = std::array<std::uint32_t, 3>;

struct Box {
  Vec3f lo{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
           std::numeric_limits<float>::max()};
  Vec3f hi{std::numeric_limits<float>::lowest(), std::numeric_limits<float>::lowest(),
           std::numeric_limits<float>::lowest()};
  void add(const Vec3f& p) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  float distance2(const Vec3f& p) const {
    const float dx = std::max({lo.x - p.x, 0.0f, p.x - hi.x});
    const float dy = std::max({lo.y - p.y, 0.0f, p.y - hi.y});
    const float dz = std::max({lo.z - p.z, 0.0f, p.z - hi.z});
    return dx * dx + dy * dy + dz * dz;
  }
};

struct Node {
  Box box;
  std::uint32_t first = 0;  ///< leaf: first triangle in `order`; inner: left child (right = +1)
  std::uint32_t count = 0;  ///< leaf: triangles; inner: 0
};

/// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection §5.1.5).
Vec3f closest_on_triangle(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3f ab = b - a, ac = c - a, ap = p - a;
  const float d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0.0f && d2 <= 0.0f) return a;
  const Vec3f bp = p - b;
  const float d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0.0f && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) return a + ab * (d1 / (d1 - d3));
  const Vec3f cp = p - c;
  const float d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0.0f && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) return a + ac * (d2 / (d2 - d6));
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f)
    return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const float denom = 1.0f / (va + vb + vc);
  if (!std::isfinite(denom)) return a;  // no area: a corner is as good as any point
  return a + ab * (vb * denom) + ac * (vc * denom);
}

class Bvh {
 public:
  explicit Bvh(const TriangleSet& s) : p_(*s.positions), t_(*s.triangles) {
    const std::size_t n = t_.size();
    order_.resize(n);
    centre_.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      order_[i] = i;
      const Tri& t = t_[i];
      centre_[i] = (p_[t[0]] + p_[t[1]] + p_[t[2]]) * (1.0f / 3.0f);
    }
    nodes_.reserve(2 * n / kLeaf + 2);
    nodes_.emplace_back();
    build(0, 0, static_cast<std::uint32_t>(n));
  }

  double distance(const Vec3f& q) const {
    float best = std::numeric_limits<float>::max();
    std::uint32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& n = nodes_[stack[--top]];
      if (n.box.distance2(q) >= best) continue;
      if (n.count > 0) {
        for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
          const Tri& t = t_[order_[i]];
          const Vec3f c = closest_on_triangle(q, p_[t[0]], p_[t[1]], p_[t[2]]);
          best = std::min(best, length_squared(c - q));
        }
        continue;
      }
      const float dl = nodes_[n.first].box.distance2(q), dr = nodes_[n.first + 1].box.distance2(q);
      // Nearer child last, so it is popped first.
      if (top + 2 > 128) continue;  // deeper than any balanced tree of 2^64 triangles
      if (dl < dr) {
        stack[top++] = n.first + 1;
        stack[top++] = n.first;
      } else {
        stack[top++] = n.first;
        stack[top++] = n.first + 1;
      }
    }
    return std::sqrt(static_cast<double>(best));
  }

 private:
  static constexpr std::uint32_t kLeaf = 4;

  void build(std::uint32_t node, std::uint32_t begin, std::uint32_t end) {
    Box box, centres;
    for (std::uint32_t i = begin; i < end; ++i) {
      const Tri& t = t_[order_[i]];
      for (std::uint32_t v : t) box.add(p_[v]);
      centres.add(centre_[order_[i]]);
    }
    nodes_[node].box = box;
    if (end - begin <= kLeaf) {
      nodes_[node].first = begin;
      nodes_[node].count = end - begin;
      return;
    }
    const Vec3f extent = centres.hi - centres.lo;
    const int axis =
        extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
    const std::uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(
        order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
        [&](std::uint32_t a, std::uint32_t b) { return centre_[a][axis] < centre_[b][axis]; });
    const auto left = static_cast<std::uint32_t>(nodes_.size());
    nodes_.emplace_back();
    nodes_.emplace_back();
    nodes_[node].first = left;
    nodes_[node].count = 0;
    build(left, begin, mid);
    build(left + 1, mid, end);
  }

  const std::vector<Vec3f>& p_;
  const std::vector<Tri>& t_;
  std::vector<std::uint32_t> order_;
  std::vector<Vec3f> centre_;
  std::vector<Node> nodes_;
};

void require_surface(const TriangleSet& s, const char* what) {
  require(s.positions && s.triangles && !s.triangles->empty(),
          std::string("surface deviation: the ") + what + " surface has no triangles");
}

}  // namespace

std::vector<double> distances_to_surface(const TriangleSet& surface,
                                         const std::vector<Vec3f>& points) {
  require_surface(surface, "reference");
  const Bvh bvh(surface);
  std::vector<double> d(points.size());
  const auto n = static_cast<std::int64_t>(points.size());
#pragma omp parallel for schedule(dynamic, 4096)
  for (std::int64_t i = 0; i < n; ++i)
    d[static_cast<std::size_t>(i)] = bvh.distance(points[static_cast<std::size_t>(i)]);
  return d;
}

SurfaceDeviation measure_deviation(const TriangleSet& full, const TriangleSet& simplified) {
  require_surface(full, "full");
  require_surface(simplified, "simplified");
  Stopwatch clock;
  SurfaceDeviation r;
  // Simplified -> full: 7 points per triangle, each standing for a seventh of its area.
  {
    const Bvh bvh(full);
    const auto& p = *simplified.positions;
    const auto& tris = *simplified.triangles;
    const auto n = static_cast<std::int64_t>(tris.size());
    double sum = 0, weight = 0, worst = 0;
#pragma omp parallel for schedule(dynamic, 1024) reduction(+ : sum, weight) reduction(max : worst)
    for (std::int64_t i = 0; i < n; ++i) {
      const Tri& t = tris[static_cast<std::size_t>(i)];
      const Vec3f a = p[t[0]], b = p[t[1]], c = p[t[2]];
      const double area =
          0.5 * length(cross(to_double(b) - to_double(a), to_double(c) - to_double(a)));
      const Vec3f samples[7] = {(a + b + c) * (1.0f / 3.0f),
                                (a + b) * 0.5f,
                                (b + c) * 0.5f,
                                (c + a) * 0.5f,
                                a * (2.0f / 3.0f) + (b + c) * (1.0f / 6.0f),
                                b * (2.0f / 3.0f) + (a + c) * (1.0f / 6.0f),
                                c * (2.0f / 3.0f) + (a + b) * (1.0f / 6.0f)};
      for (const Vec3f& s : samples) {
        const double d = bvh.distance(s);
        sum += d * area / 7.0;
        weight += area / 7.0;
        worst = std::max(worst, d);
      }
    }
    r.to_full_samples = 7 * tris.size();
    r.to_full_mean_mm = weight > 0 ? sum / weight : 0.0;
    r.to_full_max_mm = worst;
  }
  // Full -> simplified: every vertex the full surface's triangles use.
  {
    const auto& p = *full.positions;
    std::vector<char> used(p.size(), 0);
    for (const Tri& t : *full.triangles)
      for (std::uint32_t v : t) used[v] = 1;
    std::vector<Vec3f> points;
    for (std::size_t v = 0; v < p.size(); ++v)
      if (used[v]) points.push_back(p[v]);
    const std::vector<double> d = distances_to_surface(simplified, points);
    double sum = 0, worst = 0;
    for (double x : d) {
      sum += x;
      worst = std::max(worst, x);
    }
    r.from_full_samples = d.size();
    r.from_full_mean_mm = d.empty() ? 0.0 : sum / static_cast<double>(d.size());
    r.from_full_max_mm = worst;
  }
  r.seconds = clock.seconds();
  return r;
}

}  // namespace tsf::exporter

#include "tsf/interaction/body_field.h"

#include <algorithm>
#include <cmath>

#include "tsf/common/error.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf::interaction {

BodyField::BodyField(const TissueModel& body, double spacing_mm) : spacing_mm_(spacing_mm) {
  require(std::isfinite(spacing_mm) && spacing_mm > 0,
          "body contact: the grid spacing must be > 0 mm, got " + std::to_string(spacing_mm));
  build_grid(body);
  follow(body);
}

void BodyField::build_grid(const TissueModel& body) {
  const imt::SurfaceMesh rest = body.surface().compact();
  try {
    grid_ = std::make_shared<collision::SignedDistanceGrid>(
        collision::SignedDistanceGrid::from_closed_mesh(rest.positions, rest.triangles,
                                                        spacing_mm_, 2.0 * spacing_mm_));
  } catch (const Error& e) {
    throw Error(std::string("body contact: the pushing tissue's surface: ") + e.what());
  }
  edits_seen_ = body.totals().edits;
}

void BodyField::follow(const TissueModel& body) {
  if (body.totals().edits != edits_seen_) build_grid(body);
  const crms::Lattice& lattice = body.solver().lattice();
  const crms::LatticeGeometry& g = lattice.geometry();
  const std::vector<Vec3f> positions = body.solver().positions();
  const auto n = static_cast<std::size_t>(g.node_count());
  displacement_.resize(n);
  alive_.resize(n);
  max_displacement_ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto node = static_cast<std::int64_t>(i);
    alive_[i] = lattice.alive(node) ? 1 : 0;
    displacement_[i] = alive_[i] ? positions[i] - to_float(g.rest_position(node)) : Vec3f{0, 0, 0};
    if (alive_[i]) max_displacement_ = std::max(max_displacement_, double(length(displacement_[i])));
  }
  // Carry the motion kDilation node layers beyond the body (each empty node takes the mean of
  // its filled face neighbours): a point just outside the body is mapped with the body's motion,
  // not at rest, so a body that moves pushes what lies against it.
  std::vector<std::uint8_t> filled = alive_;
  std::vector<Vec3f> next = displacement_;
  for (int layer = 0; layer < kDilation; ++layer) {
    std::vector<std::uint8_t> grown = filled;
    for (int k = 0; k < g.dims.z; ++k)
      for (int j = 0; j < g.dims.y; ++j)
        for (int i = 0; i < g.dims.x; ++i) {
          const std::size_t at = static_cast<std::size_t>(g.index(i, j, k));
          if (filled[at]) continue;
          Vec3f sum{0, 0, 0};
          int count = 0;
          const int nb[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
          for (const auto& d : nb) {
            const int a = i + d[0], b = j + d[1], c = k + d[2];
            if (!g.contains(a, b, c)) continue;
            const std::size_t o = static_cast<std::size_t>(g.index(a, b, c));
            if (!filled[o]) continue;
            sum += displacement_[o];
            ++count;
          }
          if (count == 0) continue;
          next[at] = sum / static_cast<float>(count);
          grown[at] = 1;
        }
    filled.swap(grown);
    displacement_ = next;
  }
  alive_.swap(filled);
  view_.displacement = displacement_.data();
  view_.alive = alive_.data();
  view_.dims = g.dims;
  view_.origin = g.origin;
  view_.spacing = g.spacing;
}

void BodyField::set_rest_allowance(const crms::Lattice& pushed) {
  const crms::LatticeGeometry& g = pushed.geometry();
  allowance_.assign(static_cast<std::size_t>(g.node_count()), 0.0f);
  overlapping_ = 0;
  for (std::int64_t n = 0; n < g.node_count(); ++n) {
    if (!pushed.alive(n)) continue;
    Vec3d normal;
    const double d = distance(g.rest_position(n), normal);
    if (d < 0) {
      allowance_[static_cast<std::size_t>(n)] = static_cast<float>(d);
      ++overlapping_;
    }
  }
}

double BodyField::distance(const Vec3d& p, Vec3d& normal) const {
  const coupler::LocalWarp warp = coupler::inverse_warp(view_, p);
  Vec3d n_rest;
  const double d = grid_->distance(warp.rest_centre, n_rest);
  // A rest normal is a covector: it maps to the world by F⁻ᵀ.
  const double* Fi = warp.F_inv;
  const Vec3d n{Fi[0] * n_rest.x + Fi[3] * n_rest.y + Fi[6] * n_rest.z,
                Fi[1] * n_rest.x + Fi[4] * n_rest.y + Fi[7] * n_rest.z,
                Fi[2] * n_rest.x + Fi[5] * n_rest.y + Fi[8] * n_rest.z};
  const double len = length(n);
  normal = len > 1e-12 ? n / len : n_rest;
  return d;
}

void BodyField::bounds(Vec3d& lo, Vec3d& hi) const {
  const Vec3d m{max_displacement_, max_displacement_, max_displacement_};
  lo = grid_->lo() - m;
  hi = grid_->hi() + m;
}

}  // namespace tsf::interaction

#include "tsf/imt/imt_surface.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "imt_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/volume_edits.h"

namespace tsf::imt {
namespace {

/// The surface as lattice keys: sorted triangles of key triples (rotated, orientation kept) and
/// per-key position, label and normal.
struct KeyedSurface {
  std::vector<std::array<std::uint64_t, 3>> triangles;
  std::map<std::uint64_t, std::tuple<Vec3f, std::uint8_t, Vec3f>> vertices;
};

KeyedSurface keyed(const ImtSurface& s) {
  KeyedSurface k;
  for (std::uint32_t t = 0; t < s.triangle_slot_count(); ++t) {
    if (!s.triangle_live(t)) continue;
    std::array<std::uint64_t, 3> tri{};
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t v = s.triangles()[t][static_cast<std::size_t>(i)];
      tri[static_cast<std::size_t>(i)] = s.vertex_key(v);
      k.vertices[s.vertex_key(v)] = {s.positions()[v], s.labels()[v], s.normals()[v]};
    }
    std::rotate(tri.begin(), std::min_element(tri.begin(), tri.end()), tri.end());
    k.triangles.push_back(tri);
  }
  std::sort(k.triangles.begin(), k.triangles.end());
  return k;
}

void expect_same_surface(const KeyedSurface& a, const KeyedSurface& b, const std::string& when) {
  ASSERT_EQ(a.triangles.size(), b.triangles.size()) << when;
  ASSERT_EQ(a.vertices.size(), b.vertices.size()) << when;
  EXPECT_TRUE(a.triangles == b.triangles) << when << ": triangles differ";
  std::size_t differ = 0;
  for (const auto& [key, attrs] : a.vertices) {
    const auto it = b.vertices.find(key);
    if (it == b.vertices.end() || !(std::get<0>(it->second) == std::get<0>(attrs)) ||
        std::get<1>(it->second) != std::get<1>(attrs) ||
        !(std::get<2>(it->second) == std::get<2>(attrs)))
      ++differ;
  }
  EXPECT_EQ(differ, 0u) << when << ": vertices differ in position, label or normal";
}

/// What a viewer keeps: copies of the buffers patched only through the change lists.
struct MirroredBuffers {
  std::vector<Vec3f> positions, normals;
  std::vector<std::uint8_t> labels;
  std::vector<std::array<std::uint32_t, 3>> triangles;

  void apply(const ImtSurface& s, const SurfaceChanges& c) {
    if (c.reallocated) {
      positions = s.positions();
      normals = s.normals();
      labels = s.labels();
      triangles = s.triangles();
      return;
    }
    for (const auto* list : {&c.vertices_added, &c.vertices_modified, &c.vertices_normal_changed})
      for (std::uint32_t v : *list) {
        positions[v] = s.positions()[v];
        normals[v] = s.normals()[v];
        labels[v] = s.labels()[v];
      }
    for (std::uint32_t t : c.triangles_added) triangles[t] = s.triangles()[t];
    for (std::uint32_t t : c.triangles_freed) triangles[t] = {0, 0, 0};
  }
  /// Every live triangle and live vertex the surface has, the mirror has identically.
  void expect_matches(const ImtSurface& s, const std::string& when) const {
    std::size_t bad_triangles = 0, bad_vertices = 0;
    for (std::uint32_t t = 0; t < s.triangle_slot_count(); ++t)
      if (triangles[t] != s.triangles()[t]) ++bad_triangles;
    for (std::uint32_t v = 1; v < s.vertex_slot_count(); ++v)
      if (s.vertex_live(v) && (!(positions[v] == s.positions()[v]) ||
                               !(normals[v] == s.normals()[v]) || labels[v] != s.labels()[v]))
        ++bad_vertices;
    EXPECT_EQ(bad_triangles, 0u) << when;
    EXPECT_EQ(bad_vertices, 0u) << when;
  }
};

VoxelVolume test_volume(unsigned seed) {
  VolumeGeometry g;
  g.dims = {36, 34, 30};
  g.spacing = {0.9, 1.0, 1.2};  // anisotropic on purpose
  g.origin = {-12.0, 3.0, 40.0};
  return make_blob_volume(g, seed, 6, 1.2);
}

/// One random edit of each kind in turn, tools in tissue space.
VoxelBox random_edit(VoxelVolume& v, std::mt19937& rng, int i) {
  const auto& g = v.geometry();
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto point = [&] {
    return g.index_to_tissue({u(rng) * g.dims.x, u(rng) * g.dims.y, u(rng) * g.dims.z});
  };
  RemovalOptions o;
  o.strength = static_cast<float>(0.3 + 0.7 * u(rng));
  o.rates = LabelRates::tissue_defaults();
  switch (i % 4) {
    case 0:
      return ablate_sphere(v, {point(), 0.8 + 4.0 * u(rng)}, o);
    case 1: {
      const Vec3d a = point();
      const Vec3d b = a + Vec3d{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5} * 10.0;
      return ablate_capsule(v, {a, b, 0.7 + 2.0 * u(rng)}, o);
    }
    case 2: {
      const BladeTool blade{{2.0 + 5.0 * u(rng), 1.5 + 3.0 * u(rng), 0.3 + 0.5 * u(rng)}};
      const Vec3d axis{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5};
      const ToolPose from{point(), Rotation::about_axis(axis, 3.0 * u(rng))};
      const ToolPose to{
          from.position + Vec3d{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5} * 8.0,
          Rotation::slerp(from.orientation, Rotation::about_axis({u(rng), u(rng), 1.0}, 0.5), 0.5)};
      return cut_swept_blade(v, blade, from, to, o);
    }
    default: {
      const Vec3d lo = point();
      const Vec3d hi = lo + Vec3d{u(rng), u(rng), u(rng)} * 6.0;
      const bool add = u(rng) < 0.5;
      const float density = add ? 1.0f : static_cast<float>(u(rng));
      return set_box(v, lo, hi, density,
                     add ? std::optional<std::uint8_t>(kLabelMucosa + (i % 3)) : std::nullopt);
    }
  }
}

void run_random_edits(float eps, int edits, int check_every, unsigned seed, float iso = 0.5f) {
  VoxelVolume volume = test_volume(seed);
  SurfaceOptions options;
  options.snap_epsilon = eps;
  options.iso = iso;
  ImtSurface surface(options);
  surface.build(volume);
  MirroredBuffers mirror;
  mirror.apply(surface, surface.take_changes());
  std::mt19937 rng(seed * 7919u + 13u);
  std::size_t nonempty = 0;
  for (int i = 1; i <= edits; ++i) {
    const VoxelBox changed = random_edit(volume, rng, i);
    nonempty += !changed.empty();
    surface.update(volume, changed);
    mirror.apply(surface, surface.take_changes());
    if (i % check_every != 0) continue;
    const std::string when = "eps " + std::to_string(eps) + " after edit " + std::to_string(i);
    ASSERT_NO_THROW(surface.check_invariants()) << when;
    mirror.expect_matches(surface, when);
    ImtSurface fresh(options);
    fresh.build(volume);
    expect_same_surface(keyed(surface), keyed(fresh), when);
    test::expect_closed_manifold(surface.compact(), when);
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_GT(nonempty, static_cast<std::size_t>(edits) / 2) << "most edits should change voxels";
}

TEST(ImtSurfaceRobustness, IncrementalEqualsFullAfter1000RandomEditsWithoutMerging) {
  run_random_edits(0.0f, 1000, 100, 1);
}

TEST(ImtSurfaceRobustness, IncrementalEqualsFullAfter1000RandomEditsWithMerging) {
  run_random_edits(0.1f, 1000, 100, 2);
}

TEST(ImtSurfaceRobustness, IncrementalEqualsFullAtAnotherIsoLevel) {
  run_random_edits(0.15f, 300, 100, 3, 0.35f);
}

TEST(ImtSurface, BuildMatchesExtractSurface) {
  const VoxelVolume volume = test_volume(3);
  ImtSurface s;
  s.build(volume);
  const SurfaceMesh a = s.compact();
  const SurfaceMesh b = extract_surface(volume);
  EXPECT_EQ(test::canonical_triangles(a), test::canonical_triangles(b));
  EXPECT_EQ(s.live_vertex_count(), b.vertex_count());
  EXPECT_EQ(s.live_triangle_count(), b.triangle_count());
  s.check_invariants();
}

TEST(ImtSurface, FreedTrianglesCollapseOntoTheSentinelAndSlotsAreReused) {
  VoxelVolume volume = make_sdf_volume(
      cube_geometry({32, 32, 32}),
      [](const Vec3d& p) {
        return length(p - Vec3d{16, 16, 16}) - 10;
      },
      1.5);
  ImtSurface s;
  s.build(volume);
  s.take_changes();
  const std::uint32_t slots_before = s.triangle_slot_count();
  const VoxelBox changed = ablate_sphere(volume, {{16, 16, 26}, 4.0});
  ASSERT_FALSE(changed.empty());
  s.update(volume, changed);
  const SurfaceChanges c = s.take_changes();
  EXPECT_FALSE(c.reallocated);
  EXPECT_FALSE(c.triangles_added.empty());
  EXPECT_FALSE(c.vertices_added.empty());
  for (std::uint32_t t : c.triangles_freed) {
    EXPECT_EQ(s.triangles()[t][0], ImtSurface::kSentinelVertex);
    EXPECT_EQ(s.triangles()[t][1], ImtSurface::kSentinelVertex);
    EXPECT_EQ(s.triangles()[t][2], ImtSurface::kSentinelVertex);
  }
  // Released slots are reused before new ones are taken: the crater needs more triangles than
  // the cap it replaced, so the slot count grows by at most the difference.
  const std::size_t live_growth =
      s.live_triangle_count() > 0 ? s.triangle_slot_count() - slots_before : 0;
  EXPECT_LE(live_growth, c.triangles_added.size());
  for (std::uint32_t v : c.vertices_freed) EXPECT_FALSE(s.vertex_live(v));
  s.check_invariants();
  test::expect_closed_manifold(s.compact(), "after ablation");
}

TEST(ImtSurface, VerticesAwayFromAnEditKeepTheirSlots) {
  VoxelVolume volume = make_sdf_volume(
      cube_geometry({40, 40, 40}),
      [](const Vec3d& p) {
        return length(p - Vec3d{20, 20, 20}) - 14;
      },
      1.5);
  ImtSurface s;
  s.build(volume);
  s.take_changes();
  std::map<std::uint64_t, std::uint32_t> slot_of;
  for (std::uint32_t v = 1; v < s.vertex_slot_count(); ++v)
    if (s.vertex_live(v)) slot_of[s.vertex_key(v)] = v;
  const VoxelBox changed = ablate_sphere(volume, {{20, 20, 34}, 3.0});
  s.update(volume, changed);
  const SurfaceChanges c = s.take_changes();
  std::size_t kept = 0, far = 0;
  for (std::uint32_t v = 1; v < s.vertex_slot_count(); ++v) {
    if (!s.vertex_live(v)) continue;
    const Vec3f p = s.positions()[v];
    if (p.z > 25.0f) continue;  // near the edit
    ++far;
    const auto it = slot_of.find(s.vertex_key(v));
    if (it != slot_of.end() && it->second == v) ++kept;
  }
  EXPECT_GT(far, 100u);
  EXPECT_EQ(kept, far) << "vertices far from the edit must keep their ids";
  EXPECT_LT(c.vertices_added.size() + c.vertices_modified.size(), s.live_vertex_count() / 4);
}

TEST(ImtSurface, BuffersGrowAndSayWhenHeadroomRunsOut) {
  VoxelVolume volume = make_sdf_volume(
      cube_geometry({32, 32, 32}),
      [](const Vec3d& p) {
        return length(p - Vec3d{16, 16, 16}) - 6;
      },
      1.5);
  ImtSurface s(SurfaceOptions{}, 0.0);
  s.build(volume);
  s.take_changes();
  const std::uint32_t capacity = s.triangle_capacity();
  // Add far more surface than the headroom allows: many separate small boxes.
  VoxelBox changed{};
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i)
        changed = changed.united(set_box(volume, {2.0 + 7 * i, 2.0 + 7 * j, 2.0 + 7 * k},
                                         {4.0 + 7 * i, 4.0 + 7 * j, 4.0 + 7 * k}, 1.0f));
  s.update(volume, changed);
  const SurfaceChanges c = s.take_changes();
  EXPECT_GT(s.triangle_capacity(), capacity);
  EXPECT_TRUE(c.reallocated);
  s.check_invariants();
}

TEST(ImtSurface, RejectsAVolumeOfOtherDimensions) {
  const VoxelVolume a = make_sdf_volume(
      cube_geometry({16, 16, 16}), [](const Vec3d& p) { return length(p) - 5; }, 1.0);
  const VoxelVolume b = make_sdf_volume(
      cube_geometry({16, 16, 17}), [](const Vec3d& p) { return length(p) - 5; }, 1.0);
  ImtSurface s;
  s.build(a);
  EXPECT_THROW(s.update(b, VoxelBox::of_dims(b.dims())), Error);
  ImtSurface unbuilt;
  EXPECT_THROW(unbuilt.update(a, VoxelBox::of_dims(a.dims())), Error);
}

/// Large edits (regions of many 32-cube chunks) on two surfaces, one updated on one thread (each
/// batch of chunks is a single chunk, its cubes planned as they are meshed in the serial order)
/// and one on four (batches of four chunks whose windows, vertex tables and refresh plans are made
/// ahead on the threads before the serial pass): the same slots, buffers and change lists after
/// every edit, bit for bit.
void expect_threads_agree(float eps) {
  VolumeGeometry g;
  g.dims = {104, 96, 84};
  g.spacing = {0.9, 1.0, 1.2};
  g.origin = {-40.0, 3.0, 40.0};
  VoxelVolume volume = make_blob_volume(g, 11, 14, 1.2);
  SurfaceOptions options;
  options.snap_epsilon = eps;
  const int before = omp_get_max_threads();
  ImtSurface one(options), four(options);
  one.build(volume);
  four.build(volume);
  (void)one.take_changes();
  (void)four.take_changes();
  std::mt19937 rng(97);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto point = [&] {
    return g.index_to_tissue({u(rng) * g.dims.x, u(rng) * g.dims.y, u(rng) * g.dims.z});
  };
  std::size_t ahead = 0;
  for (int i = 0; i < 24; ++i) {
    VoxelBox changed;
    RemovalOptions o;
    o.strength = 1.0f;
    if (i % 3 == 0) {
      const BladeTool blade{{20.0, 18.0, 0.6}};
      const ToolPose from{point(), Rotation::about_axis({u(rng), u(rng), 1.0}, 3.0 * u(rng))};
      const ToolPose to{from.position + Vec3d{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5} * 40.0,
                        from.orientation};
      changed = cut_swept_blade(volume, blade, from, to, o);
    } else if (i % 3 == 1) {
      changed = ablate_sphere(volume, {point(), 12.0 + 10.0 * u(rng)}, o);
    } else {
      const Vec3d lo = point();
      const bool add = i % 2 == 0;
      changed =
          set_box(volume, lo, lo + Vec3d{30 + 30 * u(rng), 30 + 30 * u(rng), 8}, add ? 1.0f : 0.0f,
                  add ? std::optional<std::uint8_t>(kLabelMucosa) : std::nullopt);
    }
    const std::string when = "eps " + std::to_string(eps) + ", edit " + std::to_string(i);
    omp_set_num_threads(1);
    const SurfaceUpdateStats s1 = one.update(volume, changed);
    omp_set_num_threads(4);
    const SurfaceUpdateStats s4 = four.update(volume, changed);
    omp_set_num_threads(before);
    EXPECT_EQ(s1.chunks_ahead, 0u) << when;
    ahead += s4.chunks_ahead;
    const SurfaceChanges c1 = one.take_changes(), c4 = four.take_changes();
    ASSERT_EQ(one.vertex_slot_count(), four.vertex_slot_count()) << when;
    ASSERT_EQ(one.triangle_slot_count(), four.triangle_slot_count()) << when;
    EXPECT_TRUE(c1.vertices_added == c4.vertices_added && c1.vertices_freed == c4.vertices_freed &&
                c1.vertices_modified == c4.vertices_modified &&
                c1.vertices_normal_changed == c4.vertices_normal_changed &&
                c1.triangles_added == c4.triangles_added &&
                c1.triangles_freed == c4.triangles_freed && c1.reallocated == c4.reallocated)
        << when << ": the change lists differ";
    std::size_t differ = 0;
    for (std::uint32_t v = 0; v < one.vertex_slot_count(); ++v)
      if (one.vertex_live(v) != four.vertex_live(v) ||
          (one.vertex_live(v) &&
           (!(one.positions()[v] == four.positions()[v]) ||
            !(one.normals()[v] == four.normals()[v]) || one.labels()[v] != four.labels()[v] ||
            one.vertex_key(v) != four.vertex_key(v))))
        ++differ;
    for (std::uint32_t t = 0; t < one.triangle_slot_count(); ++t)
      if (one.triangles()[t] != four.triangles()[t]) ++differ;
    ASSERT_EQ(differ, 0u) << when << ": slots differ";
  }
  ASSERT_NO_THROW(four.check_invariants());
  // The four-thread surface must have taken the path under test, and often.
  EXPECT_GE(ahead, 16u);
}

TEST(ImtSurfaceThreads, LargeEditsGiveTheSameSlotsOnOneAndFourThreadsWithoutMerging) {
  expect_threads_agree(0.0f);
}

TEST(ImtSurfaceThreads, LargeEditsGiveTheSameSlotsOnOneAndFourThreadsWithMerging) {
  expect_threads_agree(0.1f);
}

}  // namespace
}  // namespace tsf::imt

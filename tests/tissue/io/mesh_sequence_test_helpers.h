// Small sequences for the mesh sequence tests: a labelled sphere surface that breathes, then is
// "cut" (a new topology), with a non-trivial volume geometry.
#pragma once

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "tsf/imt/extract_surface.h"
#include "tsf/io/mesh_sequence.h"
#include "tsf/volume/analytic_volumes.h"

namespace tsf::io::test {

inline VolumeGeometry oblique_geometry() {
  VolumeGeometry g = cube_geometry({16, 16, 16}, 0.75);
  g.origin = {-12.5, 30.25, -101.0};
  // A rotation about z by 30 degrees: columns are the i, j, k axes in LPS.
  const double c = std::sqrt(3.0) / 2.0, s = 0.5;
  g.direction = {c, -s, 0, s, c, 0, 0, 0, 1};
  return g;
}

/// A sphere surface in tissue space with two labels (upper half mucosa).
inline imt::SurfaceMesh labelled_sphere(const VolumeGeometry& g, double radius) {
  const Vec3d centre = g.index_to_tissue({7.5, 7.5, 7.5});
  const VoxelVolume volume = make_sdf_volume(
      g, [&](const Vec3d& p) { return length(p - centre) - radius; }, 1.0);
  imt::SurfaceMesh mesh = imt::extract_surface(volume);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v)
    mesh.labels[v] =
        static_cast<double>(mesh.positions[v].z) > centre.z ? kLabelMucosa : kLabelSoftTissue;
  return mesh;
}

/// A tetrahedron at rest, one pose, one re-mesh to a single triangle (a few hundred bytes).
inline MeshSequence tiny_sequence() {
  MeshSequence s;
  s.geometry = oblique_geometry();
  s.rest.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  s.rest.normals = {{-0.577f, -0.577f, -0.577f}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  s.rest.labels = {1, 1, 2, 3};
  s.rest.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  MeshFrame pose;
  pose.time_s = 0.1;
  pose.positions = {{0, 0, 0}, {1.1f, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  s.frames.push_back(pose);
  MeshFrame cut;
  cut.time_s = 0.2;
  cut.topology_changed = true;
  cut.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  cut.labels = {1, 1, 1};
  cut.triangles = {{0, 1, 2}};
  s.frames.push_back(cut);
  return s;
}

/// rest, three poses (scaled about the first vertex), one cut (smaller sphere), one more pose.
inline MeshSequence small_sequence() {
  MeshSequence s;
  s.geometry = oblique_geometry();
  s.rest_time_s = 0.0;
  s.rest = labelled_sphere(s.geometry, 4.0);
  for (int f = 1; f <= 3; ++f) {
    MeshFrame frame;
    frame.time_s = 0.01 * f;
    const float k = 1.0f + 0.02f * static_cast<float>(f);
    for (const Vec3f& p : s.rest.positions)
      frame.positions.push_back(s.rest.positions[0] + (p - s.rest.positions[0]) * k);
    frame.normals = s.rest.normals;
    s.frames.push_back(frame);
  }
  const imt::SurfaceMesh cut = labelled_sphere(s.geometry, 3.0);
  MeshFrame remeshed;
  remeshed.time_s = 0.04;
  remeshed.topology_changed = true;
  remeshed.positions = cut.positions;
  remeshed.normals = cut.normals;
  remeshed.labels = cut.labels;
  remeshed.triangles = cut.triangles;
  s.frames.push_back(remeshed);
  MeshFrame after;
  after.time_s = 0.05;
  for (const Vec3f& p : cut.positions) after.positions.push_back(p + Vec3f{0.1f, 0.0f, -0.2f});
  s.frames.push_back(after);  // no normals in this one
  return s;
}

inline std::string read_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline void write_bytes(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace tsf::io::test

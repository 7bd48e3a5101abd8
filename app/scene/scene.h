// The tsf scene model (start of the project's scene format; issue 10 grows it) and its strict
// YAML reader. A scene says what tissue to build, how to simulate it and for how long.
//
// Every key is checked: an unknown key, a wrong type or an out-of-range value is an error naming
// the file and the key path (`beam.yaml: lattice.spacing: expected a number > 0, got -1`).
// Schema and examples: docs/crms.md ("Scenes"), scenes/*.yaml.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/solver_config.h"

namespace tsf::app {

struct SceneLattice {
  enum class Source { kBox, kVolume };
  Source source = Source::kBox;
  // box
  Vec3d size_mm{10, 10, 10};
  double spacing_mm = 1.0;
  Vec3d min_corner_mm{0, 0, 0};
  // volume (PREFIX-density.nrrd written by tsf segment / import)
  std::filesystem::path volume;
  int node_spacing_voxels = 2;
  double occupancy_threshold = 0.125;
  double mass_floor = 0.5;
};

struct SceneAnchor {
  enum class Kind { kBox, kPlane, kLabels };
  Kind kind = Kind::kBox;
  Vec3d min_mm, max_mm;    ///< box
  Vec3d point_mm, normal;  ///< plane: nodes with (p − point)·normal ≤ 0 are anchored
  std::vector<std::uint8_t> labels;
};

/// A constant force on every alive node whose rest position lies in a box.
struct SceneLoad {
  Vec3d min_mm, max_mm;
  Vec3d force_un{0, 0, 0};  ///< µN per node
};

/// Start from a scaled copy of the rest shape: p0 = about + scale ⊙ (p − about).
struct SceneInitialState {
  bool scaled = false;
  Vec3d scale{1, 1, 1};
  Vec3d about_mm{0, 0, 0};
};

struct Scene {
  std::filesystem::path file;
  std::string name;
  SceneLattice lattice;
  crms::SolverConfig solver;  ///< materials[0] is the scene's material
  double dt_s = 0.0;          ///< 0 = automatic: dt_safety × the stable estimate
  double dt_safety = 0.9;
  std::int64_t steps = 1000;
  std::int64_t report_every = 100;
  std::vector<SceneAnchor> anchors;
  std::vector<SceneLoad> loads;
  SceneInitialState initial;
};

/// Reads and validates a scene; relative paths inside it are resolved against its folder.
/// Throws tsf::Error "FILE: key.path: what is wrong".
Scene read_scene(const std::filesystem::path& file);

}  // namespace tsf::app

// Tissue surfaces -> mesh files through assimp (`tsf export`).
//
// One state (a surface, or one state of a mesh sequence) becomes one file (plus the .mtl of an
// OBJ). Several states of a sequence become numbered files STEM-KKKK.EXT (K = state number,
// frame_selection.h), always; for glTF/GLB, when the selected states share one topology (no cut
// or ablation re-meshed the surface between them), PATH itself also gets written as one animated
// asset: the first selected state as the base mesh, every later one a morph target, and an
// animation "tissue-motion" with one keyframe per state at its simulation time (minus the first
// state's, times time_scale) that blends linearly from state to state.
//
// When a cut or ablation re-meshed the surface inside the selection, the animated asset holds
// one node per run of states that share a topology (morph targets within the run) and switches
// between them with STEP scale keys (gltf_document.h, add_state_animation).
//
// Every exported mesh is made clean first (mesh_cleanup.h: no zero-area, no duplicate
// triangles, counts before and after in the report), in the file's frame so that what is
// counted is what is written; it can then be decimated and given levels of detail
// (mesh_decimation.h), each level's distance to the full surface measured in mm
// (surface_deviation.h). Normals are area-weighted (export_normals.h). Materials: one per
// tissue, coloured (tissue_palette.h); per-vertex colours on request.
//
// Every file of one export appears together or not at all (output_file_set.h): a failed export
// (unknown extension, empty mesh, unwritable folder, ...) throws tsf::Error saying why and leaves
// none of its files. Frames, units and colours: output_frame.h, tissue_palette.h,
// export_format.h; docs/export.md has the whole story.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tsf/export/export_format.h"
#include "tsf/export/frame_selection.h"
#include "tsf/export/mesh_cleanup.h"
#include "tsf/export/mesh_decimation.h"
#include "tsf/export/surface_deviation.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/io/mesh_sequence.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::exporter {

struct ExportOptions {
  ExportFormat format = ExportFormat::glb;
  std::optional<LengthUnit> units;     ///< default: the format's (glTF: metres, fixed)
  std::optional<AxisConvention> axes;  ///< default: the format's (glTF, FBX: y-up, fixed)
  bool split_labels = false;           ///< one node per tissue label (else one node, a mesh each)
  bool vertex_colours = false;         ///< per-vertex tissue colours (glTF: materials then white)
  bool centre = false;                 ///< move the first exported state's bounding box centre to 0
  double time_scale = 1.0;             ///< animation seconds per simulated second (> 0)
  /// Decimation of every exported state (--decimate N, --max-error MM); none when empty.
  std::optional<DecimationOptions> decimation;
  /// Further levels of detail (--lods): triangle counts, decreasing, each level made from the
  /// one before (level 0 is the full or decimated surface). One state only.
  std::vector<std::size_t> lods;
  bool measure_error = true;    ///< distance of every decimated level to the full surface
  bool numbered_files = true;   ///< sequences: STEM-KKKK.EXT per state besides the animation
  std::string name = "tissue";  ///< root node name
  std::string source;           ///< input description recorded in the file's metadata
  /// Said in the file's metadata beside the frame when not empty, e.g. that the source CT records
  /// no patient orientation ("left/right unknown: ...").
  std::string frame_warning;

  /// Throws tsf::Error for a unit or axis convention the format fixes otherwise, --split-labels
  /// on a format that holds one mesh, a time scale that is not finite and positive, or levels
  /// of detail that do not decrease.
  void validate() const;
  LengthUnit resolved_units() const;
  AxisConvention resolved_axes() const;
};

struct ExportedFile {
  std::filesystem::path path;
  std::uintmax_t bytes = 0;
  std::string content;  ///< "state 3 (t = 0.030000 s)", "animation of states 0..5", "materials"
};

/// One level of detail of the first exported state (level 0: the surface as exported).
struct LevelReport {
  std::size_t vertices = 0, triangles = 0;
  bool decimated = false;
  double decimate_s = 0.0;
  double decimate_idle_s = 0.0;   ///< CPU time on its critical path (DecimatedMesh)
  double meshopt_error_mm = 0.0;  ///< meshoptimizer's own estimate
  int slabs = 1;                  ///< slabs simplified in parallel (mesh_decimation.h)
  int rounds = 1;                 ///< meshoptimizer runs (reruns lock non-manifold spots)
  std::size_t locked_vertices = 0, nonmanifold_vertices = 0;  ///< see DecimatedMesh
  std::size_t repaired_triangles = 0;         ///< fins, duplicates and caps meshoptimizer left
  std::optional<SurfaceDeviation> deviation;  ///< to the full (cleaned) surface, mm
};

struct ExportReport {
  ExportFormat format = ExportFormat::glb;
  LengthUnit units = LengthUnit::millimetre;
  AxisConvention axes = AxisConvention::lps;
  std::vector<ExportedFile> files;
  std::vector<std::size_t> states;          ///< state numbers exported
  bool animated = false;                    ///< PATH holds a morph-target animation
  std::string animation_note;               ///< why there is no animation, when there is none
  std::size_t meshes_per_file = 0;          ///< meshes in one file (tissues × levels)
  std::vector<std::string> tissues;         ///< material names, in label order
  std::size_t vertices = 0, triangles = 0;  ///< written for the first exported state (level 0)
  std::size_t input_triangles = 0;          ///< of the first exported state, before cleaning
  std::size_t normals_without_area = 0;     ///< normals taken from neighbours (export_normals.h)
  CleanupReport cleanup;                    ///< of the first exported state (mesh_cleanup.h)
  TriangleDefects written;                  ///< over every mesh written, in the file's frame
  std::vector<LevelReport> levels;          ///< of the first exported state
  std::size_t topology_runs = 0;            ///< nodes of the animation (runs of one topology)
  struct Body {
    std::string tissue;
    std::size_t vertices = 0, triangles = 0;
    bool closed_manifold = false;  ///< every edge in two opposite triangles, every vertex a disc
    std::size_t boundary_edges = 0, nonmanifold_edges = 0, nonmanifold_vertices = 0;
    std::size_t components = 0;
  };
  std::vector<Body> bodies;  ///< --bodies: per tissue, level 0
  // Time per stage, summed over the files written (seconds).
  double prepare_s = 0;   ///< frame mapping, normals, partition
  double clean_s = 0;     ///< mesh_cleanup
  double decimate_s = 0;  ///< decimation (every level)
  double measure_s = 0;   ///< error measurement
  double scene_s = 0;     ///< assimp scene construction
  double assimp_s = 0;    ///< assimp's exporter (ExportToBlob)
  double finish_s = 0;    ///< tsf finishing (glTF JSON/animation, FBX repair, headers)
  double write_s = 0;     ///< temporary files and the atomic commit
};

/// Exports one surface (tissue space, mm) of a volume with `geometry` to `path`.
ExportReport export_surface(const imt::SurfaceMesh& mesh, const VolumeGeometry& geometry,
                            const std::filesystem::path& path, const ExportOptions& options);

/// Exports the states of `sequence` that `selection` names (see the top of this file).
ExportReport export_sequence(const io::MeshSequence& sequence, const FrameSelection& selection,
                             const std::filesystem::path& path, const ExportOptions& options);

/// Each tissue of `volume` (density and labels) as its own closed body (tissue_bodies.h), to
/// `path`: one file with a node per body (glTF, OBJ, FBX), or STEM-TISSUE.EXT per body (STL,
/// PLY). Decimation and levels of detail apply to the bodies together, so neighbours keep
/// sharing their interface.
ExportReport export_bodies(const VoxelVolume& volume, float iso, const std::filesystem::path& path,
                           const ExportOptions& options);

/// The report as JSON (`tsf export --stats`): files, counts before/after cleaning, levels with
/// their distance to the full surface, times per stage.
nlohmann::json export_report_json(const ExportReport& report);

/// The report in a few lines for people: triangles in and out with the cleaning counts, and
/// per level its triangles and distance to the full surface.
std::vector<std::string> export_summary_lines(const ExportReport& report);

/// A count with its digits grouped by commas (1,798,678), as the summary prints counts.
std::string thousands(std::size_t n);

/// STEM-KKKK.EXT beside `path` (at least 4 digits, more when `state_count` needs them).
std::filesystem::path numbered_path(const std::filesystem::path& path, std::size_t state,
                                    std::size_t state_count);

}  // namespace tsf::exporter

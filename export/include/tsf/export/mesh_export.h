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

#include "tsf/export/export_format.h"
#include "tsf/export/frame_selection.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/io/mesh_sequence.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::exporter {

struct ExportOptions {
  ExportFormat format = ExportFormat::glb;
  std::optional<LengthUnit> units;     ///< default: the format's (glTF: metres, fixed)
  std::optional<AxisConvention> axes;  ///< default: the format's (glTF, FBX: y-up, fixed)
  bool split_labels = false;           ///< one mesh (node, material) per tissue label
  bool centre = false;                 ///< move the first exported state's bounding box centre to 0
  double time_scale = 1.0;             ///< animation seconds per simulated second (> 0)
  std::string name = "tissue";         ///< root node name
  std::string source;                  ///< input description recorded in the file's metadata
  /// Said in the file's metadata beside the frame when not empty, e.g. that the source CT records
  /// no patient orientation ("left/right unknown: ...").
  std::string frame_warning;

  /// Throws tsf::Error for a unit or axis convention the format fixes otherwise, --split-labels
  /// on a format that holds one mesh, or a time scale that is not finite and positive.
  void validate() const;
  LengthUnit resolved_units() const;
  AxisConvention resolved_axes() const;
};

struct ExportedFile {
  std::filesystem::path path;
  std::uintmax_t bytes = 0;
  std::string content;  ///< "state 3 (t = 0.030000 s)", "animation of states 0..5", "materials"
};

struct ExportReport {
  ExportFormat format = ExportFormat::glb;
  LengthUnit units = LengthUnit::millimetre;
  AxisConvention axes = AxisConvention::lps;
  std::vector<ExportedFile> files;
  std::vector<std::size_t> states;          ///< state numbers exported
  bool animated = false;                    ///< PATH holds a morph-target animation
  std::string animation_note;               ///< why there is no animation, when there is none
  std::size_t meshes_per_file = 0;          ///< 1, or the number of tissues (--split-labels)
  std::size_t vertices = 0, triangles = 0;  ///< of the first exported state
  std::size_t repaired_normals = 0;         ///< zero normals replaced (export_normals.h)
  // Time per stage, summed over the files written (seconds).
  double prepare_s = 0;  ///< frame mapping, normals, partition
  double scene_s = 0;    ///< assimp scene construction
  double assimp_s = 0;   ///< assimp's exporter (ExportToBlob)
  double finish_s = 0;   ///< tsf finishing (glTF JSON/animation, FBX repair, headers)
  double write_s = 0;    ///< temporary files and the atomic commit
};

/// Exports one surface (tissue space, mm) of a volume with `geometry` to `path`.
ExportReport export_surface(const imt::SurfaceMesh& mesh, const VolumeGeometry& geometry,
                            const std::filesystem::path& path, const ExportOptions& options);

/// Exports the states of `sequence` that `selection` names (see the top of this file).
ExportReport export_sequence(const io::MeshSequence& sequence, const FrameSelection& selection,
                             const std::filesystem::path& path, const ExportOptions& options);

/// STEM-KKKK.EXT beside `path` (at least 4 digits, more when `state_count` needs them).
std::filesystem::path numbered_path(const std::filesystem::path& path, std::size_t state,
                                    std::size_t state_count);

}  // namespace tsf::exporter

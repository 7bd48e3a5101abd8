// The mesh files an interactive run writes while it plays (`outputs:` of a scene): the rest
// surface at the start, saved states every `states_every` frames and at the end (.tsfmesh for
// `tsf export`), the final deformed, cut surface. One writer for every command that plays a
// tissue frame by frame: the scripted runner (interaction_run.h) and `tsf view`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>

#include "tsf/imt/surface_mesh.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::io {
class MeshSequenceWriter;
}

namespace tsf::app {

/// `mesh` (tissue space) in the patient frame (LPS mm), the frame every written or served mesh is
/// in: positions through origin + D·(p − origin), normals through D, and the winding reversed
/// when D mirrors so triangles stay counter-clockwise seen from outside.
imt::SurfaceMesh mesh_in_patient_frame(const imt::SurfaceMesh& mesh, const VolumeGeometry& frame);

/// The files an interactive run writes (absolute paths; empty = not written).
struct InteractionOutputs {
  std::filesystem::path mesh, rest_mesh, report, states;
  std::int64_t states_every = 10;
};

class SceneOutputWriter {
 public:
  /// Writes the rest mesh and opens the states file (streamed to a temporary that appears only
  /// at finish()). `patient_frame` maps the tissue's coordinates to the patient. `report` is not
  /// written here: each command writes its own.
  SceneOutputWriter(const InteractionOutputs& files, const VolumeGeometry& patient_frame,
                    const interaction::TissueModel& model);
  ~SceneOutputWriter();
  SceneOutputWriter(SceneOutputWriter&&) noexcept;
  SceneOutputWriter& operator=(SceneOutputWriter&&) noexcept;

  /// After frame `frame` (1-based) at `time_s`: a saved state every states_every frames, except
  /// on the last planned frame (`last`), whose state finish() saves.
  void frame(const interaction::TissueModel& model, std::int64_t frame, double time_s,
             bool last = false);
  /// The last state (unless frame() just saved it, or nothing was played) and the final mesh.
  void finish(const imt::SurfaceMesh& final_mesh, double time_s);
  /// States saved so far, the rest state included (0 without a states file).
  std::size_t states_saved() const;

 private:
  InteractionOutputs files_;
  VolumeGeometry frame_;  ///< tissue → patient (LPS): the PLY files are written in LPS
  std::unique_ptr<io::MeshSequenceWriter> states_;
  std::int64_t last_frame_ = 0;
  bool last_saved_ = false;  ///< frame() saved the state of last_frame_
};

}  // namespace tsf::app

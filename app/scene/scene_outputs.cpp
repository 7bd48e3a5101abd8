#include "scene/scene_outputs.h"

#include "tsf/imt/surface_ply.h"
#include "tsf/io/mesh_sequence.h"

#include <utility>

namespace tsf::app {

imt::SurfaceMesh mesh_in_patient_frame(const imt::SurfaceMesh& mesh, const VolumeGeometry& frame) {
  if (frame.identity_direction()) return mesh;
  imt::SurfaceMesh out = mesh;
  for (Vec3f& p : out.positions) p = to_float(frame.tissue_to_patient(to_double(p)));
  for (Vec3f& n : out.normals) n = to_float(frame.direction_to_patient(to_double(n)));
  if (frame.mirrors())
    for (auto& t : out.triangles) std::swap(t[1], t[2]);
  return out;
}

SceneOutputWriter::SceneOutputWriter(const InteractionOutputs& files,
                                     const VolumeGeometry& patient_frame,
                                     const interaction::TissueModel& model)
    : files_(files), frame_(patient_frame) {
  if (!files_.rest_mesh.empty())
    imt::write_surface_ply(files_.rest_mesh, mesh_in_patient_frame(model.deformed_mesh(), frame_));
  if (!files_.states.empty())
    states_ = std::make_unique<io::MeshSequenceWriter>(files_.states, patient_frame,
                                                       model.deformed_mesh(), 0.0);
}

SceneOutputWriter::~SceneOutputWriter() = default;
SceneOutputWriter::SceneOutputWriter(SceneOutputWriter&&) noexcept = default;
SceneOutputWriter& SceneOutputWriter::operator=(SceneOutputWriter&&) noexcept = default;

void SceneOutputWriter::frame(const interaction::TissueModel& model, std::int64_t frame,
                              double time_s, bool last) {
  last_frame_ = frame;
  last_saved_ = states_ && !last && frame % files_.states_every == 0;
  if (last_saved_) states_->add_frame(time_s, model.deformed_mesh());
}

void SceneOutputWriter::finish(const imt::SurfaceMesh& final_mesh, double time_s) {
  if (states_) {
    if (last_frame_ > 0 && !last_saved_) states_->add_frame(time_s, final_mesh);
    states_->finish();
  }
  if (!files_.mesh.empty())
    imt::write_surface_ply(files_.mesh, mesh_in_patient_frame(final_mesh, frame_));
}

std::size_t SceneOutputWriter::states_saved() const {
  return states_ ? states_->frame_count() : 0;
}

}  // namespace tsf::app

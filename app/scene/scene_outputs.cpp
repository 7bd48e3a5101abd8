#include "scene/scene_outputs.h"

#include "tsf/common/atomic_file.h"
#include "tsf/imt/surface_ply.h"
#include "tsf/io/mesh_sequence.h"

namespace tsf::app {

SceneOutputWriter::SceneOutputWriter(const Scene* scene, const OutputFolder& folder,
                                     const VolumeGeometry& geometry,
                                     const interaction::TissueModel& model) {
  if (!scene || !scene->outputs_given || folder.empty()) return;
  names_ = scene->outputs;
  folder_ = folder;
  if (!names_.rest_mesh.empty())
    imt::write_surface_ply(folder_.file(names_.rest_mesh), model.deformed_mesh());
  if (!names_.states.empty())
    states_ = std::make_unique<io::MeshSequenceWriter>(folder_.file(names_.states), geometry,
                                                       model.deformed_mesh(), 0.0);
}

SceneOutputWriter::~SceneOutputWriter() = default;

void SceneOutputWriter::frame(const interaction::TissueModel& model, std::int64_t frame,
                              double time_s) {
  last_frame_ = frame;
  if (states_ && frame % names_.states_every == 0)
    states_->add_frame(time_s, model.deformed_mesh());
}

void SceneOutputWriter::finish(const interaction::TissueModel& model, double time_s,
                               const nlohmann::json& report) {
  if (folder_.empty()) return;
  if (states_) {
    if (last_frame_ % names_.states_every != 0 && time_s > 0)
      states_->add_frame(time_s, model.deformed_mesh());
    states_->finish();
  }
  if (!names_.mesh.empty())
    imt::write_surface_ply(folder_.file(names_.mesh), model.deformed_mesh());
  if (!names_.report.empty())
    write_text_atomically(folder_.file(names_.report), report.dump(2) + "\n");
}

}  // namespace tsf::app

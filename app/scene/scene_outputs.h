// A scene's `outputs:` (rest mesh, final mesh, saved states, report) written by a command that
// runs one tissue instance frame by frame on its own loop (`tsf view`): names inside the
// command's output folder. `tsf simulate` and `tsf run` write theirs in interaction_run.h.
#pragma once

#include <cstdint>
#include <memory>

#include <nlohmann/json.hpp>

#include "output/output_folder.h"
#include "scene/scene.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf::io {
class MeshSequenceWriter;
}

namespace tsf::app {

class SceneOutputWriter {
 public:
  /// Writes the rest mesh and opens the states file; writes nothing when `scene` is null or has
  /// no outputs.
  SceneOutputWriter(const Scene* scene, const OutputFolder& folder, const VolumeGeometry& geometry,
                    const interaction::TissueModel& model);
  ~SceneOutputWriter();
  SceneOutputWriter(const SceneOutputWriter&) = delete;
  SceneOutputWriter& operator=(const SceneOutputWriter&) = delete;

  /// After frame `frame` (1-based) at `time_s`: a saved state every outputs.states_every frames.
  void frame(const interaction::TissueModel& model, std::int64_t frame, double time_s);
  /// The last state, the final mesh and `report` (outputs.report).
  void finish(const interaction::TissueModel& model, double time_s, const nlohmann::json& report);

 private:
  SceneOutputs names_;
  OutputFolder folder_;
  std::unique_ptr<io::MeshSequenceWriter> states_;
  std::int64_t last_frame_ = 0;
};

}  // namespace tsf::app

// The coupler's device mirror (private to tissue/src/coupler): bindings, sources and rest normals
// per vertex slot in GPU memory, the deformed outputs beside them, and the kernels that run
// couple_vertex() on them. coupler_device.cu implements it; coupler_device_nocuda.cpp throws.
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/coupler/couple_vertex.h"
#include "tsf/coupler/deformed_lattice_view.h"

namespace tsf::coupler {

class CouplerDevice {
 public:
  virtual ~CouplerDevice() = default;
  /// (Re)allocates `slots` vertex slots and `frames` frame slots; contents are unspecified until
  /// uploaded (vertices never uploaded read as unbound).
  virtual void reserve(std::uint32_t slots, std::uint32_t frames) = 0;
  /// Copies the frame bindings and rest normals of `slots` from host arrays indexed by slot.
  virtual void upload_vertices(const std::uint32_t* slots, std::size_t count,
                               const VertexFrameBinding* bindings, const Vec3f* rest_normals) = 0;
  /// Copies the listed frames from a host array indexed by frame.
  virtual void upload_frames(const std::uint32_t* frames, std::size_t count,
                             const CubeFrame* table) = 0;
  /// Resolves frames [0, frame_count), then couples slots [0, slot_count); dirty_blocks[b] = 1
  /// where an output of block b changed (blocks of kDirtyBlockSlots); resized to the block count.
  virtual void couple_all(const DeformedLatticeView& lattice, std::uint32_t frame_count,
                          std::uint32_t slot_count, CouplerMode mode,
                          std::vector<std::uint8_t>& dirty_blocks) = 0;
  /// Resolves the listed frames, couples the listed slots and copies their outputs into the host
  /// arrays (indexed by slot).
  virtual void couple_slots(const DeformedLatticeView& lattice, const std::uint32_t* frames,
                            std::size_t frame_count, const std::uint32_t* slots, std::size_t count,
                            CouplerMode mode, Vec3f* positions, Vec3f* normals) = 0;
  /// Copies the outputs of the slot ranges [first, last) into the host arrays (indexed by slot),
  /// all copies queued before one wait.
  virtual void download_ranges(const std::vector<std::pair<std::uint32_t, std::uint32_t>>& ranges,
                               Vec3f* positions, Vec3f* normals) = 0;
  /// Page-locks the host output arrays (count slots each) so that downloads run at the bus's
  /// speed rather than through the driver's pageable staging; release_host() before the arrays
  /// move or are freed. Best effort: an array that cannot be registered (it shares a page with
  /// one that is) is copied to as it is.
  virtual void register_host(Vec3f* positions, Vec3f* normals, std::size_t count) = 0;
  virtual void release_host() = 0;
};

/// Throws tsf::Error with cuda_status().reason when CUDA is not built or has no device.
std::unique_ptr<CouplerDevice> make_coupler_device();

}  // namespace tsf::coupler

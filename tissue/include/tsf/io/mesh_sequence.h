// A saved simulation state: the tissue surface at rest, zero or more frames of it deformed (and
// cut), and the geometry of the volume it came from, so that export can place it in the patient
// frame. `tsf simulate` writes it; `tsf export` reads it. Standard library only (the GPU build
// writes it too).
//
// Units and frames: positions in mm in tissue space (VolumeGeometry::index_to_tissue: axis-aligned,
// the image direction not applied); normals are unit vectors out of the tissue; times in s.
//
// Topology changes: a frame either keeps the topology in force (labels and triangles of the latest
// full mesh; only positions and normals are stored: a POSE record) or, after a cut or ablation
// re-meshed the surface, carries a full mesh of its own (a MESH record) that is the topology in
// force from then on. Vertex counts may change between full meshes; vertex i of one topology has
// nothing to do with vertex i of another.
//
// File ".tsfmesh", version 1; every number little endian, no alignment padding unless stated:
//   header   8 bytes magic 89 54 53 46 4D 0D 0A 1A ("\x89TSFM\r\n\x1a": the high-bit byte and
//            CR LF catch 7-bit and text-mode transfers, as in PNG), u32 version = 1,
//            u32 flags = 0 (reserved)
//   records  char tag[4], u64 payload_bytes, payload, u32 CRC-32 of the payload (io/crc32.h)
//     "GEOM" 132 bytes: i32 dims[3], f64 spacing_mm[3], f64 origin_mm[3] (LPS position of voxel
//            (0,0,0)'s centre), f64 direction[9] (row-major; columns are the i, j, k axes in LPS)
//     "MESH" f64 time_s, u32 kind (0 = the rest state, 1 = a frame), u32 flags (bit 0: normals
//            present; other bits 0), u64 V, u64 T, f32 positions[V][3], f32 normals[V][3] (when
//            flagged), u8 labels[V] (tsf/volume/tissue_labels.h), 0-3 zero bytes to a multiple of
//            4, u32 triangles[T][3] (counter-clockwise seen from outside)
//     "POSE" f64 time_s, u32 flags (bit 0: normals), u32 reserved = 0, u64 V (must equal the V of
//            the topology in force), f32 positions[V][3], f32 normals[V][3] (when flagged)
//     "END " u64 frame_count (MESH kind 1 and POSE records); nothing may follow it
//   Order: GEOM, MESH kind 0, any number of frames (MESH kind 1 or POSE) with strictly increasing
//   times after the rest time, END.
// The payload size of every record is checked against its fields and against the bytes left in
// the file before anything is allocated, so a corrupt or truncated file is an error naming the
// file, the record and the field, never a crash or an unbounded allocation.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::io {

inline constexpr std::uint32_t kMeshSequenceVersion = 1;
inline constexpr const char* kMeshSequenceExtension = ".tsfmesh";

/// One saved state after the rest state.
struct MeshFrame {
  double time_s = 0.0;               ///< simulation time, s
  std::vector<Vec3f> positions;      ///< #V, mm, tissue space
  std::vector<Vec3f> normals;        ///< #V unit vectors, or empty
  bool topology_changed = false;     ///< true: labels and triangles below replace the topology
  std::vector<std::uint8_t> labels;  ///< #V when topology_changed, else empty
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< when topology_changed, else empty
};

struct MeshSequence {
  VolumeGeometry geometry;  ///< of the source volume (places tissue space in the patient frame)
  double rest_time_s = 0.0;
  imt::SurfaceMesh rest;          ///< the state before any frame
  std::vector<MeshFrame> frames;  ///< in time order
};

/// The full mesh of frame `frame` (positions and normals of the frame with the labels and
/// triangles in force then). Throws tsf::Error when `frame` is out of range.
imt::SurfaceMesh frame_mesh(const MeshSequence& sequence, std::size_t frame);

/// True when no frame changes the topology (every frame is a pose of the rest mesh).
bool has_constant_topology(const MeshSequence& sequence);

/// Throws tsf::Error naming the frame and field: a mesh that fails imt::validate_mesh, a pose
/// whose vertex count differs from the topology in force, times not finite or not strictly
/// increasing, a geometry with non-positive dims or spacing.
void validate_mesh_sequence(const MeshSequence& sequence);

/// True when `path` starts with the mesh sequence magic (any version).
bool is_mesh_sequence_file(const std::filesystem::path& path);

/// Writes a whole sequence (validated first) atomically: temporary file, then rename.
void write_mesh_sequence(const std::filesystem::path& path, const MeshSequence& sequence);

/// Reads and validates a whole sequence. Throws tsf::Error naming the file, record and field.
MeshSequence read_mesh_sequence(const std::filesystem::path& path);

/// Streams a sequence to disk frame by frame (a simulation need not keep its history). The file
/// appears under its name only when finish() succeeds; until then the records go to a temporary
/// file beside it, which is removed if the writer is destroyed unfinished or a write fails.
class MeshSequenceWriter {
 public:
  MeshSequenceWriter(const std::filesystem::path& path, const VolumeGeometry& geometry,
                     const imt::SurfaceMesh& rest, double rest_time_s = 0.0);
  ~MeshSequenceWriter();
  MeshSequenceWriter(const MeshSequenceWriter&) = delete;
  MeshSequenceWriter& operator=(const MeshSequenceWriter&) = delete;

  /// Appends a frame: a POSE record when `mesh` has the labels and triangles in force (same
  /// vertex count), otherwise a MESH record that becomes the topology in force.
  void add_frame(double time_s, const imt::SurfaceMesh& mesh);
  /// Appends a MESH record (kind 1) whatever the topology: `mesh` becomes the topology in force.
  void add_full_frame(double time_s, const imt::SurfaceMesh& mesh);
  /// Appends a POSE: positions #V of the topology in force (normals #V, or empty).
  void add_pose(double time_s, const std::vector<Vec3f>& positions,
                const std::vector<Vec3f>& normals);
  /// Writes END, flushes and renames the temporary into place. Throws tsf::Error on failure
  /// (and leaves no file).
  void finish();

  std::size_t frame_count() const { return frames_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  void check_time(double time_s);
  void write_record(const char* tag, const std::string& payload);
  [[noreturn]] void fail(const std::string& what);

  std::filesystem::path path_, temp_;
  std::ofstream out_;
  std::size_t frames_ = 0;
  double last_time_s_ = 0.0;
  std::size_t vertex_count_ = 0;  ///< of the topology in force
  std::vector<std::uint8_t> labels_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;
  bool finished_ = false;
};

/// Reads a sequence frame by frame: the header, geometry and rest mesh on construction, then one
/// frame per next_frame() call, so only the topology in force and one frame are in memory.
class MeshSequenceReader {
 public:
  /// Throws tsf::Error naming the file and what is wrong with its header, geometry or rest mesh.
  explicit MeshSequenceReader(const std::filesystem::path& path);
  ~MeshSequenceReader();
  MeshSequenceReader(const MeshSequenceReader&) = delete;
  MeshSequenceReader& operator=(const MeshSequenceReader&) = delete;

  const VolumeGeometry& geometry() const { return geometry_; }
  const imt::SurfaceMesh& rest() const { return rest_; }
  double rest_time_s() const { return rest_time_s_; }

  /// Reads the next frame into `frame` (topology fields filled only when it changed) and
  /// updates current_mesh(). Returns false at the END record, after checking its frame count
  /// and that nothing follows it. Throws tsf::Error naming the frame, record and field.
  bool next_frame(MeshFrame& frame);
  /// The full mesh of the frame read last (the rest mesh before the first next_frame()).
  const imt::SurfaceMesh& current_mesh() const { return current_; }
  /// Frames read so far.
  std::size_t frames_read() const { return frames_read_; }

 private:
  struct Source;
  std::unique_ptr<Source> source_;
  VolumeGeometry geometry_;
  imt::SurfaceMesh rest_;
  double rest_time_s_ = 0.0;
  imt::SurfaceMesh current_;
  double last_time_s_ = 0.0;
  std::size_t frames_read_ = 0;
  bool ended_ = false;
};

}  // namespace tsf::io

#include "tsf/io/mesh_sequence.h"

#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <random>
#include <system_error>
#include <type_traits>

#include "tsf/common/error.h"
#include "tsf/io/crc32.h"
#include "tsf/io/mesh_validation.h"

namespace tsf::io {
namespace fs = std::filesystem;

static_assert(sizeof(Vec3f) == 12 && std::is_trivially_copyable_v<Vec3f>,
              "Vec3f must be three packed floats: arrays are copied as bytes");
static_assert(sizeof(std::array<std::uint32_t, 3>) == 12, "triangles are copied as bytes");

namespace {

constexpr unsigned char kMagic[8] = {0x89, 'T', 'S', 'F', 'M', '\r', '\n', 0x1a};
constexpr std::size_t kHeaderBytes = 16;        // magic, version, flags
constexpr std::size_t kRecordHeaderBytes = 12;  // tag, payload_bytes
constexpr std::size_t kCrcBytes = 4;
constexpr std::size_t kGeomBytes = 3 * 4 + 3 * 8 + 3 * 8 + 9 * 8;
constexpr std::size_t kMeshFixedBytes = 8 + 4 + 4 + 8 + 8;  // time, kind, flags, V, T
constexpr std::size_t kPoseFixedBytes = 8 + 4 + 4 + 8;      // time, flags, reserved, V
constexpr std::uint32_t kFlagNormals = 1u;
constexpr std::uint32_t kKindRest = 0, kKindFrame = 1;

bool host_is_little_endian() {
  const std::uint16_t one = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

void require_little_endian() {
  require(host_is_little_endian(),
          "mesh sequence files are little endian; this host is not (unsupported)");
}

template <typename T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

template <typename T>
void put_array(std::string& out, const std::vector<T>& values) {
  if (!values.empty())
    out.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

std::size_t label_padding(std::size_t vertex_count) {
  return (4 - vertex_count % 4) % 4;
}

std::string geometry_payload(const VolumeGeometry& g) {
  std::string p;
  p.reserve(kGeomBytes);
  put<std::int32_t>(p, g.dims.x);
  put<std::int32_t>(p, g.dims.y);
  put<std::int32_t>(p, g.dims.z);
  for (double v : {g.spacing.x, g.spacing.y, g.spacing.z}) put(p, v);
  for (double v : {g.origin.x, g.origin.y, g.origin.z}) put(p, v);
  for (double v : g.direction) put(p, v);
  return p;
}

std::string mesh_payload(double time_s, std::uint32_t kind, const imt::SurfaceMesh& mesh) {
  const bool normals = !mesh.normals.empty();
  const std::size_t v = mesh.positions.size(), t = mesh.triangles.size();
  std::string p;
  p.reserve(kMeshFixedBytes + v * (normals ? 25 : 13) + 3 + t * 12);
  put(p, time_s);
  put(p, kind);
  put<std::uint32_t>(p, normals ? kFlagNormals : 0u);
  put<std::uint64_t>(p, v);
  put<std::uint64_t>(p, t);
  put_array(p, mesh.positions);
  if (normals) put_array(p, mesh.normals);
  put_array(p, mesh.labels);
  p.append(label_padding(v), '\0');
  put_array(p, mesh.triangles);
  return p;
}

std::string pose_payload(double time_s, const std::vector<Vec3f>& positions,
                         const std::vector<Vec3f>& normals) {
  const bool has_normals = !normals.empty();
  std::string p;
  p.reserve(kPoseFixedBytes + positions.size() * (has_normals ? 24 : 12));
  put(p, time_s);
  put<std::uint32_t>(p, has_normals ? kFlagNormals : 0u);
  put<std::uint32_t>(p, 0u);
  put<std::uint64_t>(p, positions.size());
  put_array(p, positions);
  if (has_normals) put_array(p, normals);
  return p;
}

void validate_geometry(const VolumeGeometry& g, const std::string& where) {
  require(g.dims.x > 0 && g.dims.y > 0 && g.dims.z > 0,
          where + ": field 'dims' = " + std::to_string(g.dims.x) + "x" + std::to_string(g.dims.y) +
              "x" + std::to_string(g.dims.z) + ", expected positive sizes");
  for (double s : {g.spacing.x, g.spacing.y, g.spacing.z})
    require(std::isfinite(s) && s > 0.0, where + ": field 'spacing_mm' has " + std::to_string(s) +
                                             ", expected finite positive mm");
  for (double o : {g.origin.x, g.origin.y, g.origin.z})
    require(std::isfinite(o), where + ": field 'origin_mm' is not finite");
  for (double d : g.direction)
    require(std::isfinite(d), where + ": field 'direction' is not finite");
}

void validate_vectors(const std::vector<Vec3f>& values, const char* field,
                      const std::string& where) {
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!all_finite(values[i]))
      throw Error(where + ": field '" + field + "' of vertex " + std::to_string(i) +
                  " is not finite");
}

/// imt::validate_mesh with the record named in the message.
void validate_mesh_in(const imt::SurfaceMesh& mesh, const std::string& where) {
  try {
    validate_mesh_quickly(mesh);
  } catch (const Error& e) {
    throw Error(where + ": " + e.what());
  }
}

std::string frame_name(std::size_t frame) {
  return "frame " + std::to_string(frame);
}

fs::path temporary_beside(const fs::path& target) {
  static std::atomic<unsigned> counter{0};
  std::random_device rd;
  const std::string tag = std::to_string(::getpid()) + "-" + std::to_string(rd() & 0xffffffu) +
                          "-" + std::to_string(counter++);
  return target.parent_path() / ("." + target.filename().string() + ".tmp-" + tag);
}

}  // namespace

// ---- in-memory sequences ------------------------------------------------------------------------

imt::SurfaceMesh frame_mesh(const MeshSequence& sequence, std::size_t frame) {
  require(frame < sequence.frames.size(), "frame " + std::to_string(frame) +
                                              " requested from a mesh sequence of " +
                                              std::to_string(sequence.frames.size()) + " frames");
  const imt::SurfaceMesh* topology = &sequence.rest;
  const MeshFrame* changed = nullptr;
  for (std::size_t f = frame + 1; f-- > 0;)
    if (sequence.frames[f].topology_changed) {
      changed = &sequence.frames[f];
      break;
    }
  imt::SurfaceMesh out;
  const MeshFrame& current = sequence.frames[frame];
  out.positions = current.positions;
  out.normals = current.normals;
  if (changed) {
    out.labels = changed->labels;
    out.triangles = changed->triangles;
  } else {
    out.labels = topology->labels;
    out.triangles = topology->triangles;
  }
  return out;
}

bool has_constant_topology(const MeshSequence& sequence) {
  for (const MeshFrame& f : sequence.frames)
    if (f.topology_changed) return false;
  return true;
}

void validate_mesh_sequence(const MeshSequence& sequence) {
  validate_geometry(sequence.geometry, "mesh sequence geometry");
  require(std::isfinite(sequence.rest_time_s), "mesh sequence: rest time is not finite");
  validate_mesh_in(sequence.rest, "mesh sequence rest mesh");
  std::size_t vertex_count = sequence.rest.positions.size();
  double last_time = sequence.rest_time_s;
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    const MeshFrame& frame = sequence.frames[f];
    const std::string where = "mesh sequence " + frame_name(f);
    require(std::isfinite(frame.time_s) && frame.time_s > last_time,
            where + ": time " + std::to_string(frame.time_s) +
                " s must be finite and later than the previous state's " +
                std::to_string(last_time) + " s");
    last_time = frame.time_s;
    if (frame.topology_changed) {
      imt::SurfaceMesh mesh;
      mesh.positions = frame.positions;
      mesh.normals = frame.normals;
      mesh.labels = frame.labels;
      mesh.triangles = frame.triangles;
      validate_mesh_in(mesh, where);
      vertex_count = frame.positions.size();
    } else {
      require(frame.labels.empty() && frame.triangles.empty(),
              where + ": labels or triangles given for a frame that keeps the topology");
      require(frame.positions.size() == vertex_count,
              where + ": " + std::to_string(frame.positions.size()) +
                  " positions for a topology of " + std::to_string(vertex_count) + " vertices");
      require(frame.normals.empty() || frame.normals.size() == vertex_count,
              where + ": " + std::to_string(frame.normals.size()) + " normals for " +
                  std::to_string(vertex_count) + " vertices (expected the same or none)");
      validate_vectors(frame.positions, "positions", where);
      validate_vectors(frame.normals, "normals", where);
    }
  }
}

// ---- writing ------------------------------------------------------------------------------------

MeshSequenceWriter::MeshSequenceWriter(const fs::path& path, const VolumeGeometry& geometry,
                                       const imt::SurfaceMesh& rest, double rest_time_s)
    : path_(path) {
  require_little_endian();
  validate_geometry(geometry, "mesh sequence '" + path.string() + "' geometry");
  require(std::isfinite(rest_time_s),
          "mesh sequence '" + path.string() + "': rest time is not finite");
  validate_mesh_in(rest, "mesh sequence '" + path.string() + "' rest mesh");
  std::error_code ec;
  if (path.has_parent_path()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec)
      throw Error("cannot create directory '" + path.parent_path().string() +
                  "' for mesh sequence '" + path.string() + "': " + ec.message());
  }
  temp_ = temporary_beside(path);
  out_.open(temp_, std::ios::binary | std::ios::trunc);
  if (!out_)
    throw Error("cannot write mesh sequence '" + path.string() + "': cannot create '" +
                temp_.string() + "' (" + std::strerror(errno) + ")");
  try {
    std::string header(reinterpret_cast<const char*>(kMagic), sizeof(kMagic));
    put(header, kMeshSequenceVersion);
    put<std::uint32_t>(header, 0u);
    out_.write(header.data(), static_cast<std::streamsize>(header.size()));
    write_record("GEOM", geometry_payload(geometry));
    write_record("MESH", mesh_payload(rest_time_s, kKindRest, rest));
  } catch (...) {
    // The destructor does not run for a constructor that throws: clean up here.
    out_.close();
    fs::remove(temp_, ec);
    throw;
  }
  last_time_s_ = rest_time_s;
  vertex_count_ = rest.positions.size();
  labels_ = rest.labels;
  triangles_ = rest.triangles;
}

MeshSequenceWriter::~MeshSequenceWriter() {
  if (finished_) return;
  out_.close();
  std::error_code ec;
  fs::remove(temp_, ec);
}

void MeshSequenceWriter::fail(const std::string& what) {
  out_.close();
  std::error_code ec;
  fs::remove(temp_, ec);
  finished_ = true;  // nothing left to clean up
  throw Error("mesh sequence '" + path_.string() + "': " + what);
}

void MeshSequenceWriter::check_time(double time_s) {
  if (finished_) throw Error("mesh sequence '" + path_.string() + "': frame added after finish()");
  if (!(std::isfinite(time_s) && time_s > last_time_s_))
    fail(frame_name(frames_) + ": time " + std::to_string(time_s) +
         " s must be finite and later than the previous state's " + std::to_string(last_time_s_) +
         " s");
}

void MeshSequenceWriter::write_record(const char* tag, const std::string& payload) {
  std::string head(tag, 4);
  put<std::uint64_t>(head, payload.size());
  std::string tail;
  put(tail, crc32(payload.data(), payload.size()));
  out_.write(head.data(), static_cast<std::streamsize>(head.size()));
  out_.write(payload.data(), static_cast<std::streamsize>(payload.size()));
  out_.write(tail.data(), static_cast<std::streamsize>(tail.size()));
  if (!out_) fail(std::string("write failed for record '") + tag + "' (disk full?)");
}

void MeshSequenceWriter::add_frame(double time_s, const imt::SurfaceMesh& mesh) {
  if (mesh.positions.size() == vertex_count_ && mesh.labels == labels_ &&
      mesh.triangles == triangles_)
    add_pose(time_s, mesh.positions, mesh.normals);
  else
    add_full_frame(time_s, mesh);
}

void MeshSequenceWriter::add_full_frame(double time_s, const imt::SurfaceMesh& mesh) {
  check_time(time_s);
  try {
    validate_mesh_in(mesh, frame_name(frames_));
  } catch (const Error& e) {
    fail(e.what());
  }
  write_record("MESH", mesh_payload(time_s, kKindFrame, mesh));
  vertex_count_ = mesh.positions.size();
  labels_ = mesh.labels;
  triangles_ = mesh.triangles;
  last_time_s_ = time_s;
  ++frames_;
}

void MeshSequenceWriter::add_pose(double time_s, const std::vector<Vec3f>& positions,
                                  const std::vector<Vec3f>& normals) {
  check_time(time_s);
  const std::string where = frame_name(frames_);
  if (positions.size() != vertex_count_)
    fail(where + ": " + std::to_string(positions.size()) + " positions for a topology of " +
         std::to_string(vertex_count_) + " vertices");
  if (!normals.empty() && normals.size() != vertex_count_)
    fail(where + ": " + std::to_string(normals.size()) + " normals for " +
         std::to_string(vertex_count_) + " vertices (expected the same or none)");
  try {
    validate_vectors(positions, "positions", where);
    validate_vectors(normals, "normals", where);
  } catch (const Error& e) {
    fail(e.what());
  }
  write_record("POSE", pose_payload(time_s, positions, normals));
  last_time_s_ = time_s;
  ++frames_;
}

void MeshSequenceWriter::finish() {
  if (finished_) throw Error("mesh sequence '" + path_.string() + "': finish() called twice");
  std::string payload;
  put<std::uint64_t>(payload, frames_);
  write_record("END ", payload);
  out_.flush();
  if (!out_) fail("flush failed (disk full?)");
  out_.close();
  if (out_.fail()) fail("close failed");
  std::error_code ec;
  fs::rename(temp_, path_, ec);
  if (ec) fail("cannot move the finished file into place: " + ec.message());
  finished_ = true;
}

void write_mesh_sequence(const fs::path& path, const MeshSequence& sequence) {
  validate_mesh_sequence(sequence);
  MeshSequenceWriter writer(path, sequence.geometry, sequence.rest, sequence.rest_time_s);
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    const MeshFrame& frame = sequence.frames[f];
    if (frame.topology_changed) {
      imt::SurfaceMesh mesh;
      mesh.positions = frame.positions;
      mesh.normals = frame.normals;
      mesh.labels = frame.labels;
      mesh.triangles = frame.triangles;
      writer.add_full_frame(frame.time_s, mesh);
    } else {
      writer.add_pose(frame.time_s, frame.positions, frame.normals);
    }
  }
  writer.finish();
}

// ---- reading ------------------------------------------------------------------------------------

/// The open file with its size, and one record's payload at a time.
struct MeshSequenceReader::Source {
  fs::path path;
  std::ifstream in;
  std::uint64_t size = 0;
  std::uint64_t position = 0;
  std::size_t record_index = 0;

  [[noreturn]] void fail(const std::string& what) const {
    throw Error("mesh sequence '" + path.string() + "': " + what);
  }

  std::uint64_t left() const { return size - position; }

  void read_exact(void* into, std::uint64_t bytes, const std::string& what) {
    if (bytes > left())
      fail(what + " at byte " + std::to_string(position) + " needs " + std::to_string(bytes) +
           " bytes, " + std::to_string(left()) + " left (truncated file)");
    in.read(static_cast<char*>(into), static_cast<std::streamsize>(bytes));
    if (!in) fail(what + " at byte " + std::to_string(position) + ": read error");
    position += bytes;
  }

  struct Record {
    std::string tag;
    std::uint64_t offset = 0;
    std::vector<unsigned char> payload;
  };

  /// Reads the next record, checks its size against the file and its CRC. `expect` names what
  /// the caller expects there (for messages).
  void read_record(Record& record, const std::string& expect) {
    record.offset = position;
    const std::string where = "record " + std::to_string(record_index) + " (" + expect + ")";
    if (left() == 0) fail("ends before " + where + " (truncated file: no END record)");
    char head[kRecordHeaderBytes];
    read_exact(head, kRecordHeaderBytes, where + " header");
    record.tag.assign(head, 4);
    std::uint64_t bytes = 0;
    std::memcpy(&bytes, head + 4, 8);
    for (char c : record.tag)
      if (c < 0x20 || c > 0x7e)
        fail(where + " at byte " + std::to_string(record.offset) +
             ": field 'tag' is not a record tag (corrupt file)");
    if (bytes > left() || left() - bytes < kCrcBytes)
      fail(where + " '" + record.tag + "' at byte " + std::to_string(record.offset) +
           ": field 'payload_bytes' = " + std::to_string(bytes) + " exceeds the " +
           std::to_string(left() >= kCrcBytes ? left() - kCrcBytes : 0) +
           " bytes left (truncated or corrupt file)");
    record.payload.resize(static_cast<std::size_t>(bytes));
    read_exact(record.payload.data(), bytes, where + " payload");
    std::uint32_t stored = 0;
    read_exact(&stored, kCrcBytes, where + " CRC");
    const std::uint32_t actual = crc32(record.payload.data(), record.payload.size());
    if (stored != actual)
      fail(where + " '" + record.tag + "' at byte " + std::to_string(record.offset) +
           ": field 'crc32' does not match the payload (corrupt data)");
    ++record_index;
  }
};

namespace {

/// Reads fields from one record's payload, naming the record in every message.
class PayloadCursor {
 public:
  PayloadCursor(const std::vector<unsigned char>& payload, std::string where)
      : payload_(payload), where_(std::move(where)) {}

  [[noreturn]] void fail(const std::string& what) const { throw Error(where_ + ": " + what); }

  template <typename T>
  T scalar(const char* field) {
    T value{};
    bytes(&value, sizeof(T), field);
    return value;
  }
  void bytes(void* into, std::size_t count, const char* field) {
    if (count > payload_.size() - offset_)
      fail("field '" + std::string(field) + "' runs past the payload (" +
           std::to_string(payload_.size()) + " bytes)");
    if (count) std::memcpy(into, payload_.data() + offset_, count);
    offset_ += count;
  }
  template <typename T>
  void array(std::vector<T>& out, std::size_t count, const char* field) {
    out.resize(count);
    bytes(out.data(), count * sizeof(T), field);
  }
  void skip_zeros(std::size_t count, const char* field) {
    for (std::size_t i = 0; i < count; ++i)
      if (scalar<std::uint8_t>(field) != 0) fail("field '" + std::string(field) + "' is not zero");
  }
  std::size_t size() const { return payload_.size(); }
  const std::string& where() const { return where_; }

 private:
  const std::vector<unsigned char>& payload_;
  std::string where_;
  std::size_t offset_ = 0;
};

std::string describe(const std::string& file, std::size_t record, const std::string& what,
                     std::uint64_t offset) {
  return "mesh sequence '" + file + "': record " + std::to_string(record) + " (" + what +
         ") at byte " + std::to_string(offset);
}

VolumeGeometry parse_geometry(PayloadCursor& c) {
  if (c.size() != kGeomBytes)
    c.fail("field 'payload_bytes' = " + std::to_string(c.size()) + ", expected " +
           std::to_string(kGeomBytes));
  VolumeGeometry g;
  g.dims.x = c.scalar<std::int32_t>("dims");
  g.dims.y = c.scalar<std::int32_t>("dims");
  g.dims.z = c.scalar<std::int32_t>("dims");
  g.spacing.x = c.scalar<double>("spacing_mm");
  g.spacing.y = c.scalar<double>("spacing_mm");
  g.spacing.z = c.scalar<double>("spacing_mm");
  g.origin.x = c.scalar<double>("origin_mm");
  g.origin.y = c.scalar<double>("origin_mm");
  g.origin.z = c.scalar<double>("origin_mm");
  for (double& d : g.direction) d = c.scalar<double>("direction");
  validate_geometry(g, c.where());
  return g;
}

std::uint32_t parse_flags(PayloadCursor& c) {
  const auto flags = c.scalar<std::uint32_t>("flags");
  if (flags & ~kFlagNormals)
    c.fail("field 'flags' = " + std::to_string(flags) +
           " has unknown bits (only bit 0 is defined)");
  return flags;
}

/// Checks that a record of `fixed` bytes plus the arrays of V vertices and T triangles is exactly
/// the payload, without overflow: V and T are first bounded by the payload size.
void check_sizes(PayloadCursor& c, std::uint64_t v, std::uint64_t t, bool normals, bool mesh) {
  const std::uint64_t payload = c.size();
  if (v > payload || t > payload || v > UINT32_MAX)
    c.fail("field 'V' = " + std::to_string(v) + " or 'T' = " + std::to_string(t) +
           " is impossible for a payload of " + std::to_string(payload) + " bytes");
  std::uint64_t expected = (mesh ? kMeshFixedBytes : kPoseFixedBytes) + v * (normals ? 24 : 12);
  if (mesh) expected += v + label_padding(static_cast<std::size_t>(v)) + t * 12;
  if (expected != payload)
    c.fail("fields V = " + std::to_string(v) + (mesh ? ", T = " + std::to_string(t) : "") +
           (normals ? " with normals" : " without normals") + " need " + std::to_string(expected) +
           " payload bytes, the record has " + std::to_string(payload));
}

struct ParsedMesh {
  double time_s = 0.0;
  std::uint32_t kind = 0;
  imt::SurfaceMesh mesh;
};

ParsedMesh parse_mesh(PayloadCursor& c) {
  if (c.size() < kMeshFixedBytes)
    c.fail("field 'payload_bytes' = " + std::to_string(c.size()) + " is below the " +
           std::to_string(kMeshFixedBytes) + " bytes of the fixed fields");
  ParsedMesh m;
  m.time_s = c.scalar<double>("time_s");
  m.kind = c.scalar<std::uint32_t>("kind");
  if (m.kind != kKindRest && m.kind != kKindFrame)
    c.fail("field 'kind' = " + std::to_string(m.kind) + ", expected 0 (rest) or 1 (frame)");
  const bool normals = parse_flags(c) & kFlagNormals;
  const auto v = c.scalar<std::uint64_t>("V");
  const auto t = c.scalar<std::uint64_t>("T");
  check_sizes(c, v, t, normals, true);
  const auto nv = static_cast<std::size_t>(v);
  c.array(m.mesh.positions, nv, "positions");
  if (normals) c.array(m.mesh.normals, nv, "normals");
  c.array(m.mesh.labels, nv, "labels");
  c.skip_zeros(label_padding(nv), "label padding");
  c.array(m.mesh.triangles, static_cast<std::size_t>(t), "triangles");
  validate_mesh_in(m.mesh, c.where());
  return m;
}

}  // namespace

MeshSequenceReader::MeshSequenceReader(const fs::path& path) : source_(std::make_unique<Source>()) {
  require_little_endian();
  Source& s = *source_;
  s.path = path;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) s.fail("not found or not a regular file");
  s.size = fs::file_size(path, ec);
  if (ec) s.fail("cannot read its size: " + ec.message());
  s.in.open(path, std::ios::binary);
  if (!s.in) s.fail(std::string("cannot open: ") + std::strerror(errno));

  unsigned char header[kHeaderBytes];
  s.read_exact(header, kHeaderBytes, "file header");
  if (std::memcmp(header, kMagic, sizeof(kMagic)) != 0)
    s.fail("field 'magic' does not match: not a tsf mesh sequence (.tsfmesh) file");
  std::uint32_t version = 0, flags = 0;
  std::memcpy(&version, header + 8, 4);
  std::memcpy(&flags, header + 12, 4);
  if (version != kMeshSequenceVersion)
    s.fail("field 'version' = " + std::to_string(version) + ", this build reads version " +
           std::to_string(kMeshSequenceVersion));
  if (flags != 0) s.fail("field 'flags' = " + std::to_string(flags) + ", expected 0");

  Source::Record record;
  s.read_record(record, "GEOM");
  if (record.tag != "GEOM")
    s.fail("record 0 is '" + record.tag + "', expected 'GEOM' (the volume geometry)");
  PayloadCursor geom(record.payload, describe(path.string(), 0, "GEOM", record.offset));
  geometry_ = parse_geometry(geom);

  s.read_record(record, "rest MESH");
  if (record.tag != "MESH")
    s.fail("record 1 is '" + record.tag + "', expected 'MESH' (the rest mesh)");
  PayloadCursor rest(record.payload, describe(path.string(), 1, "rest MESH", record.offset));
  ParsedMesh parsed = parse_mesh(rest);
  if (parsed.kind != kKindRest)
    rest.fail("field 'kind' = 1, expected 0 (the rest mesh comes first)");
  if (!std::isfinite(parsed.time_s)) rest.fail("field 'time_s' is not finite");
  rest_ = std::move(parsed.mesh);
  rest_time_s_ = parsed.time_s;
  last_time_s_ = rest_time_s_;
  current_ = rest_;
}

MeshSequenceReader::~MeshSequenceReader() = default;

bool MeshSequenceReader::next_frame(MeshFrame& frame) {
  if (ended_) return false;
  Source& s = *source_;
  Source::Record record;
  const std::string expect = frame_name(frames_read_) + " or END";
  s.read_record(record, expect);
  const std::size_t index = s.record_index - 1;
  if (record.tag == "END ") {
    PayloadCursor c(record.payload, describe(s.path.string(), index, "END", record.offset));
    if (c.size() != 8)
      c.fail("field 'payload_bytes' = " + std::to_string(c.size()) + ", expected 8");
    const auto count = c.scalar<std::uint64_t>("frame_count");
    if (count != frames_read_)
      c.fail("field 'frame_count' = " + std::to_string(count) + " but the file holds " +
             std::to_string(frames_read_) + " frames");
    if (s.left() != 0)
      s.fail(std::to_string(s.left()) + " bytes follow the END record (corrupt file)");
    ended_ = true;
    return false;
  }
  const std::string what = frame_name(frames_read_) + " " + record.tag;
  PayloadCursor c(record.payload, describe(s.path.string(), index, what, record.offset));
  frame = MeshFrame{};
  if (record.tag == "MESH") {
    ParsedMesh parsed = parse_mesh(c);
    if (parsed.kind != kKindFrame)
      c.fail("field 'kind' = 0, expected 1 (only the first MESH is the rest state)");
    frame.time_s = parsed.time_s;
    frame.topology_changed = true;
    current_ = std::move(parsed.mesh);
    frame.positions = current_.positions;
    frame.normals = current_.normals;
    frame.labels = current_.labels;
    frame.triangles = current_.triangles;
  } else if (record.tag == "POSE") {
    if (c.size() < kPoseFixedBytes)
      c.fail("field 'payload_bytes' = " + std::to_string(c.size()) + " is below the " +
             std::to_string(kPoseFixedBytes) + " bytes of the fixed fields");
    frame.time_s = c.scalar<double>("time_s");
    const bool normals = parse_flags(c) & kFlagNormals;
    if (c.scalar<std::uint32_t>("reserved") != 0) c.fail("field 'reserved' is not zero");
    const auto v = c.scalar<std::uint64_t>("V");
    check_sizes(c, v, 0, normals, false);
    if (v != current_.positions.size())
      c.fail("field 'V' = " + std::to_string(v) + " but the topology in force has " +
             std::to_string(current_.positions.size()) + " vertices");
    c.array(frame.positions, static_cast<std::size_t>(v), "positions");
    if (normals) c.array(frame.normals, static_cast<std::size_t>(v), "normals");
    validate_vectors(frame.positions, "positions", c.where());
    validate_vectors(frame.normals, "normals", c.where());
    current_.positions = frame.positions;
    current_.normals = frame.normals;
  } else {
    c.fail("field 'tag' = '" + record.tag + "', expected 'MESH', 'POSE' or 'END '");
  }
  if (!(std::isfinite(frame.time_s) && frame.time_s > last_time_s_))
    c.fail("field 'time_s' = " + std::to_string(frame.time_s) +
           " must be finite and later than the previous state's " + std::to_string(last_time_s_));
  last_time_s_ = frame.time_s;
  ++frames_read_;
  return true;
}

MeshSequence read_mesh_sequence(const fs::path& path) {
  MeshSequenceReader reader(path);
  MeshSequence sequence;
  sequence.geometry = reader.geometry();
  sequence.rest = reader.rest();
  sequence.rest_time_s = reader.rest_time_s();
  MeshFrame frame;
  while (reader.next_frame(frame)) sequence.frames.push_back(std::move(frame));
  return sequence;
}

bool is_mesh_sequence_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char head[sizeof(kMagic)] = {};
  if (!in.read(reinterpret_cast<char*>(head), sizeof(head))) return false;
  return std::memcmp(head, kMagic, sizeof(kMagic)) == 0;
}

}  // namespace tsf::io

#include "tsf/import/volume_file_reader.h"

#include <itkByteSwapper.h>
#include <itkImageFileReader.h>
#include <itkImageIOBase.h>
#include <itkImageIOFactory.h>

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <new>
#include <sstream>
#include <vector>

#include "geometry_limits.h"
#include "image_buffers.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/common/text_format.h"
#include "tsf/import/imaging_library_setup.h"
#include "tsf/import/volume_statistics.h"

namespace tsf::import {
namespace fs = std::filesystem;

namespace {

/// zlib/gzip cannot compress better than about 1032:1; with margin, a compressed file smaller
/// than 1/1100 of the voxel bytes its header declares cannot hold them.
constexpr double kMaxDeflateRatio = 1100;
/// Header text is read up to this size when looking for data-file fields.
constexpr std::size_t kMaxHeaderText = 1 << 20;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

std::uint64_t file_size_or_zero(const fs::path& p) {
  std::error_code ec;
  const auto n = fs::file_size(p, ec);
  return ec ? 0 : static_cast<std::uint64_t>(n);
}

struct HeaderField {
  std::string key, value;
  int line = 0;
};

/// Every number of a geometry field is finite and within ±kMaxCoordinateMm ("none" stands for a
/// non-spatial NRRD axis): ITK's readers turn NaN into 0 or 1, overflow a 1e300 spacing into a
/// default, or abort in vnl on a non-finite NIfTI sform.
void check_geometry_fields(const std::vector<HeaderField>& fields, const std::string& where) {
  for (const HeaderField& f : fields) {
    std::string text = f.value;
    for (char& c : text)
      if (c == '(' || c == ')' || c == ',') c = ' ';
    std::istringstream tokens(text);
    std::string t;
    while (tokens >> t) {
      if (t == "none") continue;
      char* end = nullptr;
      const double v = std::strtod(t.c_str(), &end);
      if (!end || *end != '\0' || !std::isfinite(v) || !(std::abs(v) <= kMaxCoordinateMm))
        throw Error(where + (f.line > 0 ? "line " + std::to_string(f.line) + ", " : "") + f.key +
                    " is '" + f.value + "': '" + t + "' is not a finite number within ±" +
                    format_text("%g", kMaxCoordinateMm) + " mm");
    }
  }
}

/// Where the voxel bytes of a volume file live, from its header text.
struct DataLocation {
  bool known = false;  ///< false: a layout these checks do not model (lists, text encodings)
  std::uint64_t available_bytes = 0;
  bool compressed = false;
  bool deflate = false;  ///< gzip/zlib: the compression-ratio bound applies
  bool has_space = false;
  fs::path data_path;             ///< the file holding the voxel bytes
  std::uint64_t data_offset = 0;  ///< where they start in it
  /// Header fields that place or scale the volume: (key as written, value, line; 0 = binary).
  std::vector<HeaderField> geometry;
};

DataLocation locate_nrrd_data(const fs::path& path) {
  DataLocation loc;
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::size_t header_bytes = 0;
  std::string encoding = "raw", data_file;
  bool ended = false;
  int line_number = 0;
  while (header_bytes < kMaxHeaderText && std::getline(in, line)) {
    header_bytes += line.size() + 1;
    ++line_number;
    line.resize(std::min(line.size(), line.find('\0')));  // teem reads lines as C strings
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) {
      ended = true;
      break;
    }
    if (line[0] == '#') continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = lower(trim(line.substr(0, colon)));
    std::string value = trim(line.substr(colon + 1));
    if (!value.empty() && value[0] == '=') continue;  // key:=value metadata
    if (key == "encoding") encoding = lower(value);
    if (key == "data file" || key == "datafile") data_file = value;
    if (key == "space" || key == "space directions" || key == "space origin") loc.has_space = true;
    if (key == "space directions" || key == "space origin" || key == "spacings")
      loc.geometry.push_back({trim(line.substr(0, colon)), value, line_number});
  }
  loc.compressed =
      encoding == "gzip" || encoding == "gz" || encoding == "bzip2" || encoding == "bz2";
  loc.deflate = encoding == "gzip" || encoding == "gz";
  const bool binary = encoding == "raw" || loc.compressed;
  if (!binary) return loc;
  if (data_file.empty()) {
    if (!ended) return loc;
    const std::uint64_t total = file_size_or_zero(path);
    loc.available_bytes = total > header_bytes ? total - header_bytes : 0;
    loc.known = true;
    loc.data_path = path;
    loc.data_offset = header_bytes;
  } else if (data_file.find(' ') == std::string::npos && data_file.find('%') == std::string::npos &&
             lower(data_file) != "list") {
    loc.data_path = path.parent_path() / data_file;
    loc.available_bytes = file_size_or_zero(loc.data_path);
    loc.known = true;
  }
  return loc;
}

DataLocation locate_meta_data(const fs::path& path) {
  DataLocation loc;
  std::size_t header_bytes = 0;
  std::size_t consumed = 0;
  std::ifstream in(path, std::ios::binary);
  std::string line, data_file;
  int line_number = 0;
  while (consumed < kMaxHeaderText && std::getline(in, line)) {
    consumed += line.size() + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto eq = line.find('=');
    if (trim(line).empty()) continue;
    // MetaIO reads a key up to the next '=' (across lines) into fixed buffers: a line without
    // one, or a key longer than a field name, overflowed them.
    if (eq == std::string::npos || eq > 64)
      throw Error("'" + path.string() + "': line " + std::to_string(line_number) +
                  " is not 'Key = value' with a key of at most 64 characters");
    const std::string key = lower(trim(line.substr(0, eq)));
    const std::string value = trim(line.substr(eq + 1));
    if (key == "compresseddata") loc.compressed = loc.deflate = lower(value) == "true";
    // MetaIO loops and sizes its arrays by NDims before anything else is checked.
    if (key == "ndims" && value != "2" && value != "3" && value != "4")
      throw Error("'" + path.string() + "': line " + std::to_string(line_number) + ", NDims is '" +
                  value.substr(0, 32) + "': expected 2, 3 or 4");
    for (const char* g : {"offset", "origin", "position", "elementspacing", "elementsize",
                          "transformmatrix", "rotation", "orientation"})
      if (key == g) loc.geometry.push_back({trim(line.substr(0, eq)), value, line_number});
    if (key == "elementdatafile") {
      // A file list or a numbered pattern ("name%03d.raw first last step") is refused: MetaIO
      // divides by the step and reads any file the list names.
      if (lower(value) == "list" || value.find_first_of(" \t%") != std::string::npos)
        throw Error("'" + path.string() + "': line " + std::to_string(line_number) +
                    ", ElementDataFile is '" + value.substr(0, 64) +
                    "': expected LOCAL or one data file name");
      data_file = value;
      header_bytes = consumed;
      break;
    }
  }
  if (data_file.empty()) return loc;
  if (lower(data_file) == "local") {
    const std::uint64_t total = file_size_or_zero(path);
    loc.available_bytes = total > header_bytes ? total - header_bytes : 0;
    loc.known = true;
    loc.data_path = path;
    loc.data_offset = header_bytes;
  } else {  // one data file (lists and patterns were refused above)
    loc.data_path = path.parent_path() / data_file;
    loc.available_bytes = file_size_or_zero(loc.data_path);
    loc.known = true;
  }
  return loc;
}

/// The NIfTI-1 header fields that place and scale the volume (those its qform_code and
/// sform_code put in use), as text for check_geometry_fields. NIfTI-2 headers (540 bytes) are
/// left to ITK; a header of any other size is refused (ITK's reader took one for NIfTI and
/// aborted in vnl on its garbage).
std::vector<HeaderField> nifti_geometry_fields(const fs::path& path, bool gzipped) {
  unsigned char h[348] = {};
  int n = 0;
  if (gzipped) {
    gzFile gz = gzopen(path.c_str(), "rb");
    if (!gz) return {};
    n = gzread(gz, h, sizeof h);
    int code = Z_OK;
    const std::string message = n < 0 ? gzerror(gz, &code) : "";
    gzclose(gz);
    if (n < 0)  // a small file is inflated whole here, trailer included
      throw Error("'" + path.string() + "': the compressed data fail their check: " + message);
  } else {
    std::ifstream in(path, std::ios::binary);
    in.read(reinterpret_cast<char*>(h), sizeof h);
    n = static_cast<int>(in.gcount());
  }
  if (n != static_cast<int>(sizeof h))
    throw Error("'" + path.string() + "': shorter than a NIfTI header (348 bytes)");
  std::int32_t size = 0;
  std::memcpy(&size, h, 4);
  const auto swapped_size =
      static_cast<std::int32_t>(__builtin_bswap32(static_cast<std::uint32_t>(size)));
  if (size == 540 || swapped_size == 540) return {};
  if (size != 348 && swapped_size != 348)
    throw Error("'" + path.string() + "': sizeof_hdr is " + std::to_string(size) +
                ": expected 348 (NIfTI-1) or 540 (NIfTI-2)");
  const bool swapped = size != 348;
  auto i16 = [&](int at) {
    std::uint16_t v = 0;
    std::memcpy(&v, h + at, 2);
    return static_cast<std::int16_t>(swapped ? __builtin_bswap16(v) : v);
  };
  auto f32 = [&](int at) {
    std::uint32_t v = 0;
    std::memcpy(&v, h + at, 4);
    if (swapped) v = __builtin_bswap32(v);
    float f = 0;
    std::memcpy(&f, &v, 4);
    return f;
  };
  std::vector<HeaderField> fields;
  auto add = [&](const std::string& key, int at) {
    fields.push_back({key, format_text("%g", static_cast<double>(f32(at)))});
  };
  for (int i = 1; i <= 3; ++i) add("pixdim[" + std::to_string(i) + "]", 76 + 4 * i);
  if (i16(252) > 0) {
    const char* names[6] = {"quatern_b", "quatern_c", "quatern_d",
                            "qoffset_x", "qoffset_y", "qoffset_z"};
    for (int i = 0; i < 6; ++i) add(names[i], 256 + 4 * i);
  }
  if (i16(254) > 0)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        add(std::string("srow_") + "xyz"[r] + "[" + std::to_string(c) + "]", 280 + 16 * r + 4 * c);
  return fields;
}

DataLocation locate_nifti_data(const fs::path& path) {
  DataLocation loc;
  loc.known = true;
  loc.available_bytes = file_size_or_zero(path);
  loc.compressed = loc.deflate = ends_with(lower(path.filename().string()), ".gz");
  loc.data_path = path;
  loc.geometry = nifti_geometry_fields(path, loc.compressed);
  return loc;
}

/// Inflates the compressed voxel data of `loc` to nowhere, so that zlib checks every gzip
/// member's CRC-32 and length (or a zlib stream's Adler-32): ITK's readers stop once they have
/// the voxels, before the trailer, so flipped bits in a gzip NRRD decoded as valid voxels. The
/// data must end with a complete stream and decompress to at least `min_bytes` and at most
/// 2·min_bytes + 1 MiB (a gzip bomb is cut off, not inflated for ages).
void check_deflate_stream(const DataLocation& loc, std::uint64_t min_bytes,
                          const std::string& where) {
  std::ifstream in(loc.data_path, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(loc.data_offset));
  z_stream z{};
  if (!in || inflateInit2(&z, 15 + 32) != Z_OK)  // 15 + 32: gzip or zlib, detected
    throw Error(where + "cannot read its compressed data");
  std::vector<unsigned char> input(1 << 16), output(1 << 18);
  const std::uint64_t max_bytes = 2 * min_bytes + (1u << 20);
  std::uint64_t total = 0;
  bool ended = false;
  std::string problem;
  while (problem.empty()) {
    if (z.avail_in == 0) {
      in.read(reinterpret_cast<char*>(input.data()), static_cast<std::streamsize>(input.size()));
      z.next_in = input.data();
      z.avail_in = static_cast<uInt>(in.gcount());
      if (z.avail_in == 0) break;
    }
    if (ended) {  // after a complete member only another gzip member may follow
      if (z.avail_in < 2 || z.next_in[0] != 0x1f || z.next_in[1] != 0x8b) {
        problem = "bytes follow the end of the compressed stream";
        break;
      }
      inflateReset(&z);
      ended = false;
    }
    z.next_out = output.data();
    z.avail_out = static_cast<uInt>(output.size());
    const int r = inflate(&z, Z_NO_FLUSH);
    total += output.size() - z.avail_out;
    if (r == Z_STREAM_END)
      ended = true;
    else if (r != Z_OK && r != Z_BUF_ERROR)
      problem = z.msg ? z.msg : "corrupt compressed data";
    if (total > max_bytes)
      problem = "it decompresses to more than " + std::to_string(max_bytes) + " bytes";
  }
  inflateEnd(&z);
  if (problem.empty() && !ended) problem = "the compressed stream is cut short (no trailer)";
  if (problem.empty() && total < min_bytes)
    problem = "it decompresses to " + std::to_string(total) + " bytes, fewer than the " +
              std::to_string(min_bytes) + " the header declares";
  if (!problem.empty())
    throw Error(where + "the compressed voxel data fail their check: " + problem + " (" +
                loc.data_path.string() + ")");
}

/// The checksum at the end of a deflate stream: gzip's CRC-32 and length (mod 2^32), or zlib's
/// Adler-32. `prefix` is what the stream decompresses to before the voxels (a NIfTI header and
/// extensions; empty for NRRD and MetaImage).
struct DeflateTrailer {
  bool gzip = false, zlib = false;
  std::uint32_t check = 0, length = 0;
  std::vector<unsigned char> prefix;
};

/// Reads the trailer of the stream of `loc` and, for NIfTI, inflates the header and extensions
/// in front of the voxels (a few hundred bytes). `usable` is false where this shortcut does not
/// apply (the full check then runs).
DeflateTrailer read_deflate_trailer(const DataLocation& loc, const std::string& format,
                                    bool& usable) {
  usable = false;
  DeflateTrailer t;
  std::ifstream in(loc.data_path, std::ios::binary);
  unsigned char head[2] = {0, 0};
  in.seekg(static_cast<std::streamoff>(loc.data_offset));
  in.read(reinterpret_cast<char*>(head), 2);
  if (!in || loc.available_bytes < 18) return t;
  const std::uint64_t end = loc.data_offset + loc.available_bytes;
  unsigned char tail[8] = {};
  in.seekg(static_cast<std::streamoff>(end - 8));
  in.read(reinterpret_cast<char*>(tail), 8);
  if (!in) return t;
  if (head[0] == 0x1f && head[1] == 0x8b) {
    t.gzip = true;
    t.check = std::uint32_t{tail[0]} | (std::uint32_t{tail[1]} << 8) |
              (std::uint32_t{tail[2]} << 16) | (std::uint32_t{tail[3]} << 24);
    t.length = std::uint32_t{tail[4]} | (std::uint32_t{tail[5]} << 8) |
               (std::uint32_t{tail[6]} << 16) | (std::uint32_t{tail[7]} << 24);
  } else if ((head[0] & 0x0F) == 8 && ((unsigned{head[0]} << 8) | head[1]) % 31 == 0) {
    t.zlib = true;
    t.check = (std::uint32_t{tail[4]} << 24) | (std::uint32_t{tail[5]} << 16) |
              (std::uint32_t{tail[6]} << 8) | tail[7];
  } else {
    return t;
  }
  if (format == "nifti") {
    if (!t.gzip) return t;
    // The header and extensions up to vox_offset come first in the stream.
    in.clear();
    in.seekg(static_cast<std::streamoff>(loc.data_offset));
    z_stream z{};
    if (inflateInit2(&z, 15 + 16) != Z_OK) return t;
    std::vector<unsigned char> input(1 << 14), out(1 << 16);
    std::size_t have = 0, want = 540;
    bool sized = false;
    while (have < want) {
      if (z.avail_in == 0) {
        in.read(reinterpret_cast<char*>(input.data()), static_cast<std::streamsize>(input.size()));
        z.next_in = input.data();
        z.avail_in = static_cast<uInt>(in.gcount());
        if (z.avail_in == 0) break;
      }
      z.next_out = out.data() + have;
      z.avail_out = static_cast<uInt>(want - have);
      const int r = inflate(&z, Z_NO_FLUSH);
      have = want - z.avail_out;
      if (r != Z_OK) break;
      if (!sized && have >= 348) {
        // NIfTI-1: sizeof_hdr 348, vox_offset a float at 108; NIfTI-2: 540, an int64 at 168.
        std::int32_t size = 0;
        std::memcpy(&size, out.data(), 4);
        double offset = -1;
        if (size == 348) {
          float v = 0;
          std::memcpy(&v, out.data() + 108, 4);
          offset = v;
        } else if (size == 540 && have >= 540) {
          std::int64_t v = 0;
          std::memcpy(&v, out.data() + 168, 8);
          offset = static_cast<double>(v);
        } else if (size != 540) {
          break;
        } else {
          continue;
        }
        sized = true;
        if (!(offset >= 348 && offset <= static_cast<double>(out.size()))) break;
        want = static_cast<std::size_t>(offset);
      }
    }
    inflateEnd(&z);
    if (!sized || have != want) return t;
    t.prefix.assign(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(want));
  }
  usable = true;
  return t;
}

/// Whether `bytes` (the voxel data as the file stores them after `t.prefix`) are what the stream
/// of `t` checksums: the CRC-32 of prefix + voxels and their length (gzip) or their Adler-32.
/// `swap` undoes a byte-order swap of `component` bytes the reader made.
bool matches_trailer(const DeflateTrailer& t, const unsigned char* bytes, std::size_t n,
                     std::size_t component, bool swap) {
  uLong sum = t.gzip ? crc32(0L, Z_NULL, 0) : adler32(0L, Z_NULL, 0);
  auto add = [&](const unsigned char* p, std::size_t k) {
    while (k > 0) {
      const uInt step = static_cast<uInt>(std::min<std::size_t>(k, 1u << 30));
      sum = t.gzip ? crc32(sum, p, step) : adler32(sum, p, step);
      p += step;
      k -= step;
    }
  };
  add(t.prefix.data(), t.prefix.size());
  if (!swap || component < 2) {
    add(bytes, n);
  } else {
    std::vector<unsigned char> chunk(1 << 16);
    const std::size_t per = chunk.size() / component * component;
    for (std::size_t at = 0; at < n; at += per) {
      const std::size_t k = std::min(per, n - at);
      for (std::size_t i = 0; i < k; i += component)
        for (std::size_t b = 0; b < component; ++b)
          chunk[i + b] = bytes[at + i + component - 1 - b];
      add(chunk.data(), k);
    }
  }
  if (sum != t.check) return false;
  return !t.gzip || t.length == static_cast<std::uint32_t>((t.prefix.size() + n) & 0xFFFFFFFFu);
}

/// Where the voxel bytes of the volume file `path` live; `format` is set to nrrd, metaimage or
/// nifti.
DataLocation locate_data(const fs::path& path, std::string& format) {
  const std::string name = lower(path.filename().string());
  if (ends_with(name, ".nrrd") || ends_with(name, ".nhdr")) {
    format = "nrrd";
    return locate_nrrd_data(path);
  }
  if (ends_with(name, ".mha") || ends_with(name, ".mhd")) {
    format = "metaimage";
    return locate_meta_data(path);
  }
  format = "nifti";
  return locate_nifti_data(path);
}

itk::ImageIOBase::Pointer create_io(const fs::path& path) {
  setup_imaging_libraries();
  auto io = itk::ImageIOFactory::CreateImageIO(path.string().c_str(),
                                               itk::CommonEnums::IOFileMode::ReadMode);
  if (!io)
    throw Error("'" + path.string() +
                "' is not a readable NRRD, MetaImage or NIfTI file (no ITK reader accepts it)");
  return io;
}

}  // namespace

bool is_volume_file_path(const fs::path& path) {
  const std::string name = lower(path.filename().string());
  for (const char* ext : {".nrrd", ".nhdr", ".mha", ".mhd", ".nii", ".nii.gz"})
    if (ends_with(name, ext)) return true;
  return false;
}

VolumeFileHeader inspect_volume_file(const fs::path& path, std::int64_t max_voxels) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw Error("'" + path.string() + "' is not a file");
  VolumeFileHeader h;
  const DataLocation loc = locate_data(path, h.format);
  h.has_patient_orientation = h.format != "nrrd" || loc.has_space;

  const std::string where = "'" + path.string() + "': ";
  check_geometry_fields(loc.geometry, where);
  auto io = create_io(path);
  io->SetFileName(path.string());
  try {
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    throw Error("cannot read the header of '" + path.string() + "': " + e.GetDescription());
  } catch (const std::exception& e) {  // the readers' own parsing (std::stod, std::vector, ...)
    throw Error("cannot read the header of '" + path.string() + "': " + e.what());
  }
  const unsigned nd = io->GetNumberOfDimensions();
  if (nd < 2 || nd > 4 || (nd == 4 && io->GetDimensions(3) != 1))
    throw Error(where + std::to_string(nd) + "-D image, expected a 3-D volume");
  if (io->GetNumberOfComponents() != 1)
    throw Error(where + std::to_string(io->GetNumberOfComponents()) +
                " components per voxel, expected a scalar (grey-scale) volume");
  h.dimensions = static_cast<int>(std::min(nd, 3u));
  double voxels = 1;
  for (unsigned a = 0; a < 3; ++a) {
    const double size = a < nd ? static_cast<double>(io->GetDimensions(a)) : 1.0;
    if (size < 1)
      throw Error(where + "size " + format_text("%.0f", size) + " along axis " + std::to_string(a) +
                  " (expected at least 1)");
    voxels *= size;
    if (size > 2147483647.0)
      throw Error(where + "size " + format_text("%.0f", size) + " along axis " + std::to_string(a) +
                  " is out of range");
    h.dims[static_cast<int>(a)] = static_cast<int>(size);
    h.spacing[static_cast<int>(a)] = a < nd ? io->GetSpacing(a) : 1.0;
    h.origin[static_cast<int>(a)] = a < nd ? io->GetOrigin(a) : 0.0;
    for (unsigned r = 0; r < 3; ++r) {
      const double d = (a < nd && r < nd) ? io->GetDirection(a)[r] : (a == r ? 1.0 : 0.0);
      h.direction[r * 3 + a] = d;
    }
  }
  if (voxels > static_cast<double>(max_voxels))
    throw Error(where + "the header claims " + format_text("%.0f", voxels) + " voxels (" +
                std::to_string(h.dims.x) + "×" + std::to_string(h.dims.y) + "×" +
                std::to_string(h.dims.z) + "), more than the limit of " +
                std::to_string(max_voxels) + ": refused before allocating");
  // GetComponentSize throws for a type ITK could not name (an unknown MetaImage ElementType).
  if (io->GetComponentType() == itk::CommonEnums::IOComponent::UNKNOWNCOMPONENTTYPE)
    throw Error(where + "the voxel type is not one ITK reads (expected an integer or float type)");
  h.component_type = itk::ImageIOBase::GetComponentTypeAsString(io->GetComponentType());
  h.voxel_bytes = static_cast<std::uint64_t>(voxels) * io->GetComponentSize();
  h.available_bytes = loc.available_bytes;
  h.compressed = loc.compressed;
  if (loc.known && !loc.compressed && loc.available_bytes < h.voxel_bytes)
    throw Error(where + "the header declares " + std::to_string(h.voxel_bytes) +
                " bytes of voxel data but the file holds only " +
                std::to_string(loc.available_bytes) + ": truncated or a false header");
  if (loc.known && loc.deflate &&
      static_cast<double>(loc.available_bytes) * kMaxDeflateRatio <
          static_cast<double>(h.voxel_bytes))
    throw Error(where + "the header declares " + std::to_string(h.voxel_bytes) +
                " bytes of voxel data but only " + std::to_string(loc.available_bytes) +
                " compressed bytes follow (gzip cannot compress more than ~1000:1): a false "
                "header");
  if (h.dims.z < 2)
    throw Error(where + "a single slice (" + std::to_string(h.dims.x) + "×" +
                std::to_string(h.dims.y) + "), expected a volume of at least 2 slices");

  for (int a = 0; a < 3; ++a) {
    if (!(h.spacing[a] > 0 && h.spacing[a] <= kMaxSpacingMm))
      throw Error(where + "spacing " + format_text("%g", h.spacing[a]) + " along axis " +
                  std::to_string(a) + " (expected a number of mm in (0, " +
                  format_text("%g", kMaxSpacingMm) + "])");
    if (!(std::abs(h.origin[a]) <= kMaxCoordinateMm))
      throw Error(where + "origin " + format_text("%g", h.origin[a]) + " along axis " +
                  std::to_string(a) + " (expected a finite number of mm within ±" +
                  format_text("%g", kMaxCoordinateMm) + ")");
  }
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b) {
      double d = 0;
      for (int r = 0; r < 3; ++r) d += h.direction[r * 3 + a] * h.direction[r * 3 + b];
      const double expected = a == b ? 1.0 : 0.0;
      if (!(std::abs(d - expected) < 1e-3))
        throw Error(where + "the direction matrix is not orthonormal (axes " + std::to_string(a) +
                    "·" + std::to_string(b) + " = " + format_text("%.4f", d) +
                    "): sheared volumes are not supported, resample it onto an orthogonal grid");
    }
  return h;
}

namespace {

/// ITK's reader, values converted to float.
HuImage::Pointer read_with_itk(const fs::path& path, const VolumeFileHeader& h) {
  auto io = create_io(path);
  auto reader = itk::ImageFileReader<HuImage>::New();
  reader->SetImageIO(io);
  reader->SetFileName(path.string());
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error("cannot read '" + path.string() + "': " + e.GetDescription());
  } catch (const std::bad_alloc&) {
    throw Error("not enough memory to read '" + path.string() + "' (" +
                std::to_string(h.dims.volume()) + " voxels)");
  } catch (const std::exception& e) {  // the readers' own parsing (std::stod, std::vector, ...)
    throw Error("cannot read '" + path.string() + "': " + e.what());
  }
  HuImage::Pointer image = reader->GetOutput();
  image->DisconnectPipeline();
  image->SetMetaDataDictionary(itk::MetaDataDictionary());  // nothing from the source header
  return image;
}

/// The voxels as the file stores them (ITK's ImageIO, decompressed, in this machine's byte
/// order), checked against the stream's trailer, then converted to float as ImageFileReader
/// does. A mismatch runs the full stream check, which names the damage.
HuImage::Pointer read_checksummed(const fs::path& path, const DataLocation& loc,
                                  const DeflateTrailer& trailer, const VolumeFileHeader& h,
                                  const std::string& where) {
  auto io = create_io(path);
  io->SetFileName(path.string());
  const std::size_t n = static_cast<std::size_t>(h.dims.volume());
  std::vector<unsigned char> raw;
  try {
    io->ReadImageInformation();
    const unsigned nd = io->GetNumberOfDimensions();
    itk::ImageIORegion region(nd);
    for (unsigned a = 0; a < nd; ++a) {
      region.SetIndex(a, 0);
      region.SetSize(a, io->GetDimensions(a));
    }
    io->SetIORegion(region);
    raw.resize(static_cast<std::size_t>(io->GetImageSizeInBytes()));
    io->Read(raw.data());
  } catch (const itk::ExceptionObject& e) {
    check_deflate_stream(loc, h.voxel_bytes, where);  // names the damage when there is one
    throw Error("cannot read '" + path.string() + "': " + e.GetDescription());
  } catch (const std::bad_alloc&) {
    throw Error("not enough memory to read '" + path.string() + "' (" + std::to_string(n) +
                " voxels)");
  } catch (const std::exception& e) {
    check_deflate_stream(loc, h.voxel_bytes, where);
    throw Error("cannot read '" + path.string() + "': " + e.what());
  }
  const std::size_t component = io->GetComponentSize();
  const bool swapped = io->GetByteOrder() != itk::CommonEnums::IOByteOrder::OrderNotApplicable &&
                       ((io->GetByteOrder() == itk::CommonEnums::IOByteOrder::BigEndian) !=
                        itk::ByteSwapper<int>::SystemIsBigEndian());
  if (raw.size() != n * component ||
      !matches_trailer(trailer, raw.data(), raw.size(), component, swapped))
    check_deflate_stream(loc, h.voxel_bytes, where);  // throws unless the stream is sound

  OrthogonalGrid grid;
  grid.dims = h.dims;
  grid.spacing = h.spacing;
  grid.origin = h.origin;
  for (int a = 0; a < 3; ++a)
    grid.axes[static_cast<std::size_t>(a)] = {h.direction[a], h.direction[3 + a],
                                              h.direction[6 + a]};
  HuImage::Pointer image = make_hu_image(grid);
  if (!convert_to_float(io->GetComponentType(), raw.data(), n, image->GetBufferPointer()))
    throw Error(where + "the voxel type is not one ITK reads (expected an integer or float type)");
  return image;
}

}  // namespace

HuImage::Pointer read_volume_file(const fs::path& path, const ImportOptions& options,
                                  ImportReport& report) {
  Stopwatch clock;
  const VolumeFileHeader h = inspect_volume_file(path, options.max_voxels);
  // Compressed voxel data are checked against their stream's checksum (CRC-32 and length, or
  // Adler-32): ITK's readers stop once they have the voxels, before the trailer. The fast way
  // checksums the bytes ITK decompressed (one inflate, one CRC pass); where that does not apply
  // or does not match, the whole stream is inflated once more for the exact reason
  // (check_deflate_stream).
  std::string format;
  const DataLocation loc = locate_data(path, format);
  const std::string where = "'" + path.string() + "': ";
  const bool deflate = loc.known && loc.deflate && !loc.data_path.empty();
  bool fast = false;
  const DeflateTrailer trailer =
      deflate ? read_deflate_trailer(loc, format, fast) : DeflateTrailer{};
  if (deflate && !fast) check_deflate_stream(loc, h.voxel_bytes, where);
  HuImage::Pointer image =
      fast ? read_checksummed(path, loc, trailer, h, where) : read_with_itk(path, h);

  const VolumeStatistics stats =
      volume_statistics(image->GetBufferPointer(), static_cast<std::size_t>(h.dims.volume()));
  if (stats.non_finite > 0)
    throw Error("'" + path.string() + "': " + std::to_string(stats.non_finite) +
                " voxels are NaN or infinite (first at index " +
                std::to_string(stats.first_non_finite) + ")");

  auto& src = report.source;
  src.path = path.string();
  src.kind = h.format;
  src.files_examined = 1;
  src.files_used = 1;
  auto& acq = report.acquisition;
  acq.dims = h.dims;
  acq.pixel_spacing_x = h.spacing.x;
  acq.pixel_spacing_y = h.spacing.y;
  acq.row = {h.direction[0], h.direction[3], h.direction[6]};
  acq.column = {h.direction[1], h.direction[4], h.direction[7]};
  acq.normal = {h.direction[2], h.direction[5], h.direction[8]};
  acq.first_position = h.origin;
  acq.last_position = h.origin + acq.normal * ((h.dims.z - 1) * h.spacing.z);
  acq.span_along_normal_mm = (h.dims.z - 1) * h.spacing.z;
  acq.gaps = {{h.spacing.z, h.dims.z - 1}};
  acq.median_gap_mm = acq.regular_gap_mm = h.spacing.z;

  auto& out = report.output;
  out.dims = h.dims;
  out.spacing = h.spacing;
  out.origin = h.origin;
  out.direction = h.direction;
  out.min_value = stats.min;
  out.max_value = stats.max;
  out.integral_values = stats.integral;

  auto& rescale = report.rescale;
  rescale.pixel_representation = h.component_type;
  rescale.source = h.format == "nifti"
                       ? "NIfTI scl_slope/scl_inter (applied by the reader when set)"
                       : "none: values as stored (the file is taken to hold HU)";
  if (!h.has_patient_orientation)
    report.warnings.push_back(
        "the NRRD header has no 'space' or 'space directions': patient orientation is not "
        "recorded, axes are taken as L, P, S and the origin as 0");
  report.seconds.read = clock.seconds();
  return image;
}

}  // namespace tsf::import

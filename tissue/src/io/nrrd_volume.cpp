#include "tsf/io/nrrd_volume.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include "tsf/common/error.h"
#include "tsf/io/inflate.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::io {
namespace fs = std::filesystem;

namespace {

/// Refuse volumes larger than this many bytes of values (a corrupt `sizes` line must not make
/// the reader allocate the machine's memory).
constexpr std::size_t kMaxBytes = std::size_t{16} << 30;

std::string trim(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool parse_type(const std::string& text, NrrdType& type) {
  static const std::map<std::string, NrrdType> kTypes = {
      {"signed char", NrrdType::kInt8},
      {"int8", NrrdType::kInt8},
      {"int8_t", NrrdType::kInt8},
      {"uchar", NrrdType::kUInt8},
      {"unsigned char", NrrdType::kUInt8},
      {"uint8", NrrdType::kUInt8},
      {"uint8_t", NrrdType::kUInt8},
      {"short", NrrdType::kInt16},
      {"short int", NrrdType::kInt16},
      {"signed short", NrrdType::kInt16},
      {"signed short int", NrrdType::kInt16},
      {"int16", NrrdType::kInt16},
      {"int16_t", NrrdType::kInt16},
      {"ushort", NrrdType::kUInt16},
      {"unsigned short", NrrdType::kUInt16},
      {"unsigned short int", NrrdType::kUInt16},
      {"uint16", NrrdType::kUInt16},
      {"uint16_t", NrrdType::kUInt16},
      {"int", NrrdType::kInt32},
      {"signed int", NrrdType::kInt32},
      {"int32", NrrdType::kInt32},
      {"int32_t", NrrdType::kInt32},
      {"uint", NrrdType::kUInt32},
      {"unsigned int", NrrdType::kUInt32},
      {"uint32", NrrdType::kUInt32},
      {"uint32_t", NrrdType::kUInt32},
      {"longlong", NrrdType::kInt64},
      {"long long", NrrdType::kInt64},
      {"long long int", NrrdType::kInt64},
      {"signed long long", NrrdType::kInt64},
      {"signed long long int", NrrdType::kInt64},
      {"int64", NrrdType::kInt64},
      {"int64_t", NrrdType::kInt64},
      {"ulonglong", NrrdType::kUInt64},
      {"unsigned long long", NrrdType::kUInt64},
      {"unsigned long long int", NrrdType::kUInt64},
      {"uint64", NrrdType::kUInt64},
      {"uint64_t", NrrdType::kUInt64},
      {"float", NrrdType::kFloat},
      {"double", NrrdType::kDouble}};
  const auto it = kTypes.find(lower(text));
  if (it == kTypes.end()) return false;
  type = it->second;
  return true;
}

/// "(x,y,z)" vectors and "none" words of a `space directions` line, in order.
bool parse_directions(const std::string& text, std::vector<std::optional<Vec3d>>& out) {
  std::size_t p = 0;
  while (p < text.size()) {
    if (std::isspace(static_cast<unsigned char>(text[p]))) {
      ++p;
      continue;
    }
    if (text.compare(p, 4, "none") == 0) {
      out.emplace_back(std::nullopt);
      p += 4;
      continue;
    }
    if (text[p] != '(') return false;
    const std::size_t close = text.find(')', p);
    if (close == std::string::npos) return false;
    std::string inner = text.substr(p + 1, close - p - 1);
    std::replace(inner.begin(), inner.end(), ',', ' ');
    std::istringstream s(inner);
    Vec3d v;
    if (!(s >> v.x >> v.y >> v.z)) return false;
    std::string extra;
    if (s >> extra) return false;
    out.emplace_back(v);
    p = close + 1;
  }
  return true;
}

bool parse_vector(const std::string& text, Vec3d& v) {
  std::string t = trim(text);
  if (t.size() < 2 || t.front() != '(' || t.back() != ')') return false;
  std::vector<std::optional<Vec3d>> one;
  if (!parse_directions(t, one) || one.size() != 1 || !one[0]) return false;
  v = *one[0];
  return true;
}

template <typename T>
double read_as(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return static_cast<double>(v);
}

}  // namespace

const char* to_string(NrrdType type) {
  switch (type) {
    case NrrdType::kInt8:
      return "int8";
    case NrrdType::kUInt8:
      return "uint8";
    case NrrdType::kInt16:
      return "int16";
    case NrrdType::kUInt16:
      return "uint16";
    case NrrdType::kInt32:
      return "int32";
    case NrrdType::kUInt32:
      return "uint32";
    case NrrdType::kInt64:
      return "int64";
    case NrrdType::kUInt64:
      return "uint64";
    case NrrdType::kFloat:
      return "float";
    case NrrdType::kDouble:
      return "double";
  }
  return "?";
}

std::size_t value_bytes(NrrdType type) {
  switch (type) {
    case NrrdType::kInt8:
    case NrrdType::kUInt8:
      return 1;
    case NrrdType::kInt16:
    case NrrdType::kUInt16:
      return 2;
    case NrrdType::kInt32:
    case NrrdType::kUInt32:
    case NrrdType::kFloat:
      return 4;
    case NrrdType::kInt64:
    case NrrdType::kUInt64:
    case NrrdType::kDouble:
      return 8;
  }
  return 1;
}

double NrrdVolume::value(std::size_t index) const {
  const std::uint8_t* p = bytes.data() + index * value_bytes(type);
  switch (type) {
    case NrrdType::kInt8:
      return read_as<std::int8_t>(p);
    case NrrdType::kUInt8:
      return read_as<std::uint8_t>(p);
    case NrrdType::kInt16:
      return read_as<std::int16_t>(p);
    case NrrdType::kUInt16:
      return read_as<std::uint16_t>(p);
    case NrrdType::kInt32:
      return read_as<std::int32_t>(p);
    case NrrdType::kUInt32:
      return read_as<std::uint32_t>(p);
    case NrrdType::kInt64:
      return read_as<std::int64_t>(p);
    case NrrdType::kUInt64:
      return read_as<std::uint64_t>(p);
    case NrrdType::kFloat:
      return read_as<float>(p);
    case NrrdType::kDouble:
      return read_as<double>(p);
  }
  return 0.0;
}

std::vector<float> NrrdVolume::as_float() const {
  const std::size_t n = value_count();
  std::vector<float> out(n);
  if (type == NrrdType::kFloat) {
    std::memcpy(out.data(), bytes.data(), n * sizeof(float));
  } else {
    for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<float>(value(i));
  }
  return out;
}

NrrdVolume read_nrrd(const fs::path& path) {
  const std::string name = path.string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("NRRD file '" + name + "': cannot open it (missing or unreadable)");
  std::string line;
  std::getline(in, line);
  if (line.rfind("NRRD000", 0) != 0)
    throw Error("NRRD file '" + name + "': not a NRRD file (its first line is not NRRD000N)");

  std::map<std::string, std::string> field;
  int line_number = 1;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;  // the data follows the blank line
    if (line[0] == '#') continue;
    if (line.find(":=") != std::string::npos && line.find(": ") == std::string::npos) continue;
    const std::size_t colon = line.find(": ");
    if (colon == std::string::npos)
      throw Error("NRRD file '" + name + "', line " + std::to_string(line_number) +
                  ": expected 'field: value', got '" + line + "'");
    field[lower(trim(line.substr(0, colon)))] = trim(line.substr(colon + 2));
  }
  const std::streampos data_start = in.tellg();
  auto fail = [&](const std::string& key, const std::string& why) -> Error {
    return Error("NRRD file '" + name + "': " + key + ": " + why);
  };
  auto get = [&](const std::string& key) -> const std::string* {
    const auto it = field.find(key);
    return it == field.end() ? nullptr : &it->second;
  };

  NrrdVolume v;
  const std::string* type = get("type");
  if (!type) throw fail("type", "missing");
  if (!parse_type(*type, v.type))
    throw fail("type", "'" + *type + "' is not a scalar type this reader knows (int8 … double)");

  const std::string* dimension = get("dimension");
  if (!dimension) throw fail("dimension", "missing");
  const int dim = std::atoi(dimension->c_str());
  if (dim != 3 && dim != 4)
    throw fail("dimension",
               *dimension + ", expected 3 (a scalar volume) or 4 (a vector per voxel)");
  const std::string* sizes = get("sizes");
  if (!sizes) throw fail("sizes", "missing");
  std::vector<long long> size;
  {
    std::istringstream s(*sizes);
    long long x = 0;
    while (s >> x) size.push_back(x);
    if (static_cast<int>(size.size()) != dim || !s.eof())
      throw fail("sizes", "'" + *sizes + "', expected " + std::to_string(dim) + " sizes");
    for (long long n : size)
      if (n < 1 || n > 1'000'000) throw fail("sizes", "'" + *sizes + "': each size in [1, 1e6]");
  }

  // Which axis is per-voxel: in 4-D, the axis whose kind is not `domain`/`space` or whose space
  // direction is `none`; it must be the first (components fastest, as ITK and segment write).
  int vector_axis = -1;
  std::vector<std::optional<Vec3d>> directions;
  const std::string* space = get("space");
  const std::string* space_directions = get("space directions");
  if (space_directions && !parse_directions(*space_directions, directions))
    throw fail("space directions", "'" + *space_directions + "' is not a list of (x,y,z) or none");
  if (space_directions && static_cast<int>(directions.size()) != dim)
    throw fail("space directions", "has " + std::to_string(directions.size()) + " entries for " +
                                       std::to_string(dim) + " axes");
  if (dim == 4) {
    if (!directions.empty()) {
      for (int a = 0; a < 4; ++a)
        if (!directions[a]) {
          if (vector_axis >= 0) throw fail("space directions", "more than one axis is 'none'");
          vector_axis = a;
        }
    } else if (const std::string* kinds = get("kinds")) {
      std::istringstream s(*kinds);
      std::string k;
      for (int a = 0; a < 4 && s >> k; ++a) {
        const std::string kind = lower(k);
        if (kind != "domain" && kind != "space" && vector_axis < 0) vector_axis = a;
      }
    }
    if (vector_axis != 0)
      throw Error("NRRD file '" + name + "': a 4-D volume must have its per-voxel (vector) axis " +
                  "first, the others spatial (sizes: " + *sizes + ")");
    v.components = static_cast<int>(size[0]);
  }
  const int first = dim == 4 ? 1 : 0;
  v.geometry.dims = {static_cast<int>(size[first]), static_cast<int>(size[first + 1]),
                     static_cast<int>(size[first + 2])};

  // Geometry.
  if (space) {
    const std::string s = lower(*space);
    Vec3d flip{1, 1, 1};
    if (s == "left-posterior-superior" || s == "lps" || s == "3d-left-handed") {
    } else if (s == "right-anterior-superior" || s == "ras" || s == "3d-right-handed") {
      flip = {-1, -1, 1};
    } else if (s == "left-anterior-superior" || s == "las") {
      flip = {1, -1, 1};
    } else {
      throw fail("space",
                 "'" + *space +
                     "' is not a patient space this reader knows (left-posterior-superior, "
                     "right-anterior-superior, left-anterior-superior)");
    }
    v.has_space = true;
    if (directions.empty()) throw fail("space directions", "missing (the header names a space)");
    for (int a = 0; a < 3; ++a) {
      const Vec3d d = *directions[first + a];
      const double len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
      if (!(len > 0) || !std::isfinite(len))
        throw fail("space directions", "axis " + std::to_string(a) + " has no length");
      v.geometry.spacing[a] = len;
      v.geometry.direction[0 * 3 + a] = flip.x * d.x / len;
      v.geometry.direction[1 * 3 + a] = flip.y * d.y / len;
      v.geometry.direction[2 * 3 + a] = flip.z * d.z / len;
    }
    if (const std::string* origin = get("space origin")) {
      Vec3d o;
      if (!parse_vector(*origin, o) || !std::isfinite(o.x) || !std::isfinite(o.y) ||
          !std::isfinite(o.z))
        throw fail("space origin", "'" + *origin + "' is not a finite (x,y,z)");
      v.geometry.origin = {flip.x * o.x, flip.y * o.y, flip.z * o.z};
    }
    if (const std::string* units = get("space units")) {
      std::istringstream words(*units);
      std::string u;
      while (words >> u)
        if (u != "\"mm\"" && u != "mm")
          throw fail("space units", *units + ": only millimetres are supported");
    }
  } else if (const std::string* spacings = get("spacings")) {
    std::istringstream s(*spacings);
    std::vector<std::string> words;
    for (std::string w; s >> w;) words.push_back(w);
    if (static_cast<int>(words.size()) != dim)
      throw fail("spacings", "'" + *spacings + "', expected " + std::to_string(dim) + " values");
    for (int a = 0; a < 3; ++a) {
      const double h = std::atof(words[first + a].c_str());
      if (!(h > 0) || !std::isfinite(h))
        throw fail("spacings", "'" + *spacings + "': spatial spacings must be positive");
      v.geometry.spacing[a] = h;
    }
  } else {
    throw Error("NRRD file '" + name +
                "': neither 'space directions' nor 'spacings': the voxel "
                "size is unknown");
  }

  // Data.
  const std::size_t bytes_per = value_bytes(v.type);
  const double total = static_cast<double>(v.geometry.dims.volume()) * v.components * bytes_per;
  if (total > static_cast<double>(kMaxBytes))
    throw fail("sizes", "'" + *sizes + "' would need " + std::to_string(total / (1 << 30)) +
                            " GiB (at most 16)");
  const std::size_t expected = static_cast<std::size_t>(total);
  std::string encoding = lower(get("encoding") ? *get("encoding") : std::string("raw"));
  if (encoding == "gz") encoding = "gzip";
  if (encoding != "raw" && encoding != "gzip")
    throw fail("encoding", "'" + encoding + "', expected raw or gzip");
  if (get("line skip") && std::atoi(get("line skip")->c_str()) != 0)
    throw fail("line skip", "only 0 is supported");
  long long byte_skip = get("byte skip") ? std::atoll(get("byte skip")->c_str()) : 0;
  if (byte_skip < 0) throw fail("byte skip", "-1 (data at the end of the file) is not supported");
  if (byte_skip != 0 && encoding != "raw") throw fail("byte skip", "only with raw encoding");

  std::ifstream detached;
  std::istream* data = &in;
  std::string data_name = name;
  const std::string* data_file = get("data file");
  if (!data_file) data_file = get("datafile");
  if (data_file) {
    if (data_file->find(' ') != std::string::npos || *data_file == "LIST")
      throw fail("data file", "'" + *data_file + "': only one detached file is supported");
    fs::path p(*data_file);
    if (p.is_relative()) p = path.parent_path() / p;
    detached.open(p, std::ios::binary);
    if (!detached)
      throw fail("data file", "'" + p.string() + "' cannot be opened (missing or unreadable)");
    data = &detached;
    data_name = p.string();
  } else {
    in.clear();
    in.seekg(data_start);
  }
  std::vector<std::uint8_t> raw((std::istreambuf_iterator<char>(*data)),
                                std::istreambuf_iterator<char>());
  if (encoding == "gzip") {
    v.bytes = gunzip(raw.data(), raw.size(), expected, "NRRD file '" + data_name + "'");
  } else {
    if (static_cast<std::size_t>(byte_skip) > raw.size())
      raw.clear();
    else
      raw.erase(raw.begin(), raw.begin() + byte_skip);
    v.bytes = std::move(raw);
  }
  if (v.bytes.size() < expected)
    throw Error("NRRD file '" + data_name + "': the data holds " + std::to_string(v.bytes.size()) +
                " bytes, the header's sizes and type need " + std::to_string(expected) +
                " (a truncated file?)");
  v.bytes.resize(expected);  // raw data may be followed by padding

  const std::string* endian = get("endian");
  if (bytes_per > 1) {
    if (!endian)
      throw fail("endian", "missing (needed for " + std::string(to_string(v.type)) + ")");
    const std::string e = lower(*endian);
    if (e != "little" && e != "big")
      throw fail("endian", "'" + *endian + "', expected little or big");
    const std::uint16_t probe = 1;
    std::uint8_t first_byte = 0;
    std::memcpy(&first_byte, &probe, 1);
    const bool host_little = first_byte == 1;
    if ((e == "little") != host_little)
      for (std::size_t i = 0; i < v.bytes.size(); i += bytes_per)
        std::reverse(v.bytes.begin() + static_cast<std::ptrdiff_t>(i),
                     v.bytes.begin() + static_cast<std::ptrdiff_t>(i + bytes_per));
  }
  return v;
}

bool same_volume_geometry(const VolumeGeometry& a, const VolumeGeometry& b) {
  auto close = [](double x, double y) {
    return std::abs(x - y) <= 1e-4 * std::max(1.0, std::abs(x));
  };
  if (a.dims != b.dims) return false;
  for (int i = 0; i < 3; ++i)
    if (!close(a.spacing[i], b.spacing[i]) || !close(a.origin[i], b.origin[i])) return false;
  for (int i = 0; i < 9; ++i)
    if (std::abs(a.direction[i] - b.direction[i]) > 1e-6) return false;
  return true;
}

VoxelVolume read_tissue_volume_nrrd(const fs::path& density_path) {
  const NrrdVolume density = read_nrrd(density_path);
  if (density.components != 1)
    throw Error("density file '" + density_path.string() + "' has " +
                std::to_string(density.components) + " values per voxel, expected 1");
  const VolumeGeometry& g = density.geometry;
  const std::string file = density_path.filename().string();
  const std::string ext = density_path.extension().string();
  const std::string tag = "-density" + ext;
  fs::path labels_path, weights_path;
  if (file.size() > tag.size() && file.compare(file.size() - tag.size(), tag.size(), tag) == 0) {
    const std::string prefix = file.substr(0, file.size() - tag.size());
    labels_path = density_path.parent_path() / (prefix + "-labels" + ext);
    weights_path = density_path.parent_path() / (prefix + "-weights" + ext);
  }
  const bool has_weights = !weights_path.empty() && fs::exists(weights_path);

  VoxelVolume volume(g, has_weights);
  const std::size_t n = volume.voxel_count();
  {
    std::vector<float> values = density.as_float();
    for (std::size_t i = 0; i < n; ++i)
      if (!(values[i] >= 0.0f && values[i] <= 1.0f))
        throw Error("density file '" + density_path.string() + "': voxel " + std::to_string(i) +
                    " has value " + std::to_string(values[i]) +
                    ", expected a value in [0,1] (is this a HU volume? run `tsf segment` first)");
    volume.density_data() = std::move(values);
  }
  auto& labels = volume.label_data();
  if (!labels_path.empty() && fs::exists(labels_path)) {
    const NrrdVolume l = read_nrrd(labels_path);
    if (l.components != 1 || !same_volume_geometry(l.geometry, g))
      throw Error("labels file '" + labels_path.string() + "' does not match the geometry of '" +
                  density_path.string() + "'");
    for (std::size_t i = 0; i < n; ++i) {
      const double x = l.value(i);
      if (!(x >= 0 && x <= 255 && x == std::floor(x)))
        throw Error("labels file '" + labels_path.string() + "': voxel " + std::to_string(i) +
                    " has label " + std::to_string(x) + ", expected an integer in [0, 255]");
      labels[i] = static_cast<std::uint8_t>(x);
    }
  } else {
    const auto& d = volume.density_data();
    for (std::size_t i = 0; i < n; ++i) labels[i] = d[i] >= 0.5f ? kLabelSoftTissue : kLabelOutside;
  }
  if (has_weights) {
    const NrrdVolume w = read_nrrd(weights_path);
    if (w.components != 4)
      throw Error("weights file '" + weights_path.string() + "' has " +
                  std::to_string(w.components) + " components per voxel, expected 4");
    if (w.type != NrrdType::kUInt8)
      throw Error("weights file '" + weights_path.string() + "' holds " + to_string(w.type) +
                  " values, expected uint8");
    if (!same_volume_geometry(w.geometry, g))
      throw Error("weights file '" + weights_path.string() + "' does not match the geometry of '" +
                  density_path.string() + "'");
    auto& weights = volume.material_weight_data();
    for (std::size_t i = 0; i < n; ++i)
      weights[i] = {w.bytes[4 * i], w.bytes[4 * i + 1], w.bytes[4 * i + 2], w.bytes[4 * i + 3]};
  }
  return volume;
}

}  // namespace tsf::io

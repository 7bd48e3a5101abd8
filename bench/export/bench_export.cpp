// Export benchmark: time and file size per format for the cranium tissue mesh, against tsf's own
// binary PLY writer on the same mesh in the same run, with the round-trip accuracy of each format.
//
//   bench_export [--repeat N] [--density PREFIX-density.nrrd] [--out DIR] [--states N]
//
// The mesh: data-samples/ct-head-cranium/cranium.nrrd through the `tsf segment` pipeline (preset
// `sinus`, run here through tsf::segment::run_segment_job unless --density names its output),
// then the IMT surface with the defaults of `tsf surface` (iso 0.5, merge-eps 0.1, no smoothing).
// Per format: median wall time of export_surface over N runs (default 3) and its stages, bytes
// written (an OBJ's .mtl included), and the largest and mean distance between the vertices
// assimp's importer reads back and the double-precision patient-frame positions (µm).
// Ratios: time and size over the baseline, a raw binary PLY write of the same mesh (float
// positions and normals, colour bytes, triangles; block copies into one buffer, written
// atomically like every export: the floor of any exporter), written right before each export run
// (the time ratio is the median of the per-run ratios, robust to a shared machine). A
// sequence section times a GLB export of N states (rest + N−1 poses): numbered files plus the
// morph-target animation. Output: Markdown tables on stdout.
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <string>
#include <unordered_map>
#include <vector>

#include "tsf/common/atomic_file.h"
#include "tsf/common/stopwatch.h"
#include "tsf/export/mesh_export.h"
#include "tsf/export/output_frame.h"
#include "tsf/import/tissue_volume_io.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/imt/surface_ply.h"
#include "tsf/segment/segment_job.h"
#include "tsf/segment/segment_preset.h"

namespace fs = std::filesystem;
using namespace tsf;
using namespace tsf::exporter;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct Accuracy {
  bool matched = false;
  double max_um = 0, mean_um = 0, import_s = 0;
};

/// Reads `file` back with assimp; for every vertex read, the distance (µm) to the double-precision
/// file-frame position of the nearest mesh vertex (a grid of 1 mm cells finds it; rounding errors
/// are far below the spacing of vertices, so the nearest vertex is the one written).
Accuracy round_trip_accuracy(const fs::path& file, const imt::SurfaceMesh& mesh,
                             const OutputFrame& frame) {
  Accuracy a;
  Stopwatch clock;
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(file.string(), 0);
  a.import_s = clock.seconds();
  if (!scene) {
    std::fprintf(stderr, "bench_export: assimp cannot read %s: %s\n", file.c_str(),
                 importer.GetErrorString());
    return a;
  }
  const double to_mm = frame.units == LengthUnit::metre ? 1000.0 : 1.0;
  std::vector<Vec3d> reference(mesh.positions.size());
  for (std::size_t v = 0; v < reference.size(); ++v)
    reference[v] = frame.position(mesh.positions[v]) * to_mm;
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> grid;
  const auto cell = [](double x) { return static_cast<std::int64_t>(std::floor(x)); };
  const auto cell_key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return (x & 0x1fffff) | ((y & 0x1fffff) << 21) | ((z & 0x1fffff) << 42);
  };
  for (std::size_t v = 0; v < reference.size(); ++v)
    grid[cell_key(cell(reference[v].x), cell(reference[v].y), cell(reference[v].z))].push_back(
        static_cast<std::uint32_t>(v));
  double sum = 0;
  std::size_t count = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    for (unsigned i = 0; i < am->mNumVertices; ++i) {
      const Vec3d p = Vec3d{am->mVertices[i].x, am->mVertices[i].y, am->mVertices[i].z} * to_mm;
      double best = INFINITY;
      const std::int64_t cx = cell(p.x), cy = cell(p.y), cz = cell(p.z);
      for (std::int64_t dz = -1; dz <= 1; ++dz)
        for (std::int64_t dy = -1; dy <= 1; ++dy)
          for (std::int64_t dx = -1; dx <= 1; ++dx) {
            const auto it = grid.find(cell_key(cx + dx, cy + dy, cz + dz));
            if (it == grid.end()) continue;
            for (std::uint32_t v : it->second) best = std::min(best, length(reference[v] - p));
          }
      if (!std::isfinite(best)) return a;  // a vertex far from every written one
      a.max_um = std::max(a.max_um, best * 1000.0);
      sum += best * 1000.0;
      ++count;
    }
  }
  a.mean_um = count ? sum / static_cast<double>(count) : 0.0;
  a.matched = count > 0;
  return a;
}

/// The floor any exporter has to pay: a binary PLY of the same content (float positions and
/// normals, uchar colours, triangles) built with block copies in one buffer, written atomically
/// (temporary + rename) like every export. No validation, no format library.
void write_raw_ply(const fs::path& path, const imt::SurfaceMesh& mesh) {
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex " +
      std::to_string(mesh.vertex_count()) +
      "\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty "
      "float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\nproperty uchar "
      "blue\nelement face " +
      std::to_string(mesh.triangle_count()) +
      "\nproperty list uchar int vertex_indices\nend_header\n";
  std::string bytes(header.size() + mesh.vertex_count() * 27 + mesh.triangle_count() * 13, '\0');
  std::memcpy(&bytes[0], header.data(), header.size());
  char* p = &bytes[header.size()];
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v, p += 27) {
    std::memcpy(p, &mesh.positions[v], 12);
    std::memcpy(p + 12, &mesh.normals[v], 12);
    const auto c = imt::label_colour(mesh.labels[v]);
    std::memcpy(p + 24, c.data(), 3);
  }
  for (const auto& t : mesh.triangles) {
    *p = 3;
    std::memcpy(p + 1, t.data(), 12);
    p += 13;
  }
  write_text_atomically(path, bytes);
}

std::uintmax_t bytes_of(const ExportReport& r) {
  std::uintmax_t n = 0;
  for (const auto& f : r.files) n += f.bytes;
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3, states = 5;
  fs::path density, out = fs::temp_directory_path() / "tsf-bench-export";
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--repeat") && a + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++a]));
    } else if (!std::strcmp(argv[a], "--density") && a + 1 < argc) {
      density = argv[++a];
    } else if (!std::strcmp(argv[a], "--out") && a + 1 < argc) {
      out = argv[++a];
    } else if (!std::strcmp(argv[a], "--states") && a + 1 < argc) {
      states = std::max(2, std::atoi(argv[++a]));
    } else {
      std::fprintf(stderr,
                   "usage: bench_export [--repeat N] [--density PREFIX-density.nrrd] [--out DIR] "
                   "[--states N]\n");
      return 2;
    }
  }
  try {
    fs::create_directories(out);
    Stopwatch clock;
    double segment_s = 0;
    if (density.empty()) {
      segment::SegmentJob job;
      job.input = fs::path(TSF_SOURCE_DIR) / "data-samples" / "ct-head-cranium" / "cranium.nrrd";
      job.preset = segment::load_segment_preset("sinus");
      job.output_prefix = out / "cranium";
      job.write_preview = false;
      segment::run_segment_job(job);
      density = out / "cranium-density.nrrd";
      segment_s = clock.seconds();
    }
    const VoxelVolume volume = import::read_tissue_volume(density);
    clock.restart();
    const imt::SurfaceMesh mesh = imt::extract_surface(volume);
    const double surface_s = clock.seconds();
    const auto& g = volume.geometry();
    std::printf("### Export of the cranium tissue mesh\n\n");
    std::printf(
        "Mesh: %s (%d×%d×%d voxels of %.3f mm; `tsf segment` preset sinus%s), IMT surface "
        "%zu vertices, %zu triangles (surfaced in %.2f s). %d runs per row, median.\n\n",
        density.filename().c_str(), g.dims.x, g.dims.y, g.dims.z, g.spacing.x,
        segment_s > 0 ? (", segmented in " + std::to_string(segment_s).substr(0, 4) + " s").c_str()
                      : "",
        mesh.vertex_count(), mesh.triangle_count(), surface_s, repeat);

    // Baseline: tsf's own binary PLY writer, timed right before every export run so that each
    // ratio compares two writes made under the same load (this machine is shared).
    const fs::path base_file = out / "baseline.ply";
    const auto time_baseline = [&] {
      Stopwatch c;
      write_raw_ply(base_file, mesh);
      return c.seconds();
    };
    std::vector<double> all_base;
    std::printf(
        "| format | file | time s | × PLY baseline | size MB | × baseline | "
        "prepare | scene | assimp | finish | write | round trip max / mean µm | "
        "import s |\n");
    std::printf("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    std::string rows;
    for (const ExportFormatInfo& info : export_formats()) {
      ExportOptions options;
      options.format = info.format;
      const fs::path file = out / (std::string("cranium-") + info.name + info.extension);
      std::vector<double> times, ratios;
      std::vector<ExportReport> reports;
      for (int r = 0; r < repeat; ++r) {
        const double base = time_baseline();
        all_base.push_back(base);
        clock.restart();
        reports.push_back(export_surface(mesh, g, file, options));
        times.push_back(clock.seconds());
        ratios.push_back(times.back() / base);
      }
      const double t = median(times);
      const ExportReport& rep =
          reports[static_cast<std::size_t>(std::min_element(times.begin(), times.end(),
                                                            [&](double x, double y) {
                                                              return std::fabs(x - t) <
                                                                     std::fabs(y - t);
                                                            }) -
                                           times.begin())];
      const double bytes = static_cast<double>(bytes_of(rep));
      const double base_bytes = static_cast<double>(fs::file_size(base_file));
      const OutputFrame frame =
          make_output_frame(g, options.resolved_axes(), options.resolved_units());
      const Accuracy acc = round_trip_accuracy(file, mesh, frame);
      char accuracy[64];
      if (acc.matched)
        std::snprintf(accuracy, sizeof(accuracy), "%.3f / %.3f", acc.max_um, acc.mean_um);
      else
        std::snprintf(accuracy, sizeof(accuracy), "mismatch");
      char row[512];
      std::snprintf(
          row, sizeof(row),
          "| %s | %s | %.3f | %.2f | %.1f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %s | "
          "%.2f |\n",
          info.name, file.filename().c_str(), t, median(ratios), bytes / 1e6, bytes / base_bytes,
          rep.prepare_s, rep.scene_s, rep.assimp_s, rep.finish_s, rep.write_s, accuracy,
          acc.import_s);
      rows += row;
      std::fprintf(stderr, "%s", row);
    }
    std::printf(
        "| baseline: raw binary PLY write | baseline.ply | %.3f | 1.00 | %.1f | 1.00 | "
        "| | | | | | |\n%s",
        median(all_base), static_cast<double>(fs::file_size(base_file)) / 1e6, rows.c_str());

    // A sequence: rest + poses (the head sags by up to 2 mm, more at the top), all states as GLB.
    io::MeshSequence sequence;
    sequence.geometry = g;
    sequence.rest = mesh;
    float z_lo = 1e30f, z_hi = -1e30f;
    for (const Vec3f& p : mesh.positions) {
      z_lo = std::min(z_lo, p.z);
      z_hi = std::max(z_hi, p.z);
    }
    for (int s = 1; s < states; ++s) {
      io::MeshFrame frame;
      frame.time_s = 0.04 * s;
      const float amount = 2.0f * static_cast<float>(s) / static_cast<float>(states - 1);
      frame.positions.reserve(mesh.positions.size());
      for (const Vec3f& p : mesh.positions)
        frame.positions.push_back({p.x, p.y, p.z - amount * (p.z - z_lo) / (z_hi - z_lo)});
      sequence.frames.push_back(std::move(frame));
    }
    const fs::path seq_dir = out / "sequence";
    fs::remove_all(seq_dir);
    clock.restart();
    const ExportReport seq = export_sequence(sequence, FrameSelection::parse("all"),
                                             seq_dir / "cranium.glb", ExportOptions{});
    const double seq_s = clock.seconds();
    std::uintmax_t animated_bytes = 0;
    for (const auto& f : seq.files)
      if (f.path.filename() == "cranium.glb") animated_bytes = f.bytes;
    std::printf("\n### Sequence: %d states of the cranium mesh as GLB (`--frames all`)\n\n",
                states);
    std::printf(
        "| states | files | total MB | animated cranium.glb MB | time s | × one-state GLB "
        "size |\n|---:|---:|---:|---:|---:|---:|\n");
    std::printf("| %d | %zu | %.1f | %.1f | %.2f | %.2f |\n", states, seq.files.size(),
                static_cast<double>(bytes_of(seq)) / 1e6, static_cast<double>(animated_bytes) / 1e6,
                seq_s,
                static_cast<double>(animated_bytes) /
                    static_cast<double>(fs::file_size(out / "cranium-glb.glb")));
    std::printf(
        "\nNormals without area around them, per state (export_normals.h): %zu of %zu "
        "vertices.\n",
        seq.normals_without_area / static_cast<std::size_t>(states), mesh.vertex_count());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_export: %s\n", e.what());
    return 1;
  }
  return 0;
}

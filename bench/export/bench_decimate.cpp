// Decimation benchmark: time and distance to the full surface per triangle budget, for
// meshoptimizer called once on one thread against tsf's slab split on every thread
// (mesh_decimation.h), on real tissue surfaces.
//
//   bench_decimate --density PREFIX-density.nrrd [--density ...] [--budgets N1,N2,...]
//                  [--repeat N] [--threads T] [--max-error MM]
//
// Per density volume: the IMT surface with the defaults of `tsf surface` (iso 0.5, merge-eps
// 0.1), cleaned as every export is (mesh_cleanup.h); then per budget and method the median wall
// time of the decimation over N runs (default 3; the decimation alone, from the cleaned surface:
// the tissue-border split, meshoptimizer, compaction) and the distance of the result to the
// cleaned full surface (surface_deviation.h: two-sided, mm; mean and max, and each direction).
// Times: "time s" wall, "cpu s" the process CPU time (all threads), "idle s" the CPU time on the
// critical path (this thread's, with the longest slab in place of the one it ran; thread CPU
// clocks): the wall time on an idle machine with a core per slab, which a shared machine's wall
// time is not. "× one call": idle s over the one-call row's of the same budget in the same run.
// --max-error adds a row per budget with the measured error bound (mesh_decimation.h: vertices
// farther than MM are kept and meshoptimizer runs again).
// Budgets default to 1,000,000, 300,000, 100,000 and 30,000 triangles (those at or above the
// surface's own count are skipped). Output: one Markdown table on stdout.
#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "tsf/common/stopwatch.h"
#include "tsf/export/mesh_cleanup.h"
#include "tsf/export/mesh_decimation.h"
#include "tsf/export/mesh_export.h"
#include "tsf/export/surface_deviation.h"
#include "tsf/import/tissue_volume_io.h"
#include "tsf/imt/extract_surface.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace fs = std::filesystem;
using namespace tsf;
using namespace tsf::exporter;

namespace {

double cpu_seconds() {
  rusage r{};
  getrusage(RUSAGE_SELF, &r);
  return static_cast<double>(r.ru_utime.tv_sec + r.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(r.ru_utime.tv_usec + r.ru_stime.tv_usec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

std::vector<std::size_t> parse_list(const char* text) {
  std::vector<std::size_t> out;
  for (const char* p = text; *p;) {
    char* end = nullptr;
    const unsigned long long v = std::strtoull(p, &end, 10);
    if (end == p || v == 0) return {};
    out.push_back(static_cast<std::size_t>(v));
    p = *end == ',' ? end + 1 : end;
    if (*end && *end != ',') return {};
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<fs::path> densities;
  std::vector<std::size_t> budgets = {1'000'000, 300'000, 100'000, 30'000};
  int repeat = 3, threads = 0;
  double max_error = 0.0;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--density") && a + 1 < argc) {
      densities.push_back(argv[++a]);
    } else if (!std::strcmp(argv[a], "--budgets") && a + 1 < argc) {
      budgets = parse_list(argv[++a]);
      if (budgets.empty()) {
        std::fprintf(stderr, "bench_decimate: --budgets takes counts like 100000,30000\n");
        return 2;
      }
    } else if (!std::strcmp(argv[a], "--repeat") && a + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++a]));
    } else if (!std::strcmp(argv[a], "--max-error") && a + 1 < argc) {
      max_error = std::atof(argv[++a]);
    } else if (!std::strcmp(argv[a], "--threads") && a + 1 < argc) {
      threads = std::max(1, std::atoi(argv[++a]));
    } else {
      std::fprintf(stderr,
                   "usage: bench_decimate --density PREFIX-density.nrrd [--density ...] "
                   "[--budgets N1,N2,...] [--repeat N] [--threads T] [--max-error MM]\n");
      return 2;
    }
  }
  if (densities.empty()) {
    std::fprintf(stderr, "bench_decimate: name at least one --density (a tsf segment output)\n");
    return 2;
  }
#ifdef _OPENMP
  if (threads == 0) threads = omp_get_max_threads();
#else
  threads = 1;
#endif
  try {
    std::printf(
        "| mesh | triangles | budget | method | triangles out | time s | cpu s | idle s | × one "
        "call | "
        "mean mm | max mm | full→dec mean / max mm | dec→full mean / max mm |\n"
        "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const fs::path& density : densities) {
      const VoxelVolume volume = import::read_tissue_volume(density);
      Stopwatch clock;
      const imt::SurfaceMesh raw = imt::extract_surface(volume);
      const double surface_s = clock.seconds();
      clock.restart();
      const CleanTopology clean = clean_topology(raw);
      const double clean_s = clock.seconds();
      imt::SurfaceMesh full;
      full.positions = gather(raw.positions, clean.origin);
      full.labels = clean.labels;
      full.triangles = clean.triangles;
      std::fprintf(stderr,
                   "bench_decimate: %s: %zu triangles (surfaced in %.2f s), %zu after cleaning "
                   "(%.2f s; %zu zero-area, %zu duplicates before)\n",
                   density.filename().c_str(), raw.triangle_count(), surface_s,
                   full.triangle_count(), clean_s, clean.report.before.zero_area,
                   clean.report.before.duplicates);
      for (std::size_t budget : budgets) {
        if (budget >= full.triangle_count()) continue;
        double one_call_s = 0;
        struct Method {
          int threads;
          double max_error;
        };
        std::vector<Method> methods = {{1, 0.0}};
        if (threads > 1) methods.push_back({threads, 0.0});
        if (max_error > 0.0) methods.push_back({threads, max_error});
        for (const Method& m : methods) {
          DecimationOptions o;
          o.target_triangles = budget;
          o.threads = m.threads;
          o.max_error_mm = m.max_error;
          std::vector<double> times, cpu, idle;
          DecimatedMesh d;
          for (int r = 0; r < repeat; ++r) {
            const double c0 = cpu_seconds();
            d = decimate(full, o);
            cpu.push_back(cpu_seconds() - c0);
            times.push_back(d.seconds);
            idle.push_back(d.critical_path_cpu_s);
          }
          const double s = median(times), s_idle = median(idle);
          if (m.threads == 1 && m.max_error == 0.0) one_call_s = s_idle;
          const imt::SurfaceMesh out = decimated_surface(full, d);
          const SurfaceDeviation dev = measure_deviation({&full.positions, &full.triangles},
                                                         {&out.positions, &out.triangles});
          std::string method =
              d.slabs > 1 ? "meshoptimizer, " + std::to_string(d.slabs) + " slabs on " +
                                std::to_string(m.threads) + " threads"
              : m.threads > 1 ? "meshoptimizer, one call (not split: under 2 M triangles, or a "
                                "budget over a quarter)"
                              : "meshoptimizer, one call";
          if (m.max_error > 0.0) {
            char b[96];
            std::snprintf(b, sizeof(b), ", max error %g mm (%d runs)", m.max_error, d.rounds);
            method += b;
          }
          std::printf(
              "| %s | %s | %s | %s | %s | %.2f | %.2f | %.2f | %.2f | %.3f | %.3f | %.3f / %.3f "
              "| %.3f / %.3f |\n",
              density.filename().c_str(), thousands(full.triangle_count()).c_str(),
              thousands(budget).c_str(), method.c_str(), thousands(d.triangles.size()).c_str(), s,
              median(cpu), s_idle, one_call_s > 0 ? s_idle / one_call_s : 1.0, dev.mean_mm(),
              dev.max_mm(), dev.from_full_mean_mm, dev.from_full_max_mm, dev.to_full_mean_mm,
              dev.to_full_max_mm);
          std::fflush(stdout);
        }
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_decimate: %s\n", e.what());
    return 1;
  }
  return 0;
}

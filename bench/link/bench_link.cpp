// bench_link: what serving the surface costs per POLYDATA (docs/live.md, "Figures"): tsf's
// pack_polydata (libopenigtlink's C packer, app/link/igtl_codec.h) against the library's own C++
// igtl::PolyDataMessage filled and packed from the same mesh (the peer: what a program written
// against the C++ API pays), and a memcpy of the message's bytes (the floor), in the same run.
//
//   build/bench/bench_link [--benchmark_filter=…]
//
// The surface: a latitude-longitude sphere with normals and labels; Arg = triangles (8k, 32k,
// 128k: the link-block slab is 32k, a head's face surface a few hundred k).
#include <benchmark/benchmark.h>

#include <igtlPolyDataMessage.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "link/igtl_codec.h"

namespace {

using namespace tsf;

imt::SurfaceMesh sphere(std::int64_t triangles) {
  const int rings = static_cast<int>(std::sqrt(static_cast<double>(triangles) / 2.0));
  const int segments = rings;
  imt::SurfaceMesh m;
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double th = M_PI * r / rings, ph = 2 * M_PI * s / segments;
      const Vec3f n{static_cast<float>(std::sin(th) * std::cos(ph)),
                    static_cast<float>(std::sin(th) * std::sin(ph)),
                    static_cast<float>(std::cos(th))};
      m.positions.push_back(n * 20.0f);
      m.normals.push_back(n);
      m.labels.push_back(static_cast<std::uint8_t>(1 + r % 3));
    }
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const auto a = static_cast<std::uint32_t>(r * segments + s);
      const auto b = static_cast<std::uint32_t>(r * segments + (s + 1) % segments);
      const auto c = a + static_cast<std::uint32_t>(segments);
      const auto d = b + static_cast<std::uint32_t>(segments);
      m.triangles.push_back({a, c, b});
      m.triangles.push_back({b, c, d});
    }
  return m;
}

void set_counters(benchmark::State& state, const imt::SurfaceMesh& m, std::size_t bytes) {
  state.counters["triangles"] = static_cast<double>(m.triangles.size());
  state.counters["message_bytes"] = static_cast<double>(bytes);
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(bytes));
}

void BM_PackPolydataTsf(benchmark::State& state) {
  const imt::SurfaceMesh m = sphere(state.range(0));
  std::size_t bytes = 0;
  for (auto _ : state) {
    std::vector<std::uint8_t> msg = link::pack_polydata(m, "tissue", 0);
    bytes = msg.size();
    benchmark::DoNotOptimize(msg.data());
  }
  set_counters(state, m, bytes);
}

void BM_PackPolydataLibraryCpp(benchmark::State& state) {
  const imt::SurfaceMesh m = sphere(state.range(0));
  std::size_t bytes = 0;
  for (auto _ : state) {
    igtl::PolyDataMessage::Pointer msg = igtl::PolyDataMessage::New();
    msg->SetDeviceName("tissue");
    igtl::PolyDataPointArray::Pointer points = igtl::PolyDataPointArray::New();
    for (const Vec3f& p : m.positions) points->AddPoint(p.x, p.y, p.z);
    igtl::PolyDataCellArray::Pointer polygons = igtl::PolyDataCellArray::New();
    for (const auto& t : m.triangles) {
      igtlUint32 cell[3] = {t[0], t[1], t[2]};
      polygons->AddCell(3, cell);
    }
    igtl::PolyDataAttribute::Pointer normals = igtl::PolyDataAttribute::New();
    normals->SetType(igtl::PolyDataAttribute::POINT_NORMAL);
    normals->SetName("Normals");
    normals->SetSize(static_cast<igtlUint32>(m.normals.size()));
    std::vector<igtlFloat32> normal_values(
        reinterpret_cast<const igtlFloat32*>(m.normals.data()),
        reinterpret_cast<const igtlFloat32*>(m.normals.data()) + 3 * m.normals.size());
    normals->SetData(normal_values.data());
    std::vector<igtlFloat32> label_values(m.labels.begin(), m.labels.end());
    igtl::PolyDataAttribute::Pointer labels = igtl::PolyDataAttribute::New();
    labels->SetType(igtl::PolyDataAttribute::POINT_SCALAR);
    labels->SetName("TissueLabel");
    labels->SetSize(static_cast<igtlUint32>(label_values.size()));
    labels->SetData(label_values.data());
    msg->SetPoints(points);
    msg->SetPolygons(polygons);
    msg->AddAttribute(normals);
    msg->AddAttribute(labels);
    msg->Pack();
    bytes = static_cast<std::size_t>(msg->GetPackSize());
    benchmark::DoNotOptimize(msg->GetPackPointer());
  }
  set_counters(state, m, bytes);
}

void BM_CopyMessageBytes(benchmark::State& state) {
  const imt::SurfaceMesh m = sphere(state.range(0));
  const std::vector<std::uint8_t> msg = link::pack_polydata(m, "tissue", 0);
  for (auto _ : state) {
    std::vector<std::uint8_t> copy(msg.size());
    std::memcpy(copy.data(), msg.data(), msg.size());
    benchmark::DoNotOptimize(copy.data());
  }
  set_counters(state, m, msg.size());
}

BENCHMARK(BM_PackPolydataTsf)->Arg(8192)->Arg(32768)->Arg(131072)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PackPolydataLibraryCpp)
    ->Arg(8192)
    ->Arg(32768)
    ->Arg(131072)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CopyMessageBytes)->Arg(8192)->Arg(32768)->Arg(131072)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();

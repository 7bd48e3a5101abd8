#include "tsf/viewer/surface_uploader.h"

#include <cstring>

#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkIdTypeArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkUnsignedCharArray.h>

#include "tsf/viewer/label_colours.h"

namespace tsf::viewer {

SurfaceUploader::SurfaceUploader()
    : poly_data_(vtkSmartPointer<vtkPolyData>::New()),
      points_(vtkSmartPointer<vtkFloatArray>::New()),
      normals_(vtkSmartPointer<vtkFloatArray>::New()),
      colours_(vtkSmartPointer<vtkUnsignedCharArray>::New()) {
  points_->SetNumberOfComponents(3);
  normals_->SetNumberOfComponents(3);
  normals_->SetName("Normals");
  colours_->SetNumberOfComponents(3);
  colours_->SetName("Colours");
  vtkNew<vtkPoints> points;
  points->SetData(points_);
  poly_data_->SetPoints(points);
  poly_data_->GetPointData()->SetNormals(normals_);
  poly_data_->GetPointData()->SetScalars(colours_);
  poly_data_->SetPolys(vtkNew<vtkCellArray>());
}

SurfaceUploader::~SurfaceUploader() = default;

std::size_t SurfaceUploader::apply_full(const SurfaceBuffers& b) {
  const auto n = static_cast<vtkIdType>(b.positions.size());
  points_->SetNumberOfTuples(n);
  normals_->SetNumberOfTuples(n);
  colours_->SetNumberOfTuples(n);
  if (n > 0) {
    std::memcpy(points_->GetPointer(0), b.positions.data(), sizeof(Vec3f) * b.positions.size());
    std::memcpy(normals_->GetPointer(0), b.normals.data(), sizeof(Vec3f) * b.normals.size());
  }
  unsigned char* c = colours_->GetPointer(0);
  for (std::size_t i = 0; i < b.labels.size(); ++i) {
    const Rgb rgb = label_colour(b.labels[i]);
    std::memcpy(c + 3 * i, rgb.data(), 3);
  }
  // Cells as offsets + connectivity (VTK 9 layout), every triangle slot.
  const auto t = static_cast<vtkIdType>(b.triangles.size());
  vtkNew<vtkIdTypeArray> offsets, connectivity;
  offsets->SetNumberOfValues(t + 1);
  connectivity->SetNumberOfValues(3 * t);
  vtkIdType* off = offsets->GetPointer(0);
  vtkIdType* con = connectivity->GetPointer(0);
  for (vtkIdType i = 0; i < t; ++i) {
    off[i] = 3 * i;
    const auto& tri = b.triangles[static_cast<std::size_t>(i)];
    con[3 * i] = tri[0];
    con[3 * i + 1] = tri[1];
    con[3 * i + 2] = tri[2];
  }
  off[t] = 3 * t;
  vtkNew<vtkCellArray> polys;
  polys->SetData(offsets, connectivity);
  poly_data_->SetPolys(polys);
  points_->Modified();
  normals_->Modified();
  colours_->Modified();
  poly_data_->GetPoints()->Modified();
  poly_data_->Modified();
  live_triangles_ = b.live_triangles;
  return b.positions.size();
}

std::size_t SurfaceUploader::apply(const SurfaceBuffers& b, const SurfaceDelta& delta) {
  if (delta.topology ||
      static_cast<std::size_t>(points_->GetNumberOfTuples()) != b.positions.size())
    return apply_full(b);
  if (delta.ranges.empty()) return 0;
  std::size_t copied = 0;
  float* p = points_->GetPointer(0);
  float* nrm = normals_->GetPointer(0);
  for (const auto& r : delta.ranges) {
    const std::size_t count = r.second - r.first;
    std::memcpy(p + 3 * std::size_t{r.first}, b.positions.data() + r.first, sizeof(Vec3f) * count);
    std::memcpy(nrm + 3 * std::size_t{r.first}, b.normals.data() + r.first, sizeof(Vec3f) * count);
    copied += count;
  }
  points_->Modified();
  normals_->Modified();
  poly_data_->GetPoints()->Modified();
  return copied;
}

}  // namespace tsf::viewer

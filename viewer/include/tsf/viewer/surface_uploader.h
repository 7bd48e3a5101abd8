// The tissue surface as VTK data: a vtkPolyData whose points, normals and colours are aligned with
// the IMT vertex slots, so a frame that only moved vertices copies only the changed slot ranges.
//
//   points     vtkFloatArray #vertex slots × 3, mm (deformed tissue space)
//   normals    vtkFloatArray #vertex slots × 3
//   colours    vtkUnsignedCharArray #vertex slots × 3, by tissue label (label_colours.h)
//   polys      every triangle slot; freed slots are (0, 0, 0) and render nothing
//
// apply() with ranges copies only those ranges and marks the arrays modified; VTK 9.1's OpenGL
// mapper then re-sends the vertex buffer, but the cells (index buffer) and colours are left alone.
// A topology change (edit) rebuilds the cells and colours. apply_full() re-uploads everything:
// the baseline of bench_viewer.
#pragma once

#include <cstddef>

#include <vtkNew.h>
#include <vtkSmartPointer.h>

#include "tsf/viewer/surface_exchange.h"

class vtkPolyData;
class vtkFloatArray;
class vtkUnsignedCharArray;

namespace tsf::viewer {

class SurfaceUploader {
 public:
  SurfaceUploader();
  ~SurfaceUploader();

  /// Applies what changed; returns the number of vertex slots copied.
  std::size_t apply(const SurfaceBuffers& buffers, const SurfaceDelta& delta);
  /// Re-uploads everything (points, normals, colours, cells).
  std::size_t apply_full(const SurfaceBuffers& buffers);

  vtkPolyData* poly_data() const { return poly_data_; }
  std::size_t live_triangles() const { return live_triangles_; }

 private:
  vtkSmartPointer<vtkPolyData> poly_data_;
  vtkSmartPointer<vtkFloatArray> points_;
  vtkSmartPointer<vtkFloatArray> normals_;
  vtkSmartPointer<vtkUnsignedCharArray> colours_;
  std::size_t live_triangles_ = 0;
};

}  // namespace tsf::viewer

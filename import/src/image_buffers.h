// Buffers every reader of import/ fills: a float HU image on a grid, and values of any of ITK's
// scalar component types converted to float.
#pragma once

#include <itkImageIOBase.h>

#include <cstddef>

#include "tsf/import/import_volume.h"
#include "tsf/import/slice_stack_geometry.h"

namespace tsf::import {

/// An allocated (not initialised) image on `grid`, its memory backed by huge pages where the
/// system allows. Throws tsf::Error when it cannot be allocated.
HuImage::Pointer make_hu_image(const OrthogonalGrid& grid);

/// Converts `n` values of component type `type` at `src` to float (static_cast, as ITK's readers
/// do). False for a type that is not a scalar ITK reads.
bool convert_to_float(itk::CommonEnums::IOComponent type, const void* src, std::size_t n,
                      float* out);

}  // namespace tsf::import

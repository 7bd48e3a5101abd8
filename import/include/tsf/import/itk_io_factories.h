// Registers the ITK image IO factories tsf reads and writes with (GDCM, NRRD, MetaImage, NIfTI).
// Explicit registration replaces ITK_USE_FILE's generated registration (BUILD-NOTES pitfall 3).
#pragma once

namespace tsf::import {

/// Idempotent and thread-safe; call before any itk::ImageFileReader/Writer use.
void register_itk_io_factories();

}  // namespace tsf::import

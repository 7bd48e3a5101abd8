// One-time set-up of the imaging libraries import/ uses (DCMTK, GDCM, ITK).
//
// - DCMTK and GDCM log to stderr by default, sometimes with attribute values (private vendor
//   text, names); tsf reports problems itself, so their loggers are silenced.
// - DCMTK converts UN-encoded elements back to their dictionary VR (files re-encoded by tools
//   that did not know an attribute's VR).
// - ITK's image IO factories are registered (register_itk_io_factories()).
#pragma once

namespace tsf::import {

/// Idempotent and thread-safe.
void setup_imaging_libraries();

}  // namespace tsf::import

// The JSON form of an ImportReport: the sidecar written beside every imported volume.
//
// Top-level keys: format, source, series, acquisition, output, resampling, rescale, warnings,
// seconds. Lengths in mm, angles in degrees, vectors in the LPS patient frame, direction
// row-major with the image axes as columns. Patient name, ID and birth date never appear.
#pragma once

#include <nlohmann/json.hpp>

#include "tsf/import/import_report.h"

namespace tsf::import {

/// Identifies the sidecar layout; bumped when keys change meaning.
inline constexpr const char* kImportSidecarFormat = "tsf-import-sidecar/1";

/// Keys keep the order above (nlohmann::ordered_json) so the file reads top-down.
using SidecarJson = nlohmann::ordered_json;

SidecarJson import_report_to_json(const ImportReport& report);

}  // namespace tsf::import

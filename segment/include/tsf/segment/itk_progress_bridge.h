// ITK progress events -> the terminal progress bar (tsf::Progress).
#pragma once

#include <itkProcessObject.h>

#include "tsf/common/progress.h"

namespace tsf::segment {

/// Forwards `filter`'s ProgressEvents to `progress`, mapped into the fraction range [from, to]
/// (a stage made of several filters gives each its share). Does nothing when `progress` is null.
/// The observer lives as long as the filter; `progress` must outlive the filter's updates.
void forward_itk_progress(itk::ProcessObject* filter, Progress* progress, double from = 0.0,
                          double to = 1.0);

}  // namespace tsf::segment

#include "tsf/segment/itk_progress_bridge.h"

namespace tsf::segment {

void forward_itk_progress(itk::ProcessObject* filter, Progress* progress, double from, double to) {
  if (!filter || !progress) return;
  // The observer holds a raw pointer: the filter owns the observer, not the other way round.
  filter->AddObserver(itk::ProgressEvent(), [filter, progress, from, to](const itk::EventObject&) {
    progress->set_fraction(from + (to - from) * static_cast<double>(filter->GetProgress()));
  });
}

}  // namespace tsf::segment

#include "tsf/import/imaging_library_setup.h"

#include <dcmtk/dcmdata/dcobject.h>
#include <dcmtk/dcmdata/dcvr.h>
#include <dcmtk/oflog/oflog.h>
#include <gdcmTrace.h>
#include <itkObject.h>

#include <mutex>

#include "tsf/import/itk_io_factories.h"

namespace tsf::import {

void setup_imaging_libraries() {
  static std::once_flag once;
  std::call_once(once, [] {
    OFLog::configure(OFLogger::OFF_LOG_LEVEL);
    dcmEnableUnknownVRConversion.set(OFTrue);
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
    itk::Object::GlobalWarningDisplayOff();
    register_itk_io_factories();
  });
}

}  // namespace tsf::import

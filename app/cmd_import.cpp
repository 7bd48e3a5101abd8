// `tsf import`: placeholder until the import issue lands.
#include "commands.h"
#include "tsf/import/itk_io_factories.h"

namespace tsf::app {

void add_import_command(CLI::App& app) {
  CLI::App* sub =
      app.add_subcommand("import", "Read a CT (DICOM series, NRRD, MHA, NIfTI) into HU");
  sub->callback([] { tsf::import::register_itk_io_factories(); });
}

}  // namespace tsf::app

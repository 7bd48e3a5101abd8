// tsf: CT scan -> interactive, cuttable soft-tissue asset.
#include <cstdio>
#include <exception>
#include <string>

#include "commands.h"
#include "output/interrupt.h"
#include "tsf/common/error.h"
#include "tsf/version.h"

namespace tsf::app {

void add_unavailable_command(CLI::App& app, const char* name, const char* description,
                             const char* cmake_option) {
  CLI::App* sub = app.add_subcommand(name, std::string(description) + " (not built)");
  sub->allow_extras();
  std::string option = cmake_option;
  std::string command = name;
  sub->callback([option, command] {
    throw tsf::Error("'tsf " + command + "' is not part of this build: reconfigure with -D" +
                     option + "=ON and the packages it needs (see README.md)");
  });
}

}  // namespace tsf::app

int main(int argc, char** argv) {
  CLI::App app{
      "tsf " TSF_VERSION_STRING
      ": turns a CT scan into an interactive, cuttable soft-tissue asset.\n"
      "Pipeline: import -> segment -> surface / simulate -> export / view; `tsf run` does it all "
      "from a scene file. A new patient's CT: `tsf info CT`, then `tsf run SCENE --ct CT`."};
  tsf::app::remove_temporaries_on_signal();
  app.require_subcommand(1);
  app.set_version_flag("--version", "tsf " TSF_VERSION_STRING);

#ifdef TSF_HAVE_IMPORT
  tsf::app::add_import_command(app);
#else
  tsf::app::add_unavailable_command(app, "import", "Read a CT (DICOM, NRRD, MHA, NIfTI) into HU",
                                    "TSF_WITH_ITK");
#endif
#ifdef TSF_HAVE_INFO
  tsf::app::add_info_command(app);
#else
  tsf::app::add_unavailable_command(
      app, "info", "Describe a CT: series, geometry, extent (LPS), HU range", "TSF_WITH_ITK");
#endif
#ifdef TSF_HAVE_SEGMENT
  tsf::app::add_segment_command(app);
#else
  tsf::app::add_unavailable_command(app, "segment", "CT -> density, labels, material weights",
                                    "TSF_WITH_ITK");
#endif
#ifdef TSF_HAVE_SURFACE_CMD
  tsf::app::add_surface_command(app);
#endif
#ifdef TSF_HAVE_SIMULATE_CMD
  tsf::app::add_simulate_command(app);
#endif
#ifdef TSF_HAVE_HAPTICS_CMD
  tsf::app::add_haptics_command(app);
#endif
#ifdef TSF_HAVE_EXPORT
  tsf::app::add_export_command(app);
#else
  tsf::app::add_unavailable_command(app, "export", "Write meshes (glTF, OBJ, STL, PLY, FBX)",
                                    "TSF_WITH_ASSIMP");
#endif
#ifdef TSF_HAVE_VIEWER
  tsf::app::add_view_command(app);
#else
  tsf::app::add_unavailable_command(app, "view", "Live VTK viewer", "TSF_WITH_VTK");
#endif
#ifdef TSF_HAVE_RUN_CMD
  tsf::app::add_run_command(app);
#endif
#ifdef TSF_HAVE_LINK_CMD
  tsf::app::add_link_command(app);
#else
  tsf::app::add_unavailable_command(app, "link", "Live session linked over OpenIGTLink",
                                    "TSF_WITH_IGTL");
#endif

  // Generated documentation: the manual page and the bash completion (cmd_docs.cpp).
  if (argc == 2 &&
      (std::string(argv[1]) == "--man" || std::string(argv[1]) == "--bash-completion")) {
    const std::string text =
        std::string(argv[1]) == "--man" ? tsf::app::man_page(app) : tsf::app::bash_completion(app);
    std::fwrite(text.data(), 1, text.size(), stdout);
    return 0;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const tsf::Error& e) {
    std::fflush(stdout);  // a summary printed before the error stays before it
    std::fprintf(stderr, "tsf: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tsf: unexpected error: %s\n", e.what());
    return 1;
  }
  return 0;
}

// Strict reading of a scene's `pipeline:` section (run_spec.h).
#include "run/run_spec.h"

#include "yaml_field.h"

namespace tsf::app {
namespace fs = std::filesystem;

RunSpec read_run_spec(const fs::path& scene_file) {
  const YamlField root(load_yaml_file(scene_file.string()), "", scene_file.string());
  const YamlField p = root["pipeline"];
  RunSpec spec;
  if (!p.defined()) return spec;
  spec.present = true;
  const fs::path folder = scene_file.parent_path();
  auto resolve = [&](const std::string& text) {
    const fs::path path(text);
    return path.is_relative() ? folder / path : path;
  };
  p.expect_keys({"source", "segmentation", "material", "material_library", "outputs"});

  const YamlField source = p["source"].required();
  source.expect_keys({"ct", "series"});
  spec.ct = resolve(source["ct"].required().text());
  if (source["series"].node().IsDefined() && source["series"].node().IsNull())
    source["series"].fail(
        "expected a DICOM SeriesInstanceUID, got nothing (leave the key out to "
        "use the only series)");
  if (source["series"].defined()) {
    // A DICOM UID: digits and dots, at most 64 characters (PS3.5 §9.1). A YAML number (an
    // unquoted UID with one dot) is read as text too, so the check is on the characters.
    const YamlField f = source["series"];
    spec.series = f.text();
    const bool ok = !spec.series.empty() && spec.series.size() <= 64 &&
                    spec.series.find_first_not_of("0123456789.") == std::string::npos &&
                    spec.series.front() != '.' && spec.series.back() != '.' &&
                    spec.series.find("..") == std::string::npos;
    if (!ok)
      f.fail(
          "expected a DICOM SeriesInstanceUID (digits and dots, at most 64 characters, e.g. "
          "1.2.840.113619.2.55.3), got '" +
          spec.series + "'; `tsf info " + spec.ct.string() + "` lists the series");
  }

  const YamlField seg = p["segmentation"];
  seg.expect_keys({"preset", "voxel_mm", "smoothing_mm"});
  if (seg.defined()) {
    spec.preset = seg["preset"].text("sinus");
    if (spec.preset.empty()) seg["preset"].fail("expected a preset name or a YAML file path");
    // A path-like preset resolves against the scene; a bare name is a bundled preset.
    const bool yaml_file =
        spec.preset.size() > 5 && spec.preset.compare(spec.preset.size() - 5, 5, ".yaml") == 0;
    if (spec.preset.find('/') != std::string::npos || yaml_file)
      spec.preset = resolve(spec.preset).string();
    spec.voxel_mm = seg["voxel_mm"].number(0.0, 0.0, 10.0);
    spec.smoothing_mm = seg["smoothing_mm"].number(-1.0, 0.0, 10.0);
  }

  if (p["material_library"].defined())
    spec.material_library = resolve(p["material_library"].text());
  spec.material = p["material"].text("");

  const YamlField out = p["outputs"];
  out.expect_keys({"folder", "report", "plots", "meshes", "energy_every"});
  if (out["folder"].defined()) spec.folder = resolve(out["folder"].text());
  spec.report = out["report"].boolean(true);
  spec.plots = out["plots"].boolean(true);
  spec.meshes = out["meshes"].boolean(true);
  spec.energy_every = static_cast<int>(out["energy_every"].integer(1, 1, 100000));
  return spec;
}

}  // namespace tsf::app

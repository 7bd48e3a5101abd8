#include "tsf/import/dicom_catalog.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/common/text_format.h"
#include "tsf/import/volume_file_reader.h"

namespace tsf::import {
namespace fs = std::filesystem;

namespace {

std::string join_limited(const std::vector<std::string>& items, std::size_t limit = 4) {
  std::string out;
  for (std::size_t i = 0; i < items.size() && i < limit; ++i) out += (i ? ", " : "") + items[i];
  if (items.size() > limit) out += " and " + std::to_string(items.size() - limit) + " more";
  return out;
}

std::string plural(std::size_t n, const char* word) {
  return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

bool same_vector(const Vec3d& a, const Vec3d& b, double tol) {
  return std::abs(a.x - b.x) <= tol && std::abs(a.y - b.y) <= tol && std::abs(a.z - b.z) <= tol;
}

std::string vec_text(const Vec3d& v) {
  return "(" + format_text("%.4g", v.x) + ", " + format_text("%.4g", v.y) + ", " +
         format_text("%.4g", v.z) + ")";
}

/// Groups slices by a key with a tolerance; returns one representative slice per group and the
/// files in each group.
template <typename Same>
std::vector<std::vector<int>> group_slices(const DicomSeries& s, Same same) {
  std::vector<std::vector<int>> groups;
  for (int k = 0; k < s.slice_count(); ++k) {
    bool placed = false;
    for (auto& g : groups)
      if (same(g.front(), k)) {
        g.push_back(k);
        placed = true;
        break;
      }
    if (!placed) groups.push_back({k});
  }
  return groups;
}

}  // namespace

std::string display_path(const fs::path& path, const fs::path& root) {
  std::error_code ec;
  if (!root.empty()) {
    const fs::path base = fs::is_directory(root, ec) ? root : root.parent_path();
    const fs::path rel = path.lexically_relative(base);
    if (!rel.empty() && rel.native().rfind("..", 0) != 0) return rel.string();
  }
  return path.string();
}

std::string one_line_summary(const DicomSeries& s) {
  std::string line =
      s.series_instance_uid.empty() ? "(no SeriesInstanceUID)" : s.series_instance_uid;
  line += "  " + (s.modality.empty() ? std::string("?") : s.modality);
  if (!s.series_number.empty()) line += "  #" + s.series_number;
  if (!s.description.empty()) line += "  \"" + s.description + "\"";
  line += "  " + plural(static_cast<std::size_t>(s.image_count()), "image");
  if (!s.files.empty())
    line += "  " + std::to_string(s.files.front().columns) + "×" +
            std::to_string(s.files.front().rows) + "×" + std::to_string(s.slice_count());
  line += s.usable() ? "  usable" : "  refused: " + s.problems.front();
  return line;
}

std::vector<const DicomSeries*> DicomCatalog::usable_series() const {
  std::vector<const DicomSeries*> out;
  for (const auto& s : series)
    if (s.usable()) out.push_back(&s);
  return out;
}

const DicomSeries* DicomCatalog::find(const std::string& series_uid) const {
  for (const auto& s : series)
    if (s.series_instance_uid == series_uid) return &s;
  return nullptr;
}

void analyze_series(DicomSeries& s, const fs::path& root, const SliceStackOptions& options) {
  auto file_of = [&](int slice) -> const DicomFileInfo& { return s.files[s.slices[slice].file]; };
  auto frame_of = [&](int slice) -> const DicomFrameInfo& {
    return file_of(slice).frames[static_cast<std::size_t>(s.slices[slice].frame)];
  };
  auto name_of = [&](int slice) {
    std::string name = display_path(file_of(slice).path, root);
    if (file_of(slice).number_of_frames > 1)
      name += " frame " + std::to_string(s.slices[slice].frame + 1);
    return name;
  };
  auto describe_groups = [&](const std::vector<std::vector<int>>& groups, auto key_text) {
    std::string out;
    for (const auto& g : groups) {
      std::vector<std::string> names;
      for (int k : g) names.push_back(name_of(k));
      out += (out.empty() ? "" : "; ") + key_text(g.front()) + " in " + plural(g.size(), "slice") +
             " (" + join_limited(names, 3) + ")";
    }
    return out;
  };

  if (s.series_instance_uid.empty())
    s.problems.push_back("the files have no SeriesInstanceUID (0020,000E)");
  if (s.slice_count() < 2) {
    s.problems.push_back(plural(static_cast<std::size_t>(s.slice_count()), "slice") +
                         ": a volume needs at least 2 (import the folder of the whole series)");
    return;
  }

  const auto sizes = group_slices(s, [&](int a, int b) {
    return file_of(a).columns == file_of(b).columns && file_of(a).rows == file_of(b).rows;
  });
  if (sizes.size() > 1)
    s.problems.push_back("images differ in size: " + describe_groups(sizes, [&](int k) {
                           return std::to_string(file_of(k).columns) + "×" +
                                  std::to_string(file_of(k).rows);
                         }));

  std::vector<std::string> no_position, no_orientation, no_spacing;
  for (int k = 0; k < s.slice_count(); ++k) {
    if (!frame_of(k).has_position) no_position.push_back(name_of(k));
    if (!frame_of(k).has_orientation) no_orientation.push_back(name_of(k));
    if (!frame_of(k).has_pixel_spacing) no_spacing.push_back(name_of(k));
  }
  if (!no_position.empty())
    s.problems.push_back("no ImagePositionPatient (0020,0032) in " + join_limited(no_position) +
                         ": slices cannot be placed in patient space");
  if (!no_orientation.empty())
    s.problems.push_back("no ImageOrientationPatient (0020,0037) in " +
                         join_limited(no_orientation));
  if (!no_spacing.empty())
    s.problems.push_back("no PixelSpacing (0028,0030) in " + join_limited(no_spacing));

  bool structural_problem = false;
  if (no_orientation.empty()) {
    const auto orientations = group_slices(s, [&](int a, int b) {
      return same_vector(frame_of(a).row, frame_of(b).row, 1e-4) &&
             same_vector(frame_of(a).column, frame_of(b).column, 1e-4);
    });
    structural_problem = structural_problem || orientations.size() > 1;
    if (orientations.size() > 1)
      s.problems.push_back(
          "images differ in orientation: " + describe_groups(orientations, [&](int k) {
            return "rows " + vec_text(frame_of(k).row) + " columns " + vec_text(frame_of(k).column);
          }));
  }
  if (no_spacing.empty()) {
    const auto spacings = group_slices(s, [&](int a, int b) {
      const auto& fa = frame_of(a);
      const auto& fb = frame_of(b);
      const double tol = 1e-4 * std::max(fa.spacing_between_rows, fa.spacing_between_columns);
      return std::abs(fa.spacing_between_rows - fb.spacing_between_rows) <= tol &&
             std::abs(fa.spacing_between_columns - fb.spacing_between_columns) <= tol;
    });
    structural_problem = structural_problem || spacings.size() > 1;
    if (spacings.size() > 1)
      s.problems.push_back("images differ in pixel spacing: " +
                           describe_groups(spacings, [&](int k) {
                             return format_text("%g", frame_of(k).spacing_between_rows) + "\\" +
                                    format_text("%g", frame_of(k).spacing_between_columns) + " mm";
                           }));
  }

  // Native pixel data shorter than the header declares: refused here, before anything is
  // allocated for the volume (a false header must not make the importer reserve gigabytes).
  for (const auto& f : s.files)
    if (!f.pixel_data_encapsulated && f.pixel_data_bytes < f.decoded_bytes())
      s.problems.push_back("the pixel data of " + display_path(f.path, root) + " hold " +
                           std::to_string(f.pixel_data_bytes) + " bytes, its header declares " +
                           std::to_string(f.columns) + "×" + std::to_string(f.rows) + "×" +
                           std::to_string(f.number_of_frames) + " pixels of " +
                           std::to_string(f.bits_allocated) + " bits (" +
                           std::to_string(f.decoded_bytes()) + " bytes)");

  std::map<std::string, std::vector<std::string>> frames_of_reference, sop_instances;
  for (const auto& f : s.files) {
    if (!f.frame_of_reference_uid.empty())
      frames_of_reference[f.frame_of_reference_uid].push_back(display_path(f.path, root));
    sop_instances[f.sop_instance_uid].push_back(display_path(f.path, root));
  }
  if (frames_of_reference.size() > 1)
    s.problems.push_back("images belong to " + std::to_string(frames_of_reference.size()) +
                         " frames of reference (FrameOfReferenceUID differs): not one volume");
  for (const auto& [uid, names] : sop_instances)
    if (names.size() > 1)
      s.problems.push_back("SOP Instance UID " + (uid.empty() ? std::string("(empty)") : uid) +
                           " is repeated in " + plural(names.size(), "file") + " (" +
                           join_limited(names) +
                           "): copies or re-encodings of one image, not slices of a volume");
  // Duplicate positions are looked for even when other problems were found, so a refusal names
  // every reason; the geometry needs one size, orientation and spacing to be meaningful.
  if (sizes.size() > 1 || !no_position.empty() || !no_orientation.empty() || !no_spacing.empty() ||
      structural_problem)
    return;

  std::vector<Vec3d> positions;
  for (int k = 0; k < s.slice_count(); ++k) positions.push_back(frame_of(k).position);
  const DicomFrameInfo& first = frame_of(0);
  try {
    SliceStackGeometry g = analyze_slice_stack(
        positions, {first.row, first.column}, first.spacing_between_columns,
        first.spacing_between_rows, file_of(0).columns, file_of(0).rows, options);
    for (const auto& d : g.duplicates) {
      std::vector<std::string> names;
      for (int k : d.slices) names.push_back(name_of(k));
      s.problems.push_back(plural(d.slices.size(), "slice") + " share one position (" +
                           format_text("%.3f", d.offset_mm) +
                           " mm along the slice normal): " + join_limited(names) +
                           " — more than one volume in the series (phases, echoes or repeats)");
    }
    if (s.problems.empty()) s.geometry = std::move(g);
  } catch (const Error& e) {
    s.problems.push_back(e.what());
  }
}

DicomCatalog catalog_dicom(const fs::path& path, const CatalogOptions& options) {
  Stopwatch clock;
  DicomCatalog catalog;
  catalog.root = path;
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("'" + path.string() + "' does not exist");

  std::vector<fs::path> candidates;
  if (fs::is_directory(path, ec)) {
    catalog.discovered_by = "folder";
    try {
      for (auto it = fs::recursive_directory_iterator(
               path, fs::directory_options::skip_permission_denied);
           it != fs::recursive_directory_iterator(); ++it)
        if (it->is_regular_file(ec)) candidates.push_back(it->path());
    } catch (const fs::filesystem_error& e) {
      throw Error("cannot list folder '" + path.string() + "': " + e.what());
    }
    std::sort(candidates.begin(), candidates.end());
  } else {
    const DicomFileInfo info = read_dicom_file_info(path);
    if (info.kind == DicomObjectKind::directory) {
      catalog.discovered_by = "DICOMDIR";
      DicomDirContents contents = read_dicomdir(path);
      candidates = std::move(contents.files);
      for (const auto& id : contents.missing)
        catalog.skipped.push_back({fs::path(id), "referenced by the DICOMDIR but not found", {}});
    } else {
      catalog.discovered_by = "file";
      candidates.push_back(path);
    }
  }

  std::map<std::string, std::vector<DicomFileInfo>> by_series;
  {
    Progress progress(
        "scanning DICOM headers", candidates.size(),
        options.show_progress && candidates.size() > 50 && Progress::stderr_is_terminal());
    // Headers are read in parallel (DCMTK objects are independent; its dictionary is locked),
    // then grouped in path order so the result does not depend on thread timing.
    const auto n = static_cast<std::int64_t>(candidates.size());
    std::vector<DicomFileInfo> infos(candidates.size());
    std::vector<std::string> errors(candidates.size());
#pragma omp parallel for schedule(dynamic, 4)
    for (std::int64_t i = 0; i < n; ++i) {
      try {
        infos[static_cast<std::size_t>(i)] =
            read_dicom_file_info(candidates[static_cast<std::size_t>(i)]);
      } catch (const std::exception& e) {
        errors[static_cast<std::size_t>(i)] = e.what();
      }
      progress.advance();
    }
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      ++catalog.files_examined;
      const fs::path& file = candidates[i];
      if (!errors[i].empty()) {
        catalog.skipped.push_back({file, errors[i], {}});
        continue;
      }
      DicomFileInfo& info = infos[i];
      if (info.kind == DicomObjectKind::image) {
        by_series[info.series_instance_uid].push_back(std::move(info));
        continue;
      }
      std::string damaged_series;
      if (info.kind == DicomObjectKind::unreadable) damaged_series = info.series_instance_uid;
      std::string reason = info.skip_reason;
      if (info.kind == DicomObjectKind::not_dicom && is_volume_file_path(file))
        reason = "volume file, not DICOM: import it by its own path";
      else if (info.kind == DicomObjectKind::directory && catalog.discovered_by == "folder")
        reason += ": pass it as PATH to import through it";
      catalog.skipped.push_back({file, reason, damaged_series});
    }
  }

  for (auto& [uid, files] : by_series) {
    DicomSeries s;
    s.series_instance_uid = uid;
    s.modality = files.front().modality;
    s.description = files.front().series_description;
    s.series_number = files.front().series_number;
    s.files = std::move(files);
    for (int f = 0; f < static_cast<int>(s.files.size()); ++f)
      for (int fr = 0; fr < s.files[f].number_of_frames; ++fr) s.slices.push_back({f, fr});
    analyze_series(s, catalog.root, options.geometry);
    for (const auto& k : catalog.skipped)
      if (!uid.empty() && k.series_instance_uid == uid) {
        s.problems.push_back("a file of this series is damaged: " +
                             display_path(k.path, catalog.root) + " (" + k.reason + ")");
        s.geometry.reset();
      }
    catalog.series.push_back(std::move(s));
  }
  std::sort(catalog.series.begin(), catalog.series.end(),
            [](const DicomSeries& a, const DicomSeries& b) {
              const long na = std::atol(a.series_number.c_str());
              const long nb = std::atol(b.series_number.c_str());
              if (na != nb) return na < nb;
              return a.series_instance_uid < b.series_instance_uid;
            });
  catalog.seconds = clock.seconds();
  return catalog;
}

}  // namespace tsf::import

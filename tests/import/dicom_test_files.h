// Crafting DICOM test files: copies of real files with attributes changed through DCMTK.
#pragma once

#include <dcmtk/dcmdata/dcddirif.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

namespace tsf::import::test_files {

/// Loads `source`, lets `change` edit its data set, and saves it to `target` in the source's
/// transfer syntax.
inline void copy_with_changes(const std::filesystem::path& source,
                              const std::filesystem::path& target,
                              const std::function<void(DcmDataset&)>& change) {
  DcmFileFormat file;
  ASSERT_TRUE(file.loadFile(source.c_str()).good()) << source;
  change(*file.getDataset());
  std::filesystem::create_directories(target.parent_path());
  const E_TransferSyntax xfer = file.getDataset()->getOriginalXfer();
  ASSERT_TRUE(file.saveFile(target.c_str(), xfer).good()) << target;
}

/// A fresh SOP Instance UID, so an edited copy is a different image.
inline void new_instance_uid(DcmDataset& ds) {
  char uid[100];
  ds.putAndInsertString(DCM_SOPInstanceUID, dcmGenerateUniqueIdentifier(uid));
}

/// Writes root/DICOMDIR (a General Purpose CD-R file-set, DCMTK's DicomDirInterface) referencing
/// `ids`: files under `root`, '/'-separated.
inline void write_dicomdir(const std::filesystem::path& root, const std::vector<std::string>& ids) {
  // DicomDirInterface takes file IDs relative to the working folder; restored on any exit.
  struct WorkingFolder {
    std::filesystem::path saved = std::filesystem::current_path();
    ~WorkingFolder() { std::filesystem::current_path(saved); }
  } restore;
  std::filesystem::current_path(root);
  DicomDirInterface dicomdir;
  dicomdir.enableInventMode(OFTrue);  // the anonymised sample lacks some record keys
  ASSERT_TRUE(dicomdir.createNewDicomDir(DicomDirInterface::AP_GeneralPurpose, "DICOMDIR").good());
  for (const std::string& id : ids) EXPECT_TRUE(dicomdir.addDicomFile(id.c_str()).good()) << id;
  ASSERT_TRUE(dicomdir.writeDicomDir().good());
}

/// A series of `count` copies of the DICOM file `source` (any transfer syntax), 2 mm apart along
/// z with an axial orientation, new instance UIDs, in `dir` (emptied first): "slice-K.dcm".
inline void series_of_copies(const std::filesystem::path& source, const std::filesystem::path& dir,
                             int count) {
  std::filesystem::remove_all(dir);
  for (int k = 0; k < count; ++k)
    copy_with_changes(source, dir / ("slice-" + std::to_string(k) + ".dcm"), [&](DcmDataset& ds) {
      new_instance_uid(ds);
      ds.putAndInsertString(DCM_ImagePositionPatient, ("0\\0\\" + std::to_string(2 * k)).c_str());
      ds.putAndInsertString(DCM_ImageOrientationPatient, "1\\0\\0\\0\\1\\0");
    });
}

/// The raw bytes of a file.
inline std::string file_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace tsf::import::test_files

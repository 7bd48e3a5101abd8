// A DICOM file re-encoded by GDCM in another transfer syntax: the bundled samples are
// uncompressed, their compressed twins are made by the tests, the import benchmarks and the fuzz
// seed maker when they run.
#pragma once

#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>

#include <filesystem>

namespace tsf::test {

/// Writes `source` encoded in `syntax` to `target`; false when GDCM cannot.
inline bool transcode(const std::filesystem::path& source, const std::filesystem::path& target,
                      gdcm::TransferSyntax::TSType syntax) {
  gdcm::ImageReader reader;
  reader.SetFileName(source.c_str());
  if (!reader.Read()) return false;
  gdcm::ImageChangeTransferSyntax change;
  change.SetTransferSyntax(syntax);
  change.SetInput(reader.GetImage());
  if (!change.Change()) return false;
  gdcm::ImageWriter writer;
  writer.SetFileName(target.c_str());
  writer.SetFile(reader.GetFile());
  writer.SetImage(change.GetOutput());
  return writer.Write();
}

}  // namespace tsf::test

// Writes the seed corpora of the fuzz targets (docs/robustness.md) from the bundled data, small
// on purpose (a fuzzer mutates small inputs faster):
//   build/fuzz/tsf_fuzz_make_seeds fuzz/corpus
//   dicom/    a 32×32 crop of the GE sample's first slice, native (explicit, implicit and
//             big-endian VR, deflated) and in RLE, JPEG lossless (processes 14 and 14 SV1),
//             JPEG-LS (lossless, near-lossless) and JPEG 2000 (lossless, lossy), GDCM encoding
//   volume/   4×4×4 NRRD (raw, gzip), MetaImage, NIfTI and NIfTI gzip, each after the format
//             byte the volume target reads first
//   tsfmesh/  a tetrahedron at rest, one pose and one re-mesh
//   yaml/     the bundled haptics scene and trajectories
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "support/crafted_bytes.h"
#include "support/gdcm_transcode.h"
#include "tissue/io/mesh_sequence_test_helpers.h"

namespace fs = std::filesystem;

namespace {

void write(const fs::path& p, const std::string& bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << bytes;
}

bool dicom_seeds(const fs::path& source_dir, const fs::path& out) {
  const fs::path ge = source_dir / "data-samples" / "ct-head-ge-hispeed-tilt-varspacing" / "01.dcm";
  DcmFileFormat file;
  if (file.loadFile(ge.c_str()).bad()) return false;
  DcmDataset& ds = *file.getDataset();
  const Uint16* pixels = nullptr;
  unsigned long count = 0;
  if (ds.findAndGetUint16Array(DCM_PixelData, pixels, &count).bad() || count < 512u * 512u)
    return false;
  constexpr int kSize = 32;
  std::vector<Uint16> crop(kSize * kSize);
  for (int j = 0; j < kSize; ++j)
    for (int i = 0; i < kSize; ++i) crop[j * kSize + i] = pixels[(240 + j) * 512 + 240 + i];
  ds.putAndInsertUint16(DCM_Rows, kSize);
  ds.putAndInsertUint16(DCM_Columns, kSize);
  ds.putAndInsertUint16Array(DCM_PixelData, crop.data(), crop.size());
  fs::create_directories(out);
  const fs::path native = out / "native.dcm";
  if (file.saveFile(native.c_str(), EXS_LittleEndianExplicit).bad()) return false;
  if (file.saveFile((out / "implicit.dcm").c_str(), EXS_LittleEndianImplicit).bad()) return false;
  if (file.saveFile((out / "big-endian.dcm").c_str(), EXS_BigEndianExplicit).bad()) return false;
  if (file.saveFile((out / "deflate.dcm").c_str(), EXS_DeflatedLittleEndianExplicit).bad())
    return false;
  const std::pair<const char*, gdcm::TransferSyntax::TSType> syntaxes[] = {
      {"rle.dcm", gdcm::TransferSyntax::RLELossless},
      {"jpeg-lossless.dcm", gdcm::TransferSyntax::JPEGLosslessProcess14_1},
      {"jpeg-ls.dcm", gdcm::TransferSyntax::JPEGLSLossless},
      {"j2k.dcm", gdcm::TransferSyntax::JPEG2000Lossless},
      {"jpeg-lossless-57.dcm", gdcm::TransferSyntax::JPEGLosslessProcess14},
      {"jpeg-ls-near.dcm", gdcm::TransferSyntax::JPEGLSNearLossless},
      {"j2k-lossy.dcm", gdcm::TransferSyntax::JPEG2000}};
  for (const auto& [name, syntax] : syntaxes)
    if (!tsf::test::transcode(native, out / name, syntax)) return false;
  return true;
}

void volume_seeds(const fs::path& out) {
  std::string voxels(4 * 4 * 4 * 2, '\0');
  for (std::size_t i = 0; i < voxels.size(); i += 2) voxels[i] = static_cast<char>(i * 7);
  const std::string nrrd =
      "NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 4 4\nendian: little\nspace: "
      "left-posterior-superior\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,1.25)\nspace origin: "
      "(-10,20.5,-30)\nencoding: ";
  write(out / "raw.nrrd", std::string(1, '\0') + nrrd + "raw\n\n" + voxels);
  write(out / "gzip.nrrd",
        std::string(1, '\0') + nrrd + "gzip\n\n" + tsf::test::deflated(voxels, 15 + 16));
  write(out / "image.mha",
        std::string(1, '\1') +
            "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_SHORT\n"
            "ElementSpacing = 0.5 0.5 1.25\nOffset = -10 20.5 -30\nTransformMatrix = 1 0 0 0 1 0 "
            "0 0 1\nElementDataFile = LOCAL\n" +
            voxels);
  const float pixdim[3] = {0.5f, 0.5f, 1.25f}, qoffset[3] = {-10, 20.5f, -30}, srow[4] = {};
  const std::string h = tsf::test::nifti1_header(4, 4, 4, pixdim, 1, qoffset, 0, srow);
  write(out / "image.nii", std::string(1, '\2') + h + voxels);
  write(out / "image.nii.gz", std::string(1, '\3') + tsf::test::deflated(h + voxels, 15 + 16));
}

void tsfmesh_seed(const fs::path& out) {
  fs::create_directories(out);
  tsf::io::write_mesh_sequence(out / "tiny.tsfmesh", tsf::io::test::tiny_sequence());
}

void yaml_seeds(const fs::path& source_dir, const fs::path& out) {
  fs::create_directories(out);
  fs::copy_file(source_dir / "scenes" / "haptics-block.yaml", out / "haptics-block.yaml",
                fs::copy_options::overwrite_existing);
  for (const char* t :
       {"haptics-press-hold.yaml", "haptics-sweep.yaml", "haptics-chamfered-cube.yaml"})
    fs::copy_file(source_dir / "scenes" / "trajectories" / t, out / t,
                  fs::copy_options::overwrite_existing);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: tsf_fuzz_make_seeds CORPUS_DIR  (e.g. fuzz/corpus)\n";
    return 2;
  }
  const fs::path out = argv[1];
  const fs::path source_dir = TSF_SOURCE_DIR;
  if (!dicom_seeds(source_dir, out / "dicom")) {
    std::cerr << "tsf_fuzz_make_seeds: cannot make the DICOM seeds\n";
    return 1;
  }
  volume_seeds(out / "volume");
  tsfmesh_seed(out / "tsfmesh");
  yaml_seeds(source_dir, out / "yaml");
  std::cout << "seeds written to " << out << "\n";
  return 0;
}

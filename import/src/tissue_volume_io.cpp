#include "tsf/import/tissue_volume_io.h"

#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageIOBase.h>
#include <itkVectorImage.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>

#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/import/itk_io_factories.h"
#include "tsf/io/nrrd_volume.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::import {
namespace fs = std::filesystem;

namespace {

using DensityImage = itk::Image<float, 3>;
using LabelImage = itk::Image<unsigned char, 3>;
using WeightImage = itk::VectorImage<unsigned char, 3>;

template <typename Image>
VolumeGeometry geometry_of(const Image* image) {
  VolumeGeometry g;
  const auto size = image->GetLargestPossibleRegion().GetSize();
  g.dims = {static_cast<int>(size[0]), static_cast<int>(size[1]), static_cast<int>(size[2])};
  g.spacing = {image->GetSpacing()[0], image->GetSpacing()[1], image->GetSpacing()[2]};
  g.origin = {image->GetOrigin()[0], image->GetOrigin()[1], image->GetOrigin()[2]};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.direction[r * 3 + c] = image->GetDirection()[r][c];
  return g;
}

template <typename Image>
void set_geometry(Image* image, const VolumeGeometry& g) {
  typename Image::RegionType region;
  region.SetSize({static_cast<itk::SizeValueType>(g.dims.x),
                  static_cast<itk::SizeValueType>(g.dims.y),
                  static_cast<itk::SizeValueType>(g.dims.z)});
  image->SetRegions(region);
  typename Image::SpacingType spacing;
  spacing[0] = g.spacing.x;
  spacing[1] = g.spacing.y;
  spacing[2] = g.spacing.z;
  image->SetSpacing(spacing);
  typename Image::PointType origin;
  origin[0] = g.origin.x;
  origin[1] = g.origin.y;
  origin[2] = g.origin.z;
  image->SetOrigin(origin);
  typename Image::DirectionType dir;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) dir[r][c] = g.direction[r * 3 + c];
  image->SetDirection(dir);
}

template <typename Image>
typename Image::Pointer read_image(const fs::path& path, const char* what) {
  if (!fs::exists(path))
    throw Error(std::string(what) + " file '" + path.string() + "' does not exist");
  register_itk_io_factories();
  auto reader = itk::ImageFileReader<Image>::New();
  reader->SetFileName(path.string());
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error("cannot read " + std::string(what) + " file '" + path.string() +
                "': " + e.GetDescription());
  }
  return reader->GetOutput();
}

template <typename Image>
void write_image(const fs::path& path, const Image* image) {
  register_itk_io_factories();
  write_file_atomically(path, [&](const fs::path& temp) {
    auto writer = itk::ImageFileWriter<Image>::New();
    writer->SetFileName(temp.string());
    writer->SetInput(image);
    writer->SetUseCompression(true);
    try {
      writer->Update();
    } catch (const itk::ExceptionObject& e) {
      throw Error("cannot write '" + path.string() + "': " + e.GetDescription());
    }
  });
}

std::string prefix_of_density(const fs::path& p) {
  const std::string name = p.filename().string();
  const std::string tag = "-density";
  const auto pos = name.rfind(tag);
  if (pos == std::string::npos || pos + tag.size() != name.size() - p.extension().string().size())
    return {};
  return (p.parent_path() / name.substr(0, pos)).string();
}

}  // namespace

TissueVolumePaths TissueVolumePaths::from_prefix(const fs::path& prefix) {
  const std::string s = prefix.string();
  return {fs::path(s + "-density.nrrd"), fs::path(s + "-labels.nrrd"),
          fs::path(s + "-weights.nrrd")};
}

VoxelVolume read_tissue_volume(const fs::path& density_path) {
  // NRRD (what tsf segment writes) through the core's own reader: the ITK-free build (the GPU
  // machine's) reads the same files the same way. ITK reads the other formats (MHA, …).
  std::string lower_ext = density_path.extension().string();
  for (char& c : lower_ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower_ext == ".nrrd" || lower_ext == ".nhdr") {
    if (!fs::exists(density_path))
      throw Error("density file '" + density_path.string() + "' does not exist");
    return io::read_tissue_volume_nrrd(density_path);
  }
  const auto density = read_image<DensityImage>(density_path, "density");
  const VolumeGeometry g = geometry_of(density.GetPointer());
  const std::string prefix = prefix_of_density(density_path);
  const std::string ext = density_path.extension().string();
  const fs::path labels_path = prefix.empty() ? fs::path() : fs::path(prefix + "-labels" + ext);
  const fs::path weights_path = prefix.empty() ? fs::path() : fs::path(prefix + "-weights" + ext);
  const bool has_weights = !weights_path.empty() && fs::exists(weights_path);

  VoxelVolume volume(g, has_weights);
  const std::size_t n = volume.voxel_count();
  const float* src = density->GetBufferPointer();
  auto& dst = volume.density_data();
  for (std::size_t v = 0; v < n; ++v) {
    const float d = src[v];
    if (!(d >= 0.0f && d <= 1.0f))
      throw Error("density file '" + density_path.string() + "': voxel " + std::to_string(v) +
                  " has value " + std::to_string(d) +
                  ", expected a value in [0,1] (is this a HU volume? run `tsf segment` first)");
    dst[v] = d;
  }

  auto& labels = volume.label_data();
  if (!labels_path.empty() && fs::exists(labels_path)) {
    const auto li = read_image<LabelImage>(labels_path, "labels");
    if (!io::same_volume_geometry(geometry_of(li.GetPointer()), g))
      throw Error("labels file '" + labels_path.string() + "' does not match the geometry of '" +
                  density_path.string() + "'");
    std::copy(li->GetBufferPointer(), li->GetBufferPointer() + n, labels.begin());
  } else {
    for (std::size_t v = 0; v < n; ++v)
      labels[v] = dst[v] >= 0.5f ? kLabelSoftTissue : kLabelOutside;
  }

  if (has_weights) {
    const auto wi = read_image<WeightImage>(weights_path, "weights");
    if (wi->GetNumberOfComponentsPerPixel() != 4)
      throw Error("weights file '" + weights_path.string() + "' has " +
                  std::to_string(wi->GetNumberOfComponentsPerPixel()) +
                  " components per voxel, expected 4");
    if (!io::same_volume_geometry(geometry_of(wi.GetPointer()), g))
      throw Error("weights file '" + weights_path.string() + "' does not match the geometry of '" +
                  density_path.string() + "'");
    const unsigned char* w = wi->GetBufferPointer();
    auto& weights = volume.material_weight_data();
    for (std::size_t v = 0; v < n; ++v)
      weights[v] = {w[4 * v], w[4 * v + 1], w[4 * v + 2], w[4 * v + 3]};
  }
  return volume;
}

TissueVolumePaths write_tissue_volume(const fs::path& prefix, const VoxelVolume& volume) {
  volume.validate();
  const VolumeGeometry& g = volume.geometry();
  const std::size_t n = volume.voxel_count();
  TissueVolumePaths paths = TissueVolumePaths::from_prefix(prefix);

  auto density = DensityImage::New();
  set_geometry(density.GetPointer(), g);
  density->Allocate();
  std::copy(volume.density_data().begin(), volume.density_data().end(),
            density->GetBufferPointer());
  write_image(paths.density, density.GetPointer());

  auto labels = LabelImage::New();
  set_geometry(labels.GetPointer(), g);
  labels->Allocate();
  std::copy(volume.label_data().begin(), volume.label_data().end(), labels->GetBufferPointer());
  write_image(paths.labels, labels.GetPointer());

  if (volume.has_material_weights()) {
    auto weights = WeightImage::New();
    set_geometry(weights.GetPointer(), g);
    weights->SetNumberOfComponentsPerPixel(4);
    weights->Allocate();
    unsigned char* w = weights->GetBufferPointer();
    const auto& src = volume.material_weight_data();
    for (std::size_t v = 0; v < n; ++v)
      for (int c = 0; c < 4; ++c) w[4 * v + c] = src[v][c];
    write_image(paths.weights, weights.GetPointer());
  } else {
    paths.weights.clear();
  }
  return paths;
}

}  // namespace tsf::import

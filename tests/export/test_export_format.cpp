// Format names, extensions and the options each format allows (export_format.h, mesh_export.h).
#include <gtest/gtest.h>

#include "tsf/common/error.h"
#include "tsf/export/export_format.h"
#include "tsf/export/frame_selection.h"
#include "tsf/export/mesh_export.h"

namespace tsf::exporter {
namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ExportFormat, ExtensionsPickTheBinaryFormats) {
  EXPECT_EQ(format_from_path("a/b.glb"), ExportFormat::glb);
  EXPECT_EQ(format_from_path("x.GLTF"), ExportFormat::gltf);
  EXPECT_EQ(format_from_path("x.obj"), ExportFormat::obj);
  EXPECT_EQ(format_from_path("x.stl"), ExportFormat::stl);
  EXPECT_EQ(format_from_path("x.ply"), ExportFormat::ply);
  EXPECT_EQ(format_from_path("x.Fbx"), ExportFormat::fbx);
  const std::string e = error_of([] { format_from_path("mesh.dae"); });
  EXPECT_NE(e.find("'.dae'"), std::string::npos) << e;
  EXPECT_NE(e.find(".glb"), std::string::npos) << "lists the supported extensions: " << e;
}

TEST(ExportFormat, NamesRoundTripAndMismatchesAreErrors) {
  for (const auto& f : export_formats()) {
    EXPECT_EQ(format_from_name(f.name), f.format);
    EXPECT_EQ(format_info(f.format).name, std::string(f.name));
  }
  EXPECT_NE(error_of([] { format_from_name("collada"); }).find("glb, gltf"), std::string::npos);
  EXPECT_NE(error_of([] {
              require_extension_matches("out.glb", ExportFormat::obj);
            }).find("writes '.obj'"),
            std::string::npos);
  EXPECT_EQ(error_of([] { require_extension_matches("OUT.STL", ExportFormat::stl_ascii); }), "");
}

TEST(ExportFormat, UnitsAndAxesNames) {
  EXPECT_EQ(unit_from_name("MM"), LengthUnit::millimetre);
  EXPECT_EQ(unit_from_name("m"), LengthUnit::metre);
  EXPECT_THROW(unit_from_name("cm"), Error);
  EXPECT_EQ(axes_from_name("y-up"), AxisConvention::y_up);
  EXPECT_EQ(axes_from_name("RAS"), AxisConvention::ras);
  EXPECT_THROW(axes_from_name("zup"), Error);
}

TEST(ExportOptions, FormatsFixWhatTheirSpecificationFixes) {
  ExportOptions o;
  o.format = ExportFormat::glb;
  EXPECT_EQ(o.resolved_units(), LengthUnit::metre);
  EXPECT_EQ(o.resolved_axes(), AxisConvention::y_up);
  o.units = LengthUnit::millimetre;
  EXPECT_NE(error_of([&] { o.validate(); }).find("metres"), std::string::npos);
  o = {};
  o.format = ExportFormat::gltf;
  o.axes = AxisConvention::lps;
  EXPECT_THROW(o.validate(), Error);
  o = {};
  o.format = ExportFormat::fbx;
  o.axes = AxisConvention::ras;
  EXPECT_THROW(o.validate(), Error);
  o.axes.reset();
  o.units = LengthUnit::metre;
  EXPECT_NO_THROW(o.validate());
  o = {};
  o.format = ExportFormat::stl;
  EXPECT_EQ(o.resolved_axes(), AxisConvention::lps);
  EXPECT_EQ(o.resolved_units(), LengthUnit::millimetre);
  o.split_labels = true;
  EXPECT_NE(error_of([&] { o.validate(); }).find("--split-labels"), std::string::npos);
  o = {};
  o.time_scale = 0.0;
  EXPECT_THROW(o.validate(), Error);
}

TEST(FrameSelection, ParsesEveryFormAndChecksRanges) {
  EXPECT_EQ(FrameSelection::parse("all").states(3), (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ(FrameSelection::parse("last").states(3), (std::vector<std::size_t>{2}));
  EXPECT_EQ(FrameSelection::parse("last").states(1), (std::vector<std::size_t>{0}));
  EXPECT_EQ(FrameSelection::parse("rest").states(5), (std::vector<std::size_t>{0}));
  EXPECT_EQ(FrameSelection::parse("4").states(5), (std::vector<std::size_t>{4}));
  EXPECT_EQ(FrameSelection::parse("1:3").states(5), (std::vector<std::size_t>{1, 2, 3}));
  EXPECT_NE(error_of([] { FrameSelection::parse("5").states(5); }).find("states 0..4"),
            std::string::npos);
  for (const char* bad : {"", "first", "3:1", "-1", "1:", ":2", "2.5", "1:2:3"})
    EXPECT_THROW(FrameSelection::parse(bad), Error) << bad;
}

TEST(NumberedPath, PadsToFourDigitsOrMore) {
  EXPECT_EQ(numbered_path("out/tissue.glb", 7, 12), std::filesystem::path("out/tissue-0007.glb"));
  EXPECT_EQ(numbered_path("t.obj", 3, 123456), std::filesystem::path("t-000003.obj"));
}

}  // namespace
}  // namespace tsf::exporter

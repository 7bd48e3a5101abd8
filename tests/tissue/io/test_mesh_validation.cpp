// validate_mesh_quickly agrees with imt::validate_mesh: silent on a good mesh, the same message
// on a bad one.
#include <gtest/gtest.h>

#include <cmath>

#include "mesh_sequence_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/io/mesh_validation.h"

namespace tsf::io {
namespace {

std::string message(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(MeshValidation, SameVerdictAndMessageAsImtValidateMesh) {
  const imt::SurfaceMesh good = test::labelled_sphere(test::oblique_geometry(), 4.0);
  EXPECT_NO_THROW(validate_mesh_quickly(good));
  std::vector<imt::SurfaceMesh> bad(5, good);
  bad[0].labels.pop_back();
  bad[1].normals.pop_back();
  bad[2].positions[17].z = std::nanf("");
  bad[3].normals[3].x = INFINITY;
  bad[4].triangles[9][1] = static_cast<std::uint32_t>(good.vertex_count());
  for (std::size_t i = 0; i < bad.size(); ++i) {
    const std::string quick = message([&] { validate_mesh_quickly(bad[i]); });
    EXPECT_FALSE(quick.empty()) << "case " << i;
    EXPECT_EQ(quick, message([&] { imt::validate_mesh(bad[i]); })) << "case " << i;
  }
}

}  // namespace
}  // namespace tsf::io

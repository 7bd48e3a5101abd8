// A 4 mm cube centred on its origin, for the mesh-tool tests: its 8 corners, its 12 triangles
// (0-based, counter-clockwise seen from outside) and the same as Wavefront OBJ text.
#pragma once

#include <sstream>
#include <string>

namespace tsf::test {

inline constexpr double kCubeVertices[8][3] = {{-2, -2, -2}, {2, -2, -2}, {-2, 2, -2}, {2, 2, -2},
                                               {-2, -2, 2},  {2, -2, 2},  {-2, 2, 2},  {2, 2, 2}};
/// Triangles 2 and 3 are the top face (z = +2).
inline constexpr int kCubeTriangles[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6},
                                              {0, 1, 4}, {1, 5, 4}, {2, 6, 3}, {3, 6, 7},
                                              {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};

/// The cube as OBJ text; `without_top`: its top face left out (an open mesh).
inline std::string cube_obj(bool without_top = false) {
  std::ostringstream obj;
  for (const auto& p : kCubeVertices) obj << "v " << p[0] << " " << p[1] << " " << p[2] << "\n";
  for (int t = 0; t < 12; ++t) {
    if (without_top && (t == 2 || t == 3)) continue;
    obj << "f " << kCubeTriangles[t][0] + 1 << " " << kCubeTriangles[t][1] + 1 << " "
        << kCubeTriangles[t][2] + 1 << "\n";
  }
  return obj.str();
}

}  // namespace tsf::test

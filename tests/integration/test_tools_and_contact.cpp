// Several tools at once, tools read from mesh files and one tissue instance resting on another,
// through the commands a user runs (`tsf simulate` on the shipped scenes): two tools act in one
// frame, a mesh tool presses the tissue, a soft block rests on a bone instance without passing
// through it (and falls through without the contact), and bad tool files and contact keys are
// refused by name.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "cube_mesh.h"
#include "support/test_data.h"
#include "support/tsf_process.h"
#include "tsf/imt/surface_ply.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct Simulated {
  test::ProcessRun process;
  json report;
  fs::path out;
};

Simulated simulate(const fs::path& scene, const std::string& tag, const std::string& extra = "") {
  Simulated s;
  s.out = test::scratch_dir("tools-contact-" + tag) / "out";
  s.process = test::run_tsf(test::tsf_executable_path(),
                            "simulate -q --backend cpu " + test::shell_quoted(scene) + " --out " +
                                test::shell_quoted(s.out) + " " + extra);
  if (s.process.status == 0 && fs::exists(s.out / "report.json"))
    s.report = json::parse(test::read_text(s.out / "report.json"));
  return s;
}

/// `scene` with `from` replaced by `to`, written next to a copy of scenes/tools.
fs::path edited(const std::string& scene, const std::string& tag, const std::string& from,
                const std::string& to) {
  const fs::path dir = test::scratch_dir("tools-contact-scene-" + tag);
  std::string text = test::read_text(test::source_dir() / "scenes" / scene);
  if (!from.empty()) {
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  }
  fs::create_directories(dir / "tools");
  fs::copy_file(test::source_dir() / "scenes" / "tools" / "endoscope.stl",
                dir / "tools" / "endoscope.stl", fs::copy_options::overwrite_existing);
  std::ofstream(dir / scene) << text;
  return dir / scene;
}

/// One edit of a shipped scene that `tsf simulate` must refuse, naming `expect`.
struct Refusal {
  std::string name, from, to, expect;
};

void expect_refused(const std::string& scene, const std::vector<Refusal>& cases) {
  for (const Refusal& c : cases) {
    const Simulated s = simulate(edited(scene, c.name, c.from, c.to), "bad-" + c.name);
    EXPECT_NE(s.process.status, 0) << c.name;
    EXPECT_NE(s.process.output.find(c.expect), std::string::npos)
        << c.name << ": expected '" << c.expect << "' in: " << s.process.output;
  }
}

#define TSF_NEED_EXE()                          \
  if (!fs::exists(test::tsf_executable_path())) \
  GTEST_SKIP() << "not run: the tsf executable is not built at " << test::tsf_executable_path()

TEST(TwoTools, TheEndoscopePressesWhileTheWandAblatesInTheSameFrames) {
  TSF_NEED_EXE();
  const Simulated s = simulate(test::source_dir() / "scenes" / "two-tools.yaml", "two");
  ASSERT_EQ(s.process.status, 0) << s.process.output;
  const json& r = s.report;
  // Frames in which the wand removed tissue (edit times: the frame's start)…
  std::map<long, double> ablated;
  for (const json& e : r["edits"])
    if (e["tool"] == "wand")
      ablated[std::lround(e["time_s"].get<double>() * 200)] += e["removed_mm3"].get<double>();
  // …and frames in which the endoscope held tissue (contact samples: the frame's end).
  int both = 0;
  double scope_force = 0;
  for (const json& c : r["contact"])
    for (const json& t : c["tools"])
      if (t["tool"] == "scope" && t["nodes_held"].get<int>() > 0) {
        scope_force = std::max(scope_force, t["force_un"][2].get<double>());
        const long frame = std::lround(c["time_s"].get<double>() * 200) - 1;
        both += ablated.count(frame) && ablated[frame] > 0;
      }
  EXPECT_GE(both, 5) << "frames with both tools acting: " << both;
  EXPECT_GT(scope_force, 0.0) << "the tissue pushes the endoscope up";
  EXPECT_GT(r["totals"]["removed_mm3"].get<double>(), 5.0);
  EXPECT_EQ(r["surface"]["closed_manifold_end"], true);
  EXPECT_NE(r["stability"]["verdict"], "unstable") << r["stability"].dump();
}

TEST(TwoTools, AMeshToolPressesTheTissueAndKeepsItOut) {
  TSF_NEED_EXE();
  // The endoscope alone: the scene without the wand's trajectory.
  const fs::path scene = edited("two-tools.yaml", "scope-only", "", "");
  std::string text = test::read_text(scene);
  text = text.substr(0, text.find("    - tool: wand          #")) +
         text.substr(text.find("outputs:\n"));
  std::ofstream(scene) << text;
  const Simulated s = simulate(scene, "scope");
  ASSERT_EQ(s.process.status, 0) << s.process.output;
  int held = 0;
  double max_nodes = 0;
  for (const json& c : s.report["contact"]) {
    held += c["nodes_held"].get<int>() > 0;
    max_nodes = std::max(max_nodes, c["nodes_held"].get<double>());
  }
  EXPECT_GT(held, 10) << "the endoscope holds tissue over many frames";
  EXPECT_GE(max_nodes, 2.0);
  EXPECT_GT(s.report["max_tool_force_un"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(s.report["totals"]["removed_mm3"].get<double>(), 0.0) << "it only presses";
}

TEST(TwoTools, BadToolFilesAndShapesAreRefusedByName) {
  TSF_NEED_EXE();
  const fs::path dir = test::scratch_dir("tools-contact-bad-meshes");
  // A 4 mm cube with its top face missing.
  std::ofstream(dir / "open.obj") << test::cube_obj(/*without_top=*/true);
  std::ofstream(dir / "broken.ply") << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                                       "end_header\n0\n1\n";
  std::ofstream(dir / "tool.gltf") << "{}";
  expect_refused(
      "two-tools.yaml",
      {
          {"missing", "file: tools/endoscope.stl", "file: tools/nowhere.stl",
           "tools[0].file: no such file"},
          {"open", "file: tools/endoscope.stl", "file: " + (dir / "open.obj").string(),
           "the mesh is not closed"},
          {"broken-ply", "file: tools/endoscope.stl", "file: " + (dir / "broken.ply").string(),
           "has no property y"},
          {"format", "file: tools/endoscope.stl", "file: " + (dir / "tool.gltf").string(),
           "expected a mesh file .obj, .stl or .ply"},
          {"radius", "    grid: 0.2 ", "    radius: 2\n    grid: 0.2 ",
           "tools[0].radius: not for a mesh tool"},
          {"ablate", "mode: press}\n        - {time: 0.04", "mode: ablate}\n        - {time: 0.04",
           "cannot ablate"},
      });
}

TEST(TwoTools, AMeshToolReadsTheSameFromObjStlAndPly) {
  TSF_NEED_EXE();
  // One 4 mm cube written five ways; the same press with each gives the same contact.
  const fs::path dir = test::scratch_dir("tools-contact-formats");
  const auto& v = test::kCubeVertices;
  const auto& f = test::kCubeTriangles;
  {
    std::ofstream obj(dir / "cube.obj");
    for (const auto& p : v) obj << "v " << p[0] << " " << p[1] << " " << p[2] << "\n";
    for (const auto& t : f)
      obj << "f " << t[0] + 1 << "/1 " << t[1] + 1 << "/1 " << t[2] + 1 << "/1\n";
    std::ofstream stl(dir / "cube.stl");
    stl << "solid cube\n";
    for (const auto& t : f) {
      stl << " facet normal 0 0 0\n  outer loop\n";
      for (int k : t) stl << "   vertex " << v[k][0] << " " << v[k][1] << " " << v[k][2] << "\n";
      stl << "  endloop\n endfacet\n";
    }
    stl << "endsolid cube\n";
    std::ofstream ply(dir / "cube.ply");
    ply << "ply\nformat ascii 1.0\ncomment a cube\nelement vertex 8\nproperty double x\n"
           "property double y\nproperty double z\nproperty uchar red\nelement face 12\n"
           "property list uchar int vertex_indices\nend_header\n";
    for (const auto& p : v) ply << p[0] << " " << p[1] << " " << p[2] << " 7\n";
    for (const auto& t : f) ply << "3 " << t[0] << " " << t[1] << " " << t[2] << "\n";
    std::ofstream bin(dir / "cube-binary.ply", std::ios::binary);
    bin << "ply\nformat binary_big_endian 1.0\nelement vertex 8\nproperty float x\n"
           "property float y\nproperty float z\nelement face 12\n"
           "property list uchar int vertex_indices\nend_header\n";
    auto put = [&](const void* data, std::size_t n) {
      const auto* b = static_cast<const unsigned char*>(data);
      for (std::size_t i = n; i-- > 0;) bin.put(static_cast<char>(b[i]));  // big endian
    };
    for (const auto& p : v)
      for (double c : p) {
        const float x = static_cast<float>(c);
        put(&x, 4);
      }
    for (const auto& t : f) {
      bin.put(3);
      for (int k : t) put(&k, 4);
    }
    // The same cube as quads (OBJ polygons are fanned into triangles).
    std::ofstream quads(dir / "cube-quads.obj");
    for (const auto& p : v) quads << "v " << p[0] << " " << p[1] << " " << p[2] << "\n";
    quads << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  }
  std::vector<double> forces;
  for (const char* file :
       {"cube.obj", "cube.stl", "cube.ply", "cube-binary.ply", "cube-quads.obj"}) {
    std::ofstream(dir / "scene.yaml")
        << "lattice: {source: box, size: [12, 8, 8], spacing: 2}\n"
           "material: {youngs_modulus: 30000, viscosity: 2, density: 0.001}\n"
           "solver: {backend: cpu, dt: auto}\n"
           "anchors: [{box: {min: [-1, -1, -1], max: [13, 9, 1]}}]\n"
           "tools: [{name: cube, shape: mesh, file: "
        << file
        << ", grid: 0.25}]\n"
           "script: {frame_rate: 500, duration: 0.01, trajectories: [{tool: cube, keyframes: "
           "[{time: 0, position: [6, 4, 10], mode: press}, {time: 0.008, position: [6, 4, 9], "
           "mode: press}]}]}\n"
           "outputs: {report: report.json}\n";
    const Simulated s = simulate(dir / "scene.yaml", std::string("format-") + file);
    ASSERT_EQ(s.process.status, 0) << file << ": " << s.process.output;
    forces.push_back(s.report["max_tool_force_un"].get<double>());
  }
  EXPECT_GT(forces[0], 0.0);
  for (std::size_t i = 1; i < forces.size(); ++i)
    EXPECT_NEAR(forces[i], forces[0], 1e-3 * forces[0]) << "format " << i;
}

double lowest_z(const fs::path& ply) {
  const imt::SurfaceMesh m = imt::read_surface_ply(ply);
  double z = 1e9;
  for (const Vec3f& p : m.positions) z = std::min(z, double(p.z));
  return z;
}

double highest_z(const fs::path& ply) {
  const imt::SurfaceMesh m = imt::read_surface_ply(ply);
  double z = -1e9;
  for (const Vec3f& p : m.positions) z = std::max(z, double(p.z));
  return z;
}

TEST(InstanceContact, ASoftBlockRestsOnTheBoneInsteadOfPassingThrough) {
  TSF_NEED_EXE();
  const Simulated s = simulate(test::source_dir() / "scenes" / "rest-on-bone.yaml", "rest");
  ASSERT_EQ(s.process.status, 0) << s.process.output;
  const json& soft = s.report["instances"][0];
  ASSERT_EQ(soft["instance"], "soft");
  // The block fell its 1 mm gap and lies on the bone: its surface's lowest point at the bone's
  // top (z = 6; the bone sags a little under it), not below it.
  const double soft_low = lowest_z(s.out / "final-soft.ply");
  const double bone_top = highest_z(s.out / "final-bone.ply");
  EXPECT_LT(soft_low, 7.0 - 0.5) << "the block fell onto the bone";
  EXPECT_GT(soft_low, bone_top - 1.0) << "the block's surface stays on the bone (within a spacing)";
  EXPECT_GT(lowest_z(s.out / "final-soft.ply"), 3.0);
  // The bone holds it up, and the block comes to rest.
  const json& body = soft["body_contact"];
  ASSERT_TRUE(body.is_object()) << soft.dump().substr(0, 400);
  EXPECT_EQ(body["pushed_by"], json::array({"bone"}));
  ASSERT_FALSE(body["samples"].empty());
  const json& last = body["samples"].back();
  EXPECT_GT(last["nodes_held"].get<int>(), 4);
  EXPECT_GT(last["force_un"][2].get<double>(), 0.0);
  EXPECT_NE(soft["stability"]["verdict"], "unstable");

  // Without the contact the same block falls through the bone.
  const Simulated through = simulate(
      edited("rest-on-bone.yaml", "no-contact", "    contact: {pushed_by: [bone]}", ""), "through");
  ASSERT_EQ(through.process.status, 0) << through.process.output;
  EXPECT_LT(lowest_z(through.out / "final-soft.ply"), 0.0) << "no contact: it falls through";
}

TEST(InstanceContact, ContactKeysAreCheckedByName) {
  TSF_NEED_EXE();
  expect_refused(
      "rest-on-bone.yaml",
      {
          {"unknown", "    contact: {pushed_by: [bone]}", "    contact: {pushed_by: [skull]}",
           "tissues[0].contact.pushed_by[0]: no instance named 'skull'"},
          {"self", "    contact: {pushed_by: [bone]}", "    contact: {pushed_by: [soft]}",
           "an instance does not push itself"},
          {"circle", "    tissue: {voxels_per_node: 2}\nscript:",
           "    tissue: {voxels_per_node: 2}\n    contact: {pushed_by: [soft]}\nscript:",
           "contact is one way"},
          {"key", "    contact: {pushed_by: [bone]}", "    contact: {pushed: [bone]}",
           "tissues[0].contact.pushed: unknown key"},
      });
}

}  // namespace
}  // namespace tsf

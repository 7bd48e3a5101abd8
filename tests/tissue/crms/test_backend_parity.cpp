// CPU vs CUDA: the same scene with the same integrator stays within 1e-4 (relative to the largest
// displacement) after 1,000 steps, for every formulation and effect combination.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "physics_assertions.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/io/nrrd_volume.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::crms {
namespace {

std::vector<Vec3f> run(Backend backend, unsigned combo, Integrator integrator) {
  auto [l, c] = test::parity_scene(backend, combo);
  c.integrator = integrator;
  c.gravity = {0, 0, -9810};
  Solver s(std::move(l), c);
  test::with_parity_loads(s, combo);
  const double dt = 0.5 * s.stable_dt();
  s.step(997, dt);  // not a multiple of the graph size: graphs and single launches both run
  s.step(3, dt);
  EXPECT_FALSE(s.instability().has_value());
  return s.positions();
}

TEST(CrmsBackendParity, CpuAndCudaAgreeAfter1000Steps) {
  if (!cuda_status().available) GTEST_SKIP() << "CUDA parity not run: " << cuda_status().reason;
  const Lattice rest = test::box({12, 8, 6}, 1);
  for (unsigned combo = 0; combo < 16; ++combo)
    for (Integrator integrator : {Integrator::kSymplecticEuler, Integrator::kExplicitEuler}) {
      const auto cpu = run(Backend::kCpu, combo, integrator);
      const auto gpu = run(Backend::kCuda, combo, integrator);
      double diff = 0, scale = 0;
      for (std::size_t n = 0; n < cpu.size(); ++n) {
        diff = std::max(diff, static_cast<double>(length(cpu[n] - gpu[n])));
        scale = std::max(scale, length(to_double(cpu[n]) - rest.geometry().rest_position(n)));
      }
      EXPECT_LE(diff, 1e-4 * scale) << "combo " << combo << " " << to_string(integrator)
                                    << ": max difference " << diff << " mm of " << scale << " mm";
    }
}

/// A scene that exercises every part of the shared evaluation: tile and slab borders (odd sizes,
/// small tiles), dead nodes, a broken spring, anchors, two materials, external forces, gravity.
struct SharedScene {
  Int3 size{13, 11, 17};
  std::vector<Vec3f> run(SolverConfig c, int steps, unsigned features_combo) const {
    Lattice l = test::box({double(size.x), double(size.y), double(size.z)}, 1);
    fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
    const bool hetero = features_combo & 1, external = features_combo & 2;
    if (hetero)
      for (std::int64_t n = 0; n < l.node_count(); ++n)
        if (l.geometry().rest_position(n).z > 8) l.set_material(n, 1);
    l.set_alive(l.geometry().index(6, 5, 8), false);
    l.set_alive(l.geometry().index(12, 0, 16), false);
    c.angular_form = (features_combo & 4) ? AngularForm::kCosine : AngularForm::kExact;
    c.angular_reactions = AngularReactions::kSymmetric;
    c.materials = {test::soft_material(10e3, 2e-4)};
    if (hetero) c.materials.push_back(test::soft_material(40e3, 1e-4));
    c.gravity = {0, -3000, -9810};
    Solver s(std::move(l), c);
    s.break_springs({{s.lattice().geometry().index(7, 7, 7), 5}});
    if (external) {
      const auto tip = test::nodes_where(s.lattice(), [](Vec3d p) { return p.x > 11; });
      s.set_external_forces(tip, std::vector<Vec3f>(tip.size(), Vec3f{0, 50, -20}));
    }
    const double dt = 0.5 * s.stable_dt();
    s.step(steps - 3, dt);
    s.step(3, dt);
    EXPECT_FALSE(s.instability().has_value());
    return s.positions();
  }
};

double max_difference_relative(const std::vector<Vec3f>& a, const std::vector<Vec3f>& b,
                               const Lattice& rest) {
  double diff = 0, scale = 0;
  for (std::size_t n = 0; n < a.size(); ++n) {
    diff = std::max(diff, static_cast<double>(length(a[n] - b[n])));
    scale = std::max(scale, length(to_double(a[n]) - rest.geometry().rest_position(n)));
  }
  return diff / scale;
}

TEST(CrmsBackendParity, SharedEvaluationMatchesPerNodeOnEveryInstructionSetAndTiling) {
  const SharedScene scene;
  const Lattice rest = test::box({13, 11, 17}, 1);
  for (unsigned combo : {0u, 3u, 4u, 7u}) {
    SolverConfig reference;
    reference.backend = Backend::kCpu;
    reference.force_evaluation = ForceEvaluation::kPerNode;
    reference.cpu_instruction_set = CpuInstructionSet::kBaseline;
    const auto expected = scene.run(reference, 300, combo);
    int instruction_sets_run = 0;
    for (CpuInstructionSet isa :
         {CpuInstructionSet::kBaseline, CpuInstructionSet::kAvx2, CpuInstructionSet::kAvx512}) {
      for (int tile_rows : {0, 1, 4}) {
        SolverConfig c = reference;
        c.force_evaluation = ForceEvaluation::kShared;
        c.cpu_instruction_set = isa;
        c.cpu_tile_rows = tile_rows;
        std::vector<Vec3f> got;
        try {
          got = scene.run(c, 300, combo);
        } catch (const Error& e) {
          // This processor lacks the instruction set: nothing to compare (counted below).
          EXPECT_NE(std::string(e.what()).find("not supported"), std::string::npos) << e.what();
          break;
        }
        if (tile_rows == 0) ++instruction_sets_run;
        EXPECT_LE(max_difference_relative(got, expected, rest), 1e-5)
            << "combo " << combo << ", " << to_string(isa) << ", tile rows " << tile_rows;
      }
      // The per-node kernels of every instruction set agree as well.
      SolverConfig c = reference;
      c.cpu_instruction_set = isa;
      try {
        EXPECT_LE(max_difference_relative(scene.run(c, 300, combo), expected, rest), 1e-5)
            << "per-node, combo " << combo << ", " << to_string(isa);
      } catch (const Error&) {
      }
    }
    EXPECT_GE(instruction_sets_run, 1);
    if (cuda_status().available) {
      for (CudaLaunch launch : {CudaLaunch::kGraphs, CudaLaunch::kPersistent})
        for (CudaTileKernel kernel : {CudaTileKernel::kStaged, CudaTileKernel::kDirect})
          for (int rows : {4, 8})
            for (int planes : {0, 1, 3}) {
              if (launch == CudaLaunch::kPersistent && kernel != CudaTileKernel::kStaged)
                continue;  // the persistent launch has one tile kernel
              SolverConfig c = reference;
              c.backend = Backend::kCuda;
              c.force_evaluation = ForceEvaluation::kShared;
              c.cuda_tile_rows = rows;
              c.cuda_planes_per_block = planes;
              c.cuda_launch = launch;
              c.cuda_tile_kernel = kernel;
              EXPECT_LE(max_difference_relative(scene.run(c, 300, combo), expected, rest), 1e-4)
                  << "CUDA shared, combo " << combo << ", " << to_string(launch) << ", "
                  << to_string(kernel) << " tile kernel, rows " << rows << ", planes " << planes;
            }
      SolverConfig c = reference;
      c.backend = Backend::kCuda;
      EXPECT_LE(max_difference_relative(scene.run(c, 300, combo), expected, rest), 1e-4)
          << "CUDA per-node, combo " << combo;
      c.force_evaluation = ForceEvaluation::kShared;
      for (CudaLaunch launch : {CudaLaunch::kNodes, CudaLaunch::kBricks}) {
        c.cuda_launch = launch;
        EXPECT_LE(max_difference_relative(scene.run(c, 300, combo), expected, rest), 1e-4)
            << "CUDA " << to_string(launch) << ", combo " << combo;
      }
    }
  }
}

/// A lattice whose lower half is anchored and whose corner is dead, so whole tiles of the CUDA
/// shared evaluation move no node (they only copy the state) and the node-parallel kernel steps
/// only part of the nodes: CPU, CUDA with graphs (either tile kernel), with one persistent launch
/// over tiles and with the node-parallel launch agree, also after anchors are released (tiles turn
/// active) and nodes die (tiles turn idle, the alive list shrinks) between calls.
TEST(CrmsBackendParity, IdleTilesAndPersistentLaunchesMatchTheCpu) {
  if (!cuda_status().available) GTEST_SKIP() << "CUDA parity not run: " << cuda_status().reason;
  auto run = [](Backend backend, CudaLaunch launch,
                CudaTileKernel kernel = CudaTileKernel::kStaged) {
    Lattice l = test::box({20, 14, 24}, 1);
    fix_nodes_in_box(l, {-1, -1, -1}, {30, 30, 11.5});
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      const Vec3d p = l.geometry().rest_position(n);
      if (p.x > 15 && p.y > 10 && p.z > 18) l.set_alive(n, false);
    }
    SolverConfig c;
    c.backend = backend;
    c.cuda_launch = launch;
    c.cuda_tile_kernel = kernel;
    c.cuda_planes_per_block = 4;  // tiles of 4 planes: planes 0–11 form whole anchored tiles
    c.materials = {test::soft_material(10e3, 2e-4)};
    c.gravity = {0, -3000, -9810};
    Solver s(std::move(l), c);
    const double dt = 0.5 * s.stable_dt();
    s.step(251, dt);
    // Release a band of anchors (their tiles start to move) and delete a column (idle again).
    s.release_nodes(
        test::nodes_where(s.lattice(), [](Vec3d p) { return p.z > 7.5 && p.z < 11.5; }));
    s.delete_nodes(test::nodes_where(s.lattice(), [](Vec3d p) { return p.x < 3.5 && p.y < 3.5; }));
    s.step(250, dt);
    EXPECT_FALSE(s.instability().has_value());
    return s.positions();
  };
  const Lattice rest = test::box({20, 14, 24}, 1);
  const auto cpu = run(Backend::kCpu, CudaLaunch::kAuto);
  for (CudaLaunch launch :
       {CudaLaunch::kGraphs, CudaLaunch::kPersistent, CudaLaunch::kNodes, CudaLaunch::kBricks})
    EXPECT_LE(max_difference_relative(run(Backend::kCuda, launch), cpu, rest), 1e-4)
        << to_string(launch);
  EXPECT_LE(max_difference_relative(
                run(Backend::kCuda, CudaLaunch::kGraphs, CudaTileKernel::kDirect), cpu, rest),
            1e-4)
      << "graphs, direct tile kernel";
}

/// The segmented cranium (the committed sample: tsf segment's sinus output around the nose) as a
/// lattice at 2 voxels per node with its bone anchored, sagging under gravity: every CUDA launch
/// form agrees with the CPU on patient tissue, not only on boxes.
TEST(CrmsBackendParity, SegmentedCraniumAgreesOnEveryLaunch) {
  if (!cuda_status().available) GTEST_SKIP() << "CUDA parity not run: " << cuda_status().reason;
  const VoxelVolume volume = io::read_tissue_volume_nrrd(
      tsf::test::samples_dir() / "ct-head-cranium" / "segmented" / "cranium-density.nrrd");
  VolumeLatticeOptions o;
  o.node_spacing_voxels = 2;
  const Lattice rest = build_lattice_from_volume(volume, o);
  auto run = [&](Backend backend, CudaLaunch launch) {
    Lattice l = rest;
    fix_nodes_with_labels(l, {kLabelCancellousBone, kLabelCorticalBone});
    SolverConfig c;
    c.backend = backend;
    c.cuda_launch = launch;
    c.materials = {test::soft_material(20e3, 2e-4)};
    c.gravity = {0, 0, -9810};
    Solver s(std::move(l), c);
    const double dt = 0.5 * s.stable_dt();
    s.step(400, dt);
    EXPECT_FALSE(s.instability().has_value());
    return s.positions();
  };
  const auto cpu = run(Backend::kCpu, CudaLaunch::kAuto);
  for (CudaLaunch launch :
       {CudaLaunch::kGraphs, CudaLaunch::kPersistent, CudaLaunch::kNodes, CudaLaunch::kBricks})
    EXPECT_LE(max_difference_relative(run(Backend::kCuda, launch), cpu, rest), 1e-4)
        << to_string(launch);
}

}  // namespace
}  // namespace tsf::crms

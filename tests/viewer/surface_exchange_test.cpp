// The render hand-off copies only changed vertex ranges, and the result equals a full upload.
// No X server needed: VTK data objects only.
#include <gtest/gtest.h>

#include <cstring>

#include <vtkCellArray.h>
#include <vtkDataArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>

#include "tsf/viewer/surface_exchange.h"
#include "tsf/viewer/surface_uploader.h"
#include "viewer_fixture.h"

namespace tsf::viewer {
namespace {

using Ranges = std::vector<std::pair<std::uint32_t, std::uint32_t>>;

TEST(SurfaceExchange, MergeRangesJoinsOverlapsAndKeepsOrder) {
  Ranges into{{0, 4}, {10, 12}};
  merge_ranges(into, {{3, 6}, {12, 14}, {20, 21}, {30, 30}});
  EXPECT_EQ(into, (Ranges{{0, 6}, {10, 14}, {20, 21}}));
  merge_ranges(into, {});
  EXPECT_EQ(into, (Ranges{{0, 6}, {10, 14}, {20, 21}}));
}

/// Every point, normal, colour and cell of `a` equals `b`'s.
void expect_same_poly_data(vtkPolyData* a, vtkPolyData* b) {
  ASSERT_EQ(a->GetNumberOfPoints(), b->GetNumberOfPoints());
  vtkDataArray* pa = a->GetPoints()->GetData();
  vtkDataArray* pb = b->GetPoints()->GetData();
  vtkDataArray* na = a->GetPointData()->GetNormals();
  vtkDataArray* nb = b->GetPointData()->GetNormals();
  std::size_t differing = 0;
  for (vtkIdType i = 0; i < a->GetNumberOfPoints(); ++i)
    for (int k = 0; k < 3; ++k) {
      differing += pa->GetComponent(i, k) != pb->GetComponent(i, k) ? 1 : 0;
      differing += na->GetComponent(i, k) != nb->GetComponent(i, k) ? 1 : 0;
    }
  EXPECT_EQ(differing, 0u);
  ASSERT_EQ(a->GetPolys()->GetNumberOfCells(), b->GetPolys()->GetNumberOfCells());
  vtkDataArray* ca = a->GetPolys()->GetConnectivityArray();
  vtkDataArray* cb = b->GetPolys()->GetConnectivityArray();
  std::size_t cells_differing = 0;
  for (vtkIdType i = 0; i < ca->GetNumberOfTuples(); ++i)
    cells_differing += ca->GetComponent(i, 0) != cb->GetComponent(i, 0) ? 1 : 0;
  EXPECT_EQ(cells_differing, 0u);
}

TEST(SurfaceExchange, RangeUpdatesEqualAFullUploadThroughPressAndAblation) {
  auto session = test::make_block_session();
  session->publish_initial();
  SurfaceUploader ranged, full;
  std::size_t partial_frames = 0, frames = 0;
  std::size_t slots = 0;
  auto consume = [&] {
    session->exchange().consume([&](const SurfaceBuffers& b, const SurfaceDelta& d) {
      const std::size_t copied = ranged.apply(b, d);
      slots = b.positions.size();
      if (!d.topology && !d.ranges.empty() && copied < slots) ++partial_frames;
      ++frames;
      full.apply_full(b);
    });
  };
  consume();
  // Press the free end down with the ball, then ablate along the top with the wand.
  ToolCommand ball;
  ball.tool = 0;
  ball.mode = interaction::ToolMode::kPress;
  for (int i = 0; i < 10; ++i) {
    ball.pose.position = {36, 8, 12 + 3 - 0.2 * i};
    session->step(1e-3, ball);
    consume();
  }
  ToolCommand wand;
  wand.tool = 1;
  wand.mode = interaction::ToolMode::kAblate;
  for (int i = 0; i < 6; ++i) {
    wand.pose.position = {10.0 + i, 8, 11.5};
    session->step(1e-3, wand);
    consume();
  }
  for (int i = 0; i < 5; ++i) {
    session->step(1e-3, {});
    consume();
  }
  EXPECT_TRUE(session->stats().error.empty()) << session->stats().error;
  EXPECT_GT(session->stats().removed_mm3, 1.0);
  EXPECT_GT(partial_frames, 0u) << "some frames should copy only part of the " << slots
                                << " vertex slots";
  expect_same_poly_data(ranged.poly_data(), full.poly_data());
  EXPECT_EQ(ranged.live_triangles(), full.live_triangles());
}

TEST(SurfaceExchange, ARestingTissueCopiesNothing) {
  auto session = test::make_block_session();
  session->publish_initial();
  SurfaceUploader up;
  session->exchange().consume(
      [&](const SurfaceBuffers& b, const SurfaceDelta&) { up.apply_full(b); });
  // No gravity, no tool: after the first frames nothing moves, so nothing is copied.
  for (int i = 0; i < 3; ++i) session->step(1e-3, {});
  session->exchange().consume([](const SurfaceBuffers&, const SurfaceDelta&) {});
  std::size_t copied = 0;
  for (int i = 0; i < 3; ++i) {
    session->step(1e-3, {});
    session->exchange().consume(
        [&](const SurfaceBuffers& b, const SurfaceDelta& d) { copied += up.apply(b, d); });
  }
  EXPECT_EQ(copied, 0u);
}

}  // namespace
}  // namespace tsf::viewer

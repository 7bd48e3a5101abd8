// Offscreen frames of a tissue block (needs an X server: $DISPLAY or Xvfb, see viewer_fixture.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/viewer/viewer.h"
#include "viewer_fixture.h"

namespace tsf::viewer {
namespace {

/// Pixels that show tissue: the soft-tissue colour is warm (red well above blue); the background
/// gradient is cool grey-blue.
double tissue_coverage(const Frame& f) {
  std::size_t n = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const auto c = f.at(x, y);
      if (c[0] > c[2] + 30) ++n;
    }
  return static_cast<double>(n) / (static_cast<double>(f.width) * f.height);
}

bool differs(const Frame& a, const Frame& b, int x, int y) {
  const auto p = a.at(x, y), q = b.at(x, y);
  int d = 0;
  for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(int(p[k]) - int(q[k])));
  return d > 24;
}

TEST(ViewerRender, TissueFillsTheFrame) {
  TSF_X_DISPLAY_OR_SKIP();
  auto session = test::make_block_session();
  Viewer viewer(*session, nullptr, test::bare_offscreen_options());
  viewer.step_and_render({});
  const Frame f = viewer.capture();
  ASSERT_EQ(f.width, 480);
  ASSERT_EQ(f.height, 320);
  const double coverage = tissue_coverage(f);
  // The block framed by the default camera covers a good part of the frame, not all of it.
  EXPECT_GT(coverage, 0.15) << "tissue pixels: " << coverage;
  EXPECT_LT(coverage, 0.95) << "tissue pixels: " << coverage;
  // Its centre projects inside the frame and shows tissue there.
  const auto c = viewer.world_to_pixel({20, 8, 12});
  ASSERT_GT(c[0], 0);
  ASSERT_LT(c[0], f.width);
  const auto px = f.at(static_cast<int>(c[0]), static_cast<int>(c[1]) - 3);
  EXPECT_GT(px[0], px[2] + 30);
}

TEST(ViewerRender, TheDefaultCameraFacesThePatientAndTheCubeNamesTheSides) {
  TSF_X_DISPLAY_OR_SKIP();
  // The block (40 × 16 × 24 mm from the origin) seen from the front, no azimuth or elevation: the
  // patient's left (+x in LPS) is on the image's right when the face is toward −y (LPS), and on
  // its left when the same CT's face is toward +y (a volume stored the other way round).
  auto session = test::make_block_session();
  auto right_of = [&](const Vec3d& anterior) {
    ViewOptions o = test::bare_offscreen_options();
    o.camera.azimuth_deg = 0;
    o.camera.elevation_deg = 0;
    o.patient.known = true;
    o.patient.left_right_known = true;
    o.patient.anterior = anterior;
    o.patient.left = {1, 0, 0};
    o.patient.superior = {0, 0, 1};
    Viewer viewer(*session, nullptr, o);
    viewer.render({});
    const double left_px = viewer.world_to_pixel({40, 8, 12})[0];
    const double right_px = viewer.world_to_pixel({0, 8, 12})[0];
    // Above: +z is up on the image either way.
    EXPECT_GT(viewer.world_to_pixel({20, 8, 24})[1], viewer.world_to_pixel({20, 8, 0})[1]);
    return std::make_pair(left_px > right_px, viewer.capture());
  };
  const auto [lps_left_on_right, lps_frame] = right_of({0, -1, 0});
  const auto [flipped_left_on_right, flipped_frame] = right_of({0, 1, 0});
  EXPECT_TRUE(lps_left_on_right) << "facing the patient, their left is on the viewer's right";
  EXPECT_FALSE(flipped_left_on_right);
  // The orientation cube sits in the top-right corner: coloured faces, not the cool background.
  std::size_t coloured = 0;
  for (int y = 0; y < lps_frame.height / 5; ++y)
    for (int x = lps_frame.width * 9 / 10; x < lps_frame.width; ++x) {
      const auto c = lps_frame.at(x, lps_frame.height - 1 - y);
      coloured += (c[1] > c[2] + 40 || c[0] > c[2] + 40);
    }
  EXPECT_GT(coloured, 50u) << "no orientation cube in the corner";
  // Without a patient frame (a box) there is no cube.
  ViewOptions bare = test::bare_offscreen_options();
  Viewer plain(*session, nullptr, bare);
  plain.render({});
  const Frame f = plain.capture();
  std::size_t plain_coloured = 0;
  for (int y = 0; y < f.height / 5; ++y)
    for (int x = f.width * 9 / 10; x < f.width; ++x) {
      const auto c = f.at(x, f.height - 1 - y);
      plain_coloured += (c[1] > c[2] + 40 || c[0] > c[2] + 40);
    }
  EXPECT_EQ(plain_coloured, 0u);
}

TEST(ViewerRender, SlicePlanesAndOverlaysRender) {
  TSF_X_DISPLAY_OR_SKIP();
  auto session = test::make_block_session();
  ViewOptions o = test::bare_offscreen_options();
  o.slices.show = true;
  o.show_hud = true;
  o.show_plot = true;
  Viewer with(*session, nullptr, o);
  with.step_and_render({});
  const Frame a = with.capture();
  Viewer without(*session, nullptr, test::bare_offscreen_options());
  without.render({});
  const Frame b = without.capture();
  std::size_t changed = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) changed += differs(a, b, x, y) ? 1 : 0;
  EXPECT_GT(changed, static_cast<std::size_t>(a.width * a.height / 20))
      << "slices, HUD and plot should change many pixels";
}

TEST(ViewerRender, AblationChangesTheFrameOnlyNearTheTool) {
  TSF_X_DISPLAY_OR_SKIP();
  auto session = test::make_block_session();
  Viewer viewer(*session, nullptr, test::bare_offscreen_options());
  ToolCommand idle;
  for (int i = 0; i < 3; ++i) viewer.step_and_render(idle);
  const Frame before = viewer.capture();
  // The wand (tool 1) standing upright ablates the top from x = 16 to 24 mm at y = 8 mm.
  ToolCommand wand;
  wand.tool = 1;
  wand.mode = interaction::ToolMode::kAblate;
  const double y = 8, z = 11.5;
  for (int i = 0; i <= 8; ++i) {
    wand.pose.position = {16.0 + i, y, z};
    viewer.step_and_render(wand);
  }
  ToolCommand lift = wand;
  lift.mode = interaction::ToolMode::kIdle;
  for (int i = 0; i < 3; ++i) viewer.step_and_render(lift);
  EXPECT_GT(session->stats().removed_mm3, 5.0) << "the wand removed tissue";
  const Frame after = viewer.capture();

  // The ablated region: the wand's path ± its reach (radius 1.5 + half length 2 mm), projected.
  double lo[2] = {1e9, 1e9}, hi[2] = {-1e9, -1e9};
  for (double x : {16.0 - 4, 24.0 + 4})
    for (double yy : {y - 4, y + 4})
      for (double zz : {z - 4, z + 4}) {
        const auto p = viewer.world_to_pixel({x, yy, zz});
        lo[0] = std::min(lo[0], p[0]), lo[1] = std::min(lo[1], p[1]);
        hi[0] = std::max(hi[0], p[0]), hi[1] = std::max(hi[1], p[1]);
      }
  const int margin = 6;  // pixels: shading of the rim next to the crater
  std::size_t inside = 0, outside = 0, inside_total = 0;
  for (int py = 0; py < after.height; ++py)
    for (int px = 0; px < after.width; ++px) {
      const bool near = px >= lo[0] - margin && px <= hi[0] + margin && py >= lo[1] - margin &&
                        py <= hi[1] + margin;
      const bool d = differs(before, after, px, py);
      if (near) {
        ++inside_total;
        inside += d ? 1 : 0;
      } else {
        outside += d ? 1 : 0;
      }
    }
  ASSERT_GT(inside_total, 0u);
  EXPECT_GT(static_cast<double>(inside) / static_cast<double>(inside_total), 0.03)
      << inside << " of " << inside_total << " pixels near the wand's path changed";
  EXPECT_LT(outside, static_cast<std::size_t>(after.width * after.height / 500))
      << outside << " pixels changed far from the wand's path";
}

TEST(ViewerRender, WritesPngAtomically) {
  TSF_X_DISPLAY_OR_SKIP();
  auto session = test::make_block_session();
  Viewer viewer(*session, nullptr, test::bare_offscreen_options());
  viewer.step_and_render({});
  const auto dir = test::scratch_dir("viewer-png");
  viewer.write_png(dir / "frame.png");
  EXPECT_TRUE(std::filesystem::exists(dir / "frame.png"));
  EXPECT_GT(std::filesystem::file_size(dir / "frame.png"), 1000u);
  EXPECT_FALSE(std::filesystem::exists(dir / "frame.png.part"));
  EXPECT_THROW(viewer.write_png(dir / "no-such-folder" / "frame.png"), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "no-such-folder"));
}

/// Opens a real window with the simulation thread, lets it close itself after 10 frames, checks
/// the thread stopped (the session steps again on this thread), and exits 0 only then.
[[noreturn]] void open_window_then_exit() {
  auto session = test::make_block_session();
  ViewOptions o = test::bare_offscreen_options();
  o.offscreen = false;
  o.show_hud = true;
  o.show_plot = true;
  o.close_after_frames = 10;
  int frames = 0;
  {
    Viewer viewer(*session, nullptr, o);
    frames = viewer.run_window();
  }
  const std::uint64_t simulated = session->stats().frames;
  session->step(1e-3, {});
  const bool ok = frames == 10 && simulated > 0 && session->stats().frames == simulated + 1 &&
                  session->stats().error.empty();
  std::fprintf(stderr, "frames %d, simulated %llu: %s\n", frames,
               static_cast<unsigned long long>(simulated),
               ok ? "window closed cleanly" : "window did not close cleanly");
  std::exit(ok ? 0 : 1);
}

TEST(ViewerWindow, OpensAndClosesCleanly) {
  TSF_X_DISPLAY_OR_SKIP();
  // In a fresh process, as `tsf view` runs: Mesa's GLX keeps per-connection state that the
  // offscreen windows of the other tests leave behind in this one.
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(open_window_then_exit(), ::testing::ExitedWithCode(0), "window closed cleanly");
}

TEST(ViewerWindow, NoDisplayIsAClearErrorNotAnAbort) {
  const char* old = std::getenv("DISPLAY");
  const std::string saved = old ? old : "";
  setenv("DISPLAY", ":7919", 1);  // nothing listens there
  const DisplayStatus s = x_display_status();
  EXPECT_FALSE(s.available);
  EXPECT_NE(s.reason.find(":7919"), std::string::npos) << s.reason;
  auto session = test::make_block_session();
  EXPECT_THROW(Viewer(*session, nullptr, test::bare_offscreen_options()), Error);
  if (old)
    setenv("DISPLAY", saved.c_str(), 1);
  else
    unsetenv("DISPLAY");
}

}  // namespace
}  // namespace tsf::viewer

// View scripts: strict YAML (errors name the key path), the hand's pose and mode per frame.
#include <gtest/gtest.h>

#include <fstream>

#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/viewer/view_script.h"

namespace tsf::viewer {
namespace {

std::vector<NamedTool> tools() {
  std::vector<NamedTool> t(2);
  t[0].name = "ball";
  t[0].tool.shape = collision::ToolShape::kSphere;
  t[1].name = "scalpel";
  t[1].tool.shape = collision::ToolShape::kBlade;
  return t;
}

std::filesystem::path write(const std::string& name, const std::string& text) {
  const auto p = test::scratch_dir("view-script") / name;
  std::ofstream(p) << text;
  return p;
}

std::string error_of(const std::string& text) {
  try {
    read_view_script(write("bad.yaml", text), tools(), {});
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ViewScript, ReadsOptionsAndInterpolatesTheHand) {
  const auto p = write("ok.yaml",
                       "frame_time: 0.002\nwidth: 640\ncamera: {azimuth: 10, zoom: 2}\n"
                       "slices: {labels: false, position: [1, 2, 3]}\nhud: false\n"
                       "keyframes:\n"
                       "  - {frame: 2, tool: ball, position: [0, 0, 10], mode: press}\n"
                       "  - {frame: 6, tool: ball, position: [4, 0, 10], mode: idle}\n"
                       "  - {frame: 8, tool: scalpel, position: [0, 0, 0], mode: cut}\n");
  const ViewScript s = read_view_script(p, tools(), {});
  EXPECT_DOUBLE_EQ(s.options.frame_s, 0.002);
  EXPECT_EQ(s.options.width, 640);
  EXPECT_DOUBLE_EQ(s.options.camera.zoom, 2.0);
  EXPECT_FALSE(s.options.slices.labels);
  EXPECT_FALSE(s.options.show_hud);
  EXPECT_FALSE(s.holds_tool_at(1));
  EXPECT_EQ(s.command_at(1).mode, interaction::ToolMode::kIdle);
  const ToolCommand c = s.command_at(4);
  EXPECT_EQ(c.tool, 0);
  EXPECT_EQ(c.mode, interaction::ToolMode::kPress);
  EXPECT_NEAR(c.pose.position.x, 2.0, 1e-12);
  // Frames 6..7 hold the ball idle where it was; the scalpel takes over at 8.
  EXPECT_EQ(s.command_at(7).tool, 0);
  EXPECT_EQ(s.command_at(7).mode, interaction::ToolMode::kIdle);
  EXPECT_NEAR(s.command_at(7).pose.position.x, 4.0, 1e-12);
  EXPECT_EQ(s.command_at(9).tool, 1);
  EXPECT_EQ(s.command_at(9).mode, interaction::ToolMode::kCut);
}

TEST(ViewScript, HandsMoveTheirOwnToolsAtOnce) {
  const auto p = write("hands.yaml",
                       "keyframes:\n"
                       "  - {frame: 2, tool: ball, position: [0, 0, 10], mode: press}\n"
                       "  - {frame: 1, hand: 1, tool: scalpel, position: [5, 0, 0], mode: cut}\n"
                       "  - {frame: 6, tool: ball, position: [4, 0, 10], mode: idle}\n"
                       "  - {frame: 9, hand: 1, tool: scalpel, position: [5, 8, 0], mode: cut}\n");
  const ViewScript s = read_view_script(p, tools(), {});
  ASSERT_EQ(s.hands.size(), 2u);
  EXPECT_DOUBLE_EQ(s.last_keyframe(), 9.0);
  const std::vector<ToolCommand> at1 = s.commands_at(1);
  ASSERT_EQ(at1.size(), 2u);
  EXPECT_EQ(at1[0].tool, -1) << "hand 0 is empty before its first keyframe";
  EXPECT_EQ(at1[1].tool, 1);
  const std::vector<ToolCommand> at4 = s.commands_at(4);
  EXPECT_EQ(at4[0].tool, 0);
  EXPECT_EQ(at4[0].mode, interaction::ToolMode::kPress);
  EXPECT_EQ(at4[1].tool, 1);
  EXPECT_EQ(at4[1].mode, interaction::ToolMode::kCut);
  EXPECT_NEAR(at4[1].pose.position.y, 3.0, 1e-12) << "each hand interpolates its own keyframes";
  EXPECT_NE(error_of("keyframes:\n  - {frame: 0, hand: 9, tool: ball, position: [0, 0, 0]}\n")
                .find("keyframes[0].hand: expected a number in [0, 7]"),
            std::string::npos);
}

TEST(ViewScript, ErrorsNameTheFileAndKeyPath) {
  EXPECT_NE(error_of("camera: {zoomm: 2}\n").find("camera.zoomm: unknown key"), std::string::npos);
  EXPECT_NE(error_of("camera: {zoom: -1}\n").find("camera.zoom: expected a number in (0"),
            std::string::npos);
  EXPECT_NE(error_of("keyframes:\n  - {frame: 0, tool: knife, position: [0, 0, 0]}\n")
                .find("keyframes[0].tool: no tool named 'knife'"),
            std::string::npos);
  EXPECT_NE(error_of("keyframes:\n  - {frame: 0, tool: ball, position: [0, 0, 0], mode: cut}\n")
                .find("keyframes[0].mode: tool 'ball' (sphere) cannot cut"),
            std::string::npos);
  EXPECT_NE(error_of("keyframes:\n  - {frame: 3, tool: ball, position: [0, 0, 0]}\n"
                     "  - {frame: 3, tool: ball, position: [0, 0, 0]}\n")
                .find("keyframes[1].frame: frames must increase"),
            std::string::npos);
  EXPECT_NE(
      error_of("slices: {position: [1, 2]}\n").find("slices.position: expected a list of three"),
      std::string::npos);
  EXPECT_NE(error_of("hud: maybe\n").find("hud: expected true or false"), std::string::npos);
  EXPECT_NE(error_of("width: [1\n").find("not valid YAML"), std::string::npos);
  EXPECT_THROW(read_view_script("/nonexistent/view.yaml", tools(), {}), Error);
}

}  // namespace
}  // namespace tsf::viewer

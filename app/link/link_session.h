// A live link between a running tissue and OpenIGTLink peers (docs/live.md): the scene's tools
// follow TRANSFORM messages (device name ↔ tool name), the deformed, cut surface goes out as
// POLYDATA at the display rate, and each driven tool's force goes back as SENSOR. One session for
// every command that runs a live tissue (`tsf link`; `tsf view` with --igtl-port).
//
// Frames: a TRANSFORM (tool → wire frame; with --igtl-registration, tracker → wire frame after
// that matrix) becomes a tool pose in patient LPS, then in the tissue space of the instance it
// acts on (VolumeGeometry: p = origin + Dᵀ·(p_lps − origin), rotation Dᵀ·R; when D mirrors, the
// tool's own z is mirrored too, which every tool shape is symmetric under). Surfaces and forces
// go the other way.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "link/igtl_codec.h"
#include "link/link_server.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/interaction/tool.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::link {

/// The command-line options of a live link (the same names on every command that has one).
struct LinkOptions {
  int port = -1;  ///< --igtl-port; −1: do not listen
  std::string bind = "127.0.0.1";
  std::vector<std::string> connect;  ///< --igtl-connect HOST:PORT
  std::vector<std::string> tools;    ///< --igtl-tool TOOL[=DEVICE][:MODE]
  std::string frame = "ras";
  double rate_hz = 30.0;     ///< POLYDATA per second at most
  std::string registration;  ///< --igtl-registration FILE
  std::string name;          ///< --igtl-name: the POLYDATA device name (default: the scene's)

  bool enabled() const { return port >= 0 || !connect.empty(); }
};

/// Adds --igtl-port, --igtl-bind, --igtl-frame, --igtl-rate and --igtl-name to `sub`, and with
/// `tools` --igtl-connect, --igtl-tool and --igtl-registration (TRANSFORMs drive the scene's
/// tools). `default_port`: what --igtl-port is when not given (−1: the link is off unless asked).
void add_link_options(CLI::App& sub, LinkOptions& options, int default_port, bool tools);

/// Which scene tool follows which TRANSFORM device, in which mode.
struct ToolBinding {
  std::string tool;
  std::string device;
  interaction::ToolMode mode = interaction::ToolMode::kPress;
};

/// "TOOL[=DEVICE][:MODE]" (DEVICE defaults to TOOL, MODE to press); throws tsf::Error naming
/// --igtl-tool and what is wrong.
ToolBinding parse_tool_binding(const std::string& text);

/// A 4×4 matrix from a text file: 16 numbers (or 12: the last row 0 0 0 1 is implied), row by
/// row, rigid (an orthonormal rotation and a translation, mm). Throws tsf::Error naming the file.
Matrix4 read_registration(const std::string& file);

/// The rotation part of a pose matrix as a unit quaternion; empty when it is not a rotation
/// (determinant ≤ 0.5 or columns far from orthonormal).
std::optional<Rotation> rotation_of(const Matrix4& m);

/// A pose in patient LPS → the tissue space of `frame`, and a tissue-space direction → LPS.
ToolPose patient_pose_to_tissue(const ToolPose& lps, const VolumeGeometry& frame);

/// A received TRANSFORM (the wire frame; first mapped by `registration`, tracker → wire, when
/// given) as a pose in patient LPS; empty when its 3×3 part is not a rotation.
std::optional<ToolPose> wire_matrix_to_patient_pose(const Matrix4& wire, WireFrame frame,
                                                    const std::optional<Matrix4>& registration);

class LinkSession {
 public:
  struct NamedTool {
    std::string name;
    interaction::Tool tool;
  };
  /// Binds the tools (every tool to the device of its own name when options.tools is empty),
  /// reads the registration and starts the server. Throws tsf::Error naming the option.
  LinkSession(const LinkOptions& options, std::vector<NamedTool> tools,
              const std::string& surface_name);

  /// What a bound tool does this frame.
  struct Drive {
    std::size_t binding = 0;  ///< into bindings()
    std::size_t tool = 0;     ///< into the tools given
    ToolPose pose;            ///< tissue space of the frame asked for
    interaction::ToolMode mode = interaction::ToolMode::kPress;
    bool held = false;   ///< false: no pose (none yet, or its peer left): lift the tool
    bool fresh = false;  ///< a TRANSFORM arrived since the previous frame
  };
  /// Every binding's state now, the poses in the tissue space of `frame`. Call once per frame
  /// (the simulation thread); `time_s` is the session's time for the trace.
  std::vector<Drive> drives(const VolumeGeometry& frame, double time_s);
  /// After the frame's advance: sends binding `b`'s force (on the tool, tissue space, µN) to the
  /// peer that drives it, stamped with the pose it answers.
  void send_force(std::size_t b, const Vec3d& force_tissue_un, const VolumeGeometry& frame);

  /// Whether a surface is due (the rate); the caller then publishes one.
  bool surface_due() const;
  /// Serves `mesh` (patient LPS) as POLYDATA `name` (the surface name, or name-suffix).
  void publish_surface(const imt::SurfaceMesh& mesh_lps, const std::string& suffix = "");

  const std::vector<ToolBinding>& bindings() const { return bindings_; }
  WireFrame frame() const { return frame_; }
  LinkServer& server() { return *server_; }
  /// "listening on 127.0.0.1:18944 (RAS), tools: ball ← Tracker (press)".
  std::string describe() const;
  /// The `link` section of a report: endpoints, frame, bindings with their counts and the trace
  /// of applied poses (patient LPS), the server's statistics, the surface rate achieved.
  nlohmann::json report_json(double session_s) const;

 private:
  struct BindingState {
    std::uint64_t seen = 0;  ///< TRANSFORM count last applied
    std::uint64_t stamp = 0;
    std::uint64_t applied = 0;
    std::uint64_t rejected = 0;  ///< poses that were not rotations
    std::uint64_t mode_seen = 0;
    std::optional<interaction::ToolMode> mode_override;  ///< from a STRING
    bool held = false;
    std::deque<std::array<double, 5>> trace;  ///< time, x, y, z (LPS), TRANSFORM count
  };
  LinkOptions options_;
  WireFrame frame_ = WireFrame::kRas;
  std::optional<Matrix4> registration_;
  std::vector<NamedTool> tools_;
  std::vector<ToolBinding> bindings_;
  std::vector<std::size_t> binding_tool_;
  std::vector<BindingState> state_;
  std::string surface_name_;
  std::unique_ptr<LinkServer> server_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point last_surface_{};
  std::int64_t surfaces_published_ = 0;
  std::size_t last_vertices_ = 0, last_triangles_ = 0;
};

}  // namespace tsf::link

#include "tsf/viewer/live_haptics.h"

#include "tsf/common/error.h"

namespace tsf::viewer {

LiveHaptics::LiveHaptics(std::unique_ptr<haptics::HapticDevice> device,
                         const LiveHapticsOptions& options)
    : options_(options),
      device_(std::move(device)),
      capture_({options.force.stylus_radius_mm, options.capture_margin_mm}) {
  require(device_ != nullptr, "live haptics: no device");
  options_.force.validate();
  options_.loop.validate();
  model_ = haptics::make_force_model(options_.model, options_.force);
  // The simulation thread captures only what the model reads: every part is a pass over the
  // tissue near the stylus (or, for the triangles, over the whole surface) each frame.
  capture_.set_parts(model_->reads());
  loop_ = std::make_unique<haptics::HapticLoop>(*device_, *model_, frames_, options_.loop);
}

LiveHaptics::~LiveHaptics() {
  stop();
}

void LiveHaptics::start() {
  if (!loop_->running()) loop_->start();
}

void LiveHaptics::stop() {
  loop_->stop();
}

void LiveHaptics::publish(interaction::TissueModel& model, const ToolPose& pose, int slot) {
  const collision::ToolReaction r = model.tool_contact(slot);
  time_s_ = model.totals().simulated_s;
  haptics::HapticFrame& frame = frames_.back();
  capture_.capture(model, pose, r.force_un, static_cast<std::int64_t>(r.nodes_held), time_s_,
                   frame);
  frame.stamp_now();
  frames_.publish();
}

double LiveHaptics::recent_rate_hz() {
  const auto now = std::chrono::steady_clock::now();
  recent_.emplace_back(now, loop_->ticks());
  while (recent_.size() > 2 && now - recent_.front().first > std::chrono::seconds(1))
    recent_.pop_front();
  const double span = std::chrono::duration<double>(now - recent_.front().first).count();
  return span > 0 ? static_cast<double>(recent_.back().second - recent_.front().second) / span
                  : 0.0;
}

}  // namespace tsf::viewer

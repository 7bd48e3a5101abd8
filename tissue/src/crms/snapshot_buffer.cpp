#include "tsf/crms/snapshot_buffer.h"

#include "tsf/common/error.h"

namespace tsf::crms {

SnapshotBuffer::SnapshotBuffer(float* buffer_a, float* buffer_b, std::int64_t node_count)
    : buffers_{buffer_a, buffer_b}, node_count_(node_count) {}

void SnapshotBuffer::attach(float* buffer_a, float* buffer_b) {
  std::lock_guard<std::mutex> lock(mutex_);
  require(version_ == 0, "snapshot buffers can only be attached before the first publish");
  buffers_[0] = buffer_a;
  buffers_[1] = buffer_b;
}

void SnapshotBuffer::publish(std::int64_t step) {
  std::lock_guard<std::mutex> lock(mutex_);
  front_ = 1 - front_;
  step_ = step;
  ++version_;
}

std::uint64_t SnapshotBuffer::version() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return version_;
}

std::uint64_t SnapshotBuffer::copy_latest(std::vector<float>& positions, std::int64_t* step) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (version_ == 0) return 0;
  const float* src = buffers_[front_];
  positions.assign(src, src + node_count_ * 3);
  if (step) *step = step_;
  return version_;
}

void SnapshotBuffer::visit_latest(
    const std::function<void(const float*, std::int64_t, std::uint64_t, std::int64_t)>& visit)
    const {
  std::lock_guard<std::mutex> lock(mutex_);
  visit(version_ ? buffers_[front_] : nullptr, version_ ? node_count_ : 0, version_, step_);
}

}  // namespace tsf::crms

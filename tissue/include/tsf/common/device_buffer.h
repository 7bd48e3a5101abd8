// The one owner of GPU memory: RAII device arrays, pinned host arrays and CUDA handles.
//
// Every allocation goes through TSF_CUDA_CHECK (cuda_check.h) and is released by a destructor, so
// an object whose constructor throws halfway frees what it already holds. Members are destroyed in
// reverse order of declaration: declare a UniqueStream after the buffers its work uses (it waits
// for that work when destroyed), or wait on the stream in the owner's destructor. The types are
// move-only; destructors never throw (errors while freeing are ignored: there is no one to report
// them to). See docs/design.md, "GPU memory".
//
//   DeviceBuffer<float> u(count);                      // cudaMalloc'd, uninitialised
//   u.fill_zero(stream);                                // cudaMemsetAsync
//   u.upload(host.data(), host.size(), stream);         // cudaMemcpyAsync host → device
//   u.download(host.data(), host.size(), stream);       // device → host (wait before reading)
//   u.resize(more);                                     // grows: contents are not kept
//   UniqueStream s = make_stream();                     // cudaStreamNonBlocking
//
// Include only from .cu files (it includes cuda_runtime.h).
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <memory>
#include <type_traits>
#include <utility>

#include "tsf/common/cuda_check.h"

namespace tsf {

namespace detail {
struct DeviceFree {
  void operator()(void* p) const noexcept { cudaFree(p); }
};
struct PinnedFree {
  void operator()(void* p) const noexcept { cudaFreeHost(p); }
};
inline void* device_malloc(std::size_t bytes) {
  void* p = nullptr;
  TSF_CUDA_CHECK(cudaMalloc(&p, bytes));
  return p;
}
inline void* pinned_malloc(std::size_t bytes) {
  void* p = nullptr;
  TSF_CUDA_CHECK(cudaMallocHost(&p, bytes));
  return p;
}

/// An owning array of `T` in the memory `Alloc` hands out (freed by `Free`). `size()` is the
/// element count last asked for; `capacity()` what is allocated (at least one element, so that
/// data() is never null once allocated).
template <typename T, void* (*Alloc)(std::size_t), class Free>
class OwnedArray {
  static_assert(std::is_trivially_copyable_v<T>, "GPU arrays hold trivially copyable types");

 public:
  OwnedArray() = default;
  explicit OwnedArray(std::size_t count) { resize(count); }
  OwnedArray(OwnedArray&& o) noexcept
      : data_(std::move(o.data_)), size_(o.size_), capacity_(o.capacity_) {
    o.size_ = o.capacity_ = 0;
  }
  OwnedArray& operator=(OwnedArray&& o) noexcept {
    data_ = std::move(o.data_);
    size_ = o.size_;
    capacity_ = o.capacity_;
    o.size_ = o.capacity_ = 0;
    return *this;
  }
  OwnedArray(const OwnedArray&) = delete;
  OwnedArray& operator=(const OwnedArray&) = delete;

  /// Makes room for `count` elements. Within the capacity only the size changes (contents are
  /// kept); beyond it the array is reallocated and its contents are NOT kept.
  void resize(std::size_t count) {
    if (data_ && count <= capacity_) {
      size_ = count;
      return;
    }
    release();
    const std::size_t n = count > 0 ? count : 1;
    data_.reset(static_cast<T*>(Alloc(n * sizeof(T))));
    capacity_ = n;
    size_ = count;
  }
  /// resize(), but growing past the capacity at least doubles it, so that a run of growing
  /// requests (edit staging, say) allocates O(log n) times rather than on every call. Contents
  /// are NOT kept when it reallocates.
  void grow_to(std::size_t count) {
    if (data_ && count <= capacity_) {
      size_ = count;
      return;
    }
    resize(count > 2 * capacity_ ? count : 2 * capacity_);
    size_ = count;
  }
  /// Frees the memory (the array is empty afterwards).
  void release() noexcept {
    data_.reset();
    size_ = capacity_ = 0;
  }

  T* data() const { return data_.get(); }
  std::size_t size() const { return size_; }
  std::size_t capacity() const { return capacity_; }
  std::size_t bytes() const { return size_ * sizeof(T); }
  bool empty() const { return data_ == nullptr; }
  explicit operator bool() const { return data_ != nullptr; }

 private:
  std::unique_ptr<T, Free> data_;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
};
}  // namespace detail

/// Page-locked host memory (cudaMallocHost): the target of asynchronous device → host copies.
template <typename T>
using PinnedBuffer = detail::OwnedArray<T, detail::pinned_malloc, detail::PinnedFree>;

/// Device memory (cudaMalloc) with stream-ordered copy helpers. Copies are asynchronous on
/// `stream`: the host side must stay alive (and, for downloads, unread) until the stream is
/// synchronised.
template <typename T>
class DeviceBuffer : public detail::OwnedArray<T, detail::device_malloc, detail::DeviceFree> {
  using Base = detail::OwnedArray<T, detail::device_malloc, detail::DeviceFree>;

 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(std::size_t count) : Base(count) {}

  /// All bytes of the first size() elements set to `byte`.
  void fill_bytes(int byte, cudaStream_t stream) {
    if (this->size() > 0)
      TSF_CUDA_CHECK(cudaMemsetAsync(this->data(), byte, this->bytes(), stream));
  }
  void fill_zero(cudaStream_t stream) { fill_bytes(0, stream); }

  /// `count` elements from the host into elements [offset, offset + count).
  void upload(const T* host, std::size_t count, cudaStream_t stream, std::size_t offset = 0) {
    if (count == 0) return;
    require(offset + count <= this->size(), "DeviceBuffer::upload beyond the buffer's size");
    TSF_CUDA_CHECK(cudaMemcpyAsync(this->data() + offset, host, count * sizeof(T),
                                   cudaMemcpyHostToDevice, stream));
  }
  /// Elements [offset, offset + count) to the host.
  void download(T* host, std::size_t count, cudaStream_t stream, std::size_t offset = 0) const {
    if (count == 0) return;
    require(offset + count <= this->size(), "DeviceBuffer::download beyond the buffer's size");
    TSF_CUDA_CHECK(cudaMemcpyAsync(host, this->data() + offset, count * sizeof(T),
                                   cudaMemcpyDeviceToHost, stream));
  }
};

// ---- CUDA handles ----
namespace detail {
struct StreamDestroy {
  void operator()(cudaStream_t s) const noexcept {
    cudaStreamSynchronize(s);  // work still queued may touch buffers freed next
    cudaStreamDestroy(s);
  }
};
struct EventDestroy {
  void operator()(cudaEvent_t e) const noexcept { cudaEventDestroy(e); }
};
struct GraphExecDestroy {
  void operator()(cudaGraphExec_t g) const noexcept { cudaGraphExecDestroy(g); }
};
struct GraphDestroy {
  void operator()(cudaGraph_t g) const noexcept { cudaGraphDestroy(g); }
};
}  // namespace detail

/// A stream, synchronised and destroyed on destruction.
using UniqueStream = std::unique_ptr<std::remove_pointer_t<cudaStream_t>, detail::StreamDestroy>;
using UniqueEvent = std::unique_ptr<std::remove_pointer_t<cudaEvent_t>, detail::EventDestroy>;
using UniqueGraphExec =
    std::unique_ptr<std::remove_pointer_t<cudaGraphExec_t>, detail::GraphExecDestroy>;
using UniqueGraph = std::unique_ptr<std::remove_pointer_t<cudaGraph_t>, detail::GraphDestroy>;

inline UniqueStream make_stream(unsigned flags = cudaStreamNonBlocking) {
  cudaStream_t s = nullptr;
  TSF_CUDA_CHECK(cudaStreamCreateWithFlags(&s, flags));
  return UniqueStream(s);
}
inline UniqueEvent make_event(unsigned flags = cudaEventDisableTiming) {
  cudaEvent_t e = nullptr;
  TSF_CUDA_CHECK(cudaEventCreateWithFlags(&e, flags));
  return UniqueEvent(e);
}

}  // namespace tsf

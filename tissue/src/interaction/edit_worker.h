// One thread an edit hands a task to while it works on something else (docs/deform-cut.md,
// "The topology beside the re-mesh"): a task at a time, its exception given back by wait().
//
// Private to tissue/src/interaction.
#pragma once

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace tsf::interaction::detail {

class EditWorker {
 public:
  EditWorker();
  ~EditWorker();
  EditWorker(const EditWorker&) = delete;
  EditWorker& operator=(const EditWorker&) = delete;

  /// Runs `task` on the worker's thread. The worker must be idle (wait() returned).
  void start(std::function<void()> task);
  /// Blocks until the task has returned; rethrows what it threw.
  void wait();

 private:
  void loop();

  std::mutex mutex_;
  std::condition_variable cv_;
  std::function<void()> task_;
  bool busy_ = false, stop_ = false;
  std::exception_ptr error_;
  std::thread thread_;
};

/// Waits for a started worker when it leaves scope (an exception on the calling thread must not
/// unwind the state the task is using); wait() waits and rethrows.
class WorkerWait {
 public:
  explicit WorkerWait(EditWorker* w) : w_(w) {}
  ~WorkerWait() {
    if (w_ == nullptr) return;
    try {
      w_->wait();
    } catch (...) {  // the calling thread's own exception is on its way
    }
  }
  WorkerWait(const WorkerWait&) = delete;
  WorkerWait& operator=(const WorkerWait&) = delete;
  void wait() {
    EditWorker* w = w_;
    w_ = nullptr;
    if (w != nullptr) w->wait();
  }

 private:
  EditWorker* w_;
};

}  // namespace tsf::interaction::detail

#include "edit_worker.h"

#include <utility>

#include <omp.h>

#include "tsf/common/error.h"

namespace tsf::interaction::detail {

EditWorker::EditWorker() : thread_([this] { loop(); }) {}

EditWorker::~EditWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void EditWorker::start(std::function<void()> task) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    require(!busy_, "EditWorker::start: the worker is still running a task (internal)");
    task_ = std::move(task);
    error_ = nullptr;
    busy_ = true;
  }
  cv_.notify_all();
}

void EditWorker::wait() {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [this] { return !busy_; });
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void EditWorker::loop() {
  omp_set_num_threads(1);  // a task here is one thread beside the caller's team
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this] { return busy_ || stop_; });
    if (stop_ && !busy_) return;
    std::function<void()> task = std::move(task_);
    lock.unlock();
    std::exception_ptr error;
    try {
      task();
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    error_ = error;
    busy_ = false;
    cv_.notify_all();
  }
}

}  // namespace tsf::interaction::detail

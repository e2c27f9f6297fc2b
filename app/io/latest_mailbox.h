#pragma once
// Hands the newest item of a producer thread to a slower consumer. put() replaces an item that
// was not taken yet, which counts as dropped: at most one item waits, so a live camera that
// delivers faster than the pipeline runs never queues frames without bound, and the frame the
// pipeline gets is always the newest one.
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <utility>

namespace cofusion {

// Thread-safe: one or more producers, one consumer.
template <class T>
class LatestMailbox {
 public:
  // Offers an item; one still waiting is dropped (the newest wins). Ignored after close().
  void put(T item) {
    {
      std::lock_guard lock(mutex_);
      if (closed_) return;
      if (item_) ++dropped_;
      item_ = std::move(item);
    }
    ready_.notify_one();
  }

  // No more items. `error` (may be null) is what ended them: take() throws it once the waiting
  // item, if any, has been taken.
  void close(std::exception_ptr error = nullptr) {
    {
      std::lock_guard lock(mutex_);
      if (closed_) return;
      closed_ = true;
      error_ = std::move(error);
    }
    ready_.notify_all();
  }

  // Waits for an item. std::nullopt when closed without an error and nothing waits.
  std::optional<T> take() {
    std::unique_lock lock(mutex_);
    ready_.wait(lock, [&] { return item_.has_value() || closed_; });
    if (item_) return std::exchange(item_, std::nullopt);
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
    return std::nullopt;
  }

  bool closed() const {
    std::lock_guard lock(mutex_);
    return closed_;
  }
  // Items replaced before they were taken.
  long dropped() const {
    std::lock_guard lock(mutex_);
    return dropped_;
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::optional<T> item_;
  bool closed_ = false;
  std::exception_ptr error_;
  long dropped_ = 0;
};

}  // namespace cofusion

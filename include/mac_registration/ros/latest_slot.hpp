#pragma once

#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <optional>

namespace mac_registration {

// A one-element queue where a new item replaces the waiting one: a worker that falls behind skips to the
// newest input instead of building a backlog, so latency never grows.
template <typename T>
class LatestSlot {
 public:
  // Stores item; returns true if it replaced one nobody had taken (that one is dropped).
  bool put(T item) {
    std::lock_guard<std::mutex> lock(mutex_);
    const bool replaced = item_.has_value();
    if (replaced) ++dropped_;
    item_ = std::move(item);
    ready_.notify_one();
    return replaced;
  }

  // Blocks until an item is there or the slot is closed (then returns nothing).
  std::optional<T> take() {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [this] { return item_.has_value() || closed_; });
    if (closed_) return std::nullopt;
    std::optional<T> item = std::move(item_);
    item_.reset();
    return item;
  }

  void close() {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
    ready_.notify_all();
  }

  std::size_t dropped() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return dropped_;
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::optional<T> item_;
  std::size_t dropped_ = 0;
  bool closed_ = false;
};

}  // namespace mac_registration

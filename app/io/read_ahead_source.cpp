#include "io/read_ahead_source.h"

namespace cofusion {
namespace {
std::unique_ptr<FrameSource> require_source(std::unique_ptr<FrameSource> source) {
  if (!source) throw Error("ReadAheadSource: no source given");
  return source;
}
int require_frames_ahead(int max_frames_ahead) {
  if (max_frames_ahead < 1)
    throw Error("ReadAheadSource: frames read ahead must be 1 or more, got " + std::to_string(max_frames_ahead));
  return max_frames_ahead;
}
}  // namespace

ReadAheadSource::ReadAheadSource(std::unique_ptr<FrameSource> inner, int max_frames_ahead)
    : inner_(require_source(std::move(inner))),
      max_frames_ahead_(require_frames_ahead(max_frames_ahead)),
      intrinsics_(inner_->intrinsics()),
      size_(inner_->size()),
      description_(inner_->describe()),
      reader_([this] { read_loop(); }) {}

ReadAheadSource::~ReadAheadSource() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  room_.notify_all();
  reader_.join();
}

std::string ReadAheadSource::describe() const {
  return description_ + " [read up to " + std::to_string(max_frames_ahead_) + " frames ahead on its own thread]";
}

bool ReadAheadSource::push(Item item) {
  {
    std::unique_lock lock(mutex_);
    room_.wait(lock, [&] { return stop_ || static_cast<int>(queue_.size()) < max_frames_ahead_; });
    if (stop_) return false;
    queue_.push_back(std::move(item));
  }
  ready_.notify_one();
  return true;
}

void ReadAheadSource::read_loop() {
  while (true) {
    Item item;
    try {
      item.frame = inner_->next();
      item.last = !item.frame;
      dropped_frames_ = inner_->dropped_frames();
    } catch (const BadFrame&) {
      item.error = std::current_exception();  // the inner source has passed it and goes on
    } catch (...) {
      item.error = std::current_exception();
      item.last = true;
    }
    const bool last = item.last;
    if (!push(std::move(item)) || last) return;
  }
}

std::optional<Frame> ReadAheadSource::next() {
  if (last_) {
    if (last_->error) std::rethrow_exception(last_->error);
    return std::nullopt;
  }
  Item item;
  {
    std::unique_lock lock(mutex_);
    ready_.wait(lock, [&] { return !queue_.empty(); });
    item = std::move(queue_.front());
    queue_.pop_front();
  }
  room_.notify_one();
  if (item.last) last_ = item;
  if (item.error) std::rethrow_exception(item.error);
  return std::move(item.frame);
}

}  // namespace cofusion

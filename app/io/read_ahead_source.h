#pragma once
// A recorded source read and decoded ahead of its consumer on a thread of its own, so that the
// pipeline does not wait for files: while frame i is processed, frames i+1 .. i+N are read. Every
// frame is handed out, in the source's order (unlike LiveSource, which keeps only the newest), and
// what the inner source throws comes out of next() at the frame where it happened: a BadFrame in
// its place among the frames (the source goes on after it), a fatal error after the frames read
// before it (the source ends with it).
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "io/frame.h"

namespace cofusion {

class ReadAheadSource : public FrameSource {
 public:
  // Starts reading `inner` on a thread, at most `max_frames_ahead` (>= 1) frames, bad frames
  // included, ahead of next(). inner's intrinsics(), size() and describe() are read here, once.
  ReadAheadSource(std::unique_ptr<FrameSource> inner, int max_frames_ahead);
  // Stops the reader, whether it waits for room or not; waits for the read in progress (one frame).
  ~ReadAheadSource() override;
  ReadAheadSource(const ReadAheadSource&) = delete;
  ReadAheadSource& operator=(const ReadAheadSource&) = delete;

  // The inner source's next result, in order: a frame, its BadFrame, its fatal error, or
  // std::nullopt at its end (the last two again on every later call). Waits while the reader is
  // behind. One consumer thread.
  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override { return intrinsics_; }
  std::optional<int> size() const override { return size_; }
  long dropped_frames() const override { return dropped_frames_; }
  std::string describe() const override;

 private:
  // One result of inner->next(): a frame, or the exception it threw; neither = the end.
  struct Item {
    std::optional<Frame> frame;
    std::exception_ptr error;
    bool last = false;  // the end or a fatal error: nothing follows
  };

  void read_loop();
  // Queues `item`, waiting for room; false when the source is being destroyed.
  bool push(Item item);

  std::unique_ptr<FrameSource> inner_;
  const int max_frames_ahead_;
  const Intrinsics intrinsics_;
  const std::optional<int> size_;
  const std::string description_;
  std::atomic<long> dropped_frames_{0};  // inner's count after its latest frame (recordings: 0)

  std::mutex mutex_;
  std::condition_variable room_;   // the queue has room, or stop_
  std::condition_variable ready_;  // the queue has an item
  std::deque<Item> queue_;         // at most max_frames_ahead_ items
  bool stop_ = false;              // the destructor's request
  std::optional<Item> last_;       // consumer side: the end or fatal error once taken
  std::thread reader_;             // last: starts once everything above is constructed
};

}  // namespace cofusion

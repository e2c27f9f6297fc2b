#pragma once
// A live source read on its own thread: the device is drained as fast as it delivers and the
// pipeline gets the newest frame whenever it asks (frames that arrive while it is busy are dropped
// and counted). A fault of the device (unplugged: no frame within the source's timeout) ends the
// source with that error after the frames already delivered.
#include <atomic>
#include <memory>
#include <thread>
#include <variant>

#include "io/frame.h"
#include "io/latest_mailbox.h"

namespace cofusion {

class LiveSource : public FrameSource {
 public:
  // Starts reading `inner` on a thread. inner's intrinsics() and describe() are read here, once.
  explicit LiveSource(std::unique_ptr<FrameSource> inner);
  // Stops the reader; waits for the read in progress (at most the inner source's frame timeout).
  ~LiveSource() override;
  LiveSource(const LiveSource&) = delete;
  LiveSource& operator=(const LiveSource&) = delete;

  // The newest frame not handed out yet (waits for one); BadFrame for a bad newest frame; the
  // inner source's fatal error once its earlier frames are out; std::nullopt when it ended.
  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override { return intrinsics_; }
  long dropped_frames() const override { return mailbox_.dropped(); }
  std::string describe() const override { return description_ + " [newest frame, read on its own thread]"; }

 private:
  void read_loop();

  std::unique_ptr<FrameSource> inner_;
  Intrinsics intrinsics_;
  std::string description_;
  LatestMailbox<std::variant<Frame, BadFrame>> mailbox_;
  std::atomic<bool> stop_{false};
  std::thread reader_;  // last: starts once everything above is constructed
};

}  // namespace cofusion

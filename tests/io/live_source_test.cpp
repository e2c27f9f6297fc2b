// The newest-frame hand-over of live cameras, without a camera: a source that delivers faster than
// its reader takes frames, one that delivers bad frames, one that fails (unplugged).
#include "io/live_source.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "io/latest_mailbox.h"
#include "io/source_adaptors.h"
#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
using ::testing::HasSubstr;
using namespace std::chrono_literals;

TEST(LatestMailbox, NewestWinsAndReplacedItemsAreCounted) {
  LatestMailbox<int> box;
  box.put(1);
  box.put(2);
  box.put(3);
  EXPECT_EQ(box.take(), 3);
  EXPECT_EQ(box.dropped(), 2);
  box.put(4);
  box.close();
  box.put(5);  // after close: ignored
  EXPECT_EQ(box.take(), 4);  // what waited is still handed out
  EXPECT_EQ(box.take(), std::nullopt);
  EXPECT_EQ(box.dropped(), 2);
}

TEST(LatestMailbox, CloseWithAnErrorThrowsItAfterTheWaitingItem) {
  LatestMailbox<int> box;
  box.put(7);
  box.close(std::make_exception_ptr(Error("camera unplugged")));
  EXPECT_EQ(box.take(), 7);
  EXPECT_THAT(test::error_of([&] { box.take(); }), HasSubstr("camera unplugged"));
}

TEST(LatestMailbox, TakeWaitsForAProducerThread) {
  LatestMailbox<int> box;
  std::thread producer([&] {
    std::this_thread::sleep_for(20ms);
    box.put(42);
  });
  EXPECT_EQ(box.take(), 42);
  producer.join();
}

// A camera: `n` frames, one every `period`; then the end, or `error` when set (a disconnect).
class FakeCamera : public FrameSource {
 public:
  FakeCamera(int n, std::chrono::milliseconds period, std::string error = "", int bad_frame = -1)
      : n_(n), period_(period), error_(std::move(error)), bad_frame_(bad_frame) {}
  std::optional<Frame> next() override {
    if (next_ >= n_) {
      if (!error_.empty()) throw Error(error_);
      return std::nullopt;
    }
    std::this_thread::sleep_for(period_);
    const int i = next_++;
    if (i == bad_frame_) throw BadFrame(i, "colour frame is 8x8");
    return test::make_test_frame(4, 3, i, 0.033 * i);
  }
  Intrinsics intrinsics() const override { return test::make_test_frame(4, 3, 0, 0).intrinsics; }
  std::string describe() const override { return "fake camera"; }

 private:
  int n_;
  std::chrono::milliseconds period_;
  std::string error_;
  int bad_frame_;
  int next_ = 0;
};

TEST(LiveSource, BusyReaderGetsTheNewestFrameAndDropsAreCounted) {
  LiveSource live(std::make_unique<FakeCamera>(40, 2ms));
  std::vector<int> seen;
  while (auto frame = live.next()) {
    seen.push_back(frame->index);
    std::this_thread::sleep_for(15ms);  // the pipeline is slower than the camera
  }
  ASSERT_FALSE(seen.empty());
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(seen.back(), 39);  // the last frame is never dropped
  EXPECT_LT(seen.size(), 40u);
  EXPECT_EQ(static_cast<long>(seen.size()) + live.dropped_frames(), 40);
}

TEST(LiveSource, DropCountReachesThroughTheAdaptors) {
  LimitedSource limited(std::make_unique<LiveSource>(std::make_unique<FakeCamera>(20, 1ms)), 100);
  long taken = 0;
  for (; limited.next(); ++taken) std::this_thread::sleep_for(10ms);
  EXPECT_GT(limited.dropped_frames(), 0);
  EXPECT_EQ(taken + limited.dropped_frames(), 20);
}

// --max-frames N covers the source's first N frames, bad ones included.
TEST(LimitedSource, BadFramesCountTowardsTheLimit) {
  LimitedSource limited(std::make_unique<FakeCamera>(10, 0ms, "", 1), 3);
  EXPECT_EQ(limited.next()->index, 0);
  EXPECT_THROW(limited.next(), BadFrame);
  EXPECT_EQ(limited.next()->index, 2);
  EXPECT_FALSE(limited.next());
}

TEST(LiveSource, BadFramesPassThroughAndADisconnectEndsItWithTheError) {
  LiveSource live(std::make_unique<FakeCamera>(3, 5ms, "no depth frame within 5000 ms", 1));
  std::vector<int> frames, bad;
  std::string error;
  try {
    while (true) {
      try {
        auto frame = live.next();
        if (!frame) break;
        frames.push_back(frame->index);
      } catch (const BadFrame& e) {
        bad.push_back(e.frame_index());
      }
    }
  } catch (const Error& e) {
    error = e.what();
  }
  EXPECT_EQ(frames, (std::vector<int>{0, 2}));
  EXPECT_EQ(bad, std::vector<int>{1});
  EXPECT_THAT(error, HasSubstr("no depth frame within"));
  EXPECT_EQ(live.dropped_frames(), 0);
}

TEST(LiveSource, StopsItsReaderWhenDestroyedEarly) {
  const auto start = std::chrono::steady_clock::now();
  {
    LiveSource live(std::make_unique<FakeCamera>(1000, 1ms));
    ASSERT_TRUE(live.next());
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, 500ms);
}

}  // namespace
}  // namespace cofusion

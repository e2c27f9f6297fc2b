// ReadAheadSource: a recording read on a thread of its own hands out exactly what the recording
// does, in its order, with bad frames and a fatal error at the frames where they happened, never
// reads more than its bound ahead, and stops its reader when destroyed at any point.
#include "io/read_ahead_source.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "io/source_adaptors.h"
#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
using ::testing::HasSubstr;
using namespace std::chrono_literals;

// A recording whose frame i is good, bad (BadFrame, the source goes on) or fatal (an Error that
// ends it), by `script`; then the end. Counts its reads (from the reader thread).
class ScriptedSource : public FrameSource {
 public:
  explicit ScriptedSource(std::string script, std::chrono::milliseconds read_time = 0ms)
      : script_(std::move(script)), read_time_(read_time) {}
  std::optional<Frame> next() override {
    if (next_ >= static_cast<int>(script_.size())) return std::nullopt;
    std::this_thread::sleep_for(read_time_);
    const int i = next_++;
    ++reads_;
    if (script_[i] == 'b') throw BadFrame(i, "rgb/" + std::to_string(i) + ".png cannot be decoded");
    if (script_[i] == 'f') throw Error("associations.txt: line " + std::to_string(i) + " unreadable");
    return test::make_test_frame(4, 3, i, 0.033 * i);
  }
  Intrinsics intrinsics() const override { return test::make_test_frame(4, 3, 0, 0).intrinsics; }
  std::optional<int> size() const override { return static_cast<int>(script_.size()); }
  std::string describe() const override { return "scripted recording"; }
  int reads() const { return reads_; }

 private:
  std::string script_;  // g = good, b = bad frame, f = fatal error
  std::chrono::milliseconds read_time_;
  int next_ = 0;
  std::atomic<int> reads_{0};
};

// What next() gave, one entry per call until the end or a fatal error: "3" for frame 3, "bad 3:
// reason" for a BadFrame, "error: what" for another error, "end".
std::vector<std::string> drain(FrameSource& source, std::chrono::milliseconds per_frame = 0ms) {
  std::vector<std::string> out;
  while (true) {
    try {
      auto frame = source.next();
      if (!frame) {
        out.push_back("end");
        return out;
      }
      out.push_back(std::to_string(frame->index));
      std::this_thread::sleep_for(per_frame);  // the pipeline's work on the frame
    } catch (const BadFrame& e) {
      out.push_back("bad " + std::to_string(e.frame_index()) + ": " + e.reason());
    } catch (const Error& e) {
      out.push_back(std::string("error: ") + e.what());
      return out;
    }
  }
}

TEST(ReadAheadSource, SameFramesInTheSameOrderAsTheInnerSource) {
  std::vector<Frame> frames;
  for (int i = 0; i < 12; ++i) frames.push_back(test::make_test_frame(4, 3, i, 0.033 * i));
  MemorySource direct(frames, frames[0].intrinsics, "recording");
  ReadAheadSource ahead(std::make_unique<MemorySource>(frames, frames[0].intrinsics, "recording"), 3);
  EXPECT_EQ(ahead.size(), 12);
  EXPECT_THAT(ahead.describe(), HasSubstr("recording (12 frames in memory)"));
  EXPECT_THAT(ahead.describe(), HasSubstr("read up to 3 frames ahead"));
  for (int i = 0; i < 12; ++i) {
    const auto a = ahead.next(), d = direct.next();
    ASSERT_TRUE(a && d) << i;
    EXPECT_EQ(a->index, d->index);
    EXPECT_EQ(a->timestamp_s, d->timestamp_s);
    EXPECT_EQ(cv::norm(a->rgb, d->rgb, cv::NORM_INF), 0.0) << i;
    EXPECT_EQ(cv::norm(a->depth_m, d->depth_m, cv::NORM_INF), 0.0) << i;
  }
  EXPECT_FALSE(ahead.next());
  EXPECT_FALSE(ahead.next());  // the end stays the end
}

// However far the reader is ahead (a slow consumer lets it read everything first; a slow reader
// keeps the consumer waiting), each result comes out where the inner source gave it.
TEST(ReadAheadSource, BadFramesAndAFatalErrorComeOutAtTheirFrames) {
  const std::vector<std::string> expected{"0",
                                          "1",
                                          "bad 2: rgb/2.png cannot be decoded",
                                          "3",
                                          "bad 4: rgb/4.png cannot be decoded",
                                          "5",
                                          "error: associations.txt: line 6 unreadable"};
  ScriptedSource direct("ggbgbgfg");
  EXPECT_EQ(drain(direct), expected);
  for (const auto& [read_ms, consume_ms] : {std::pair{0, 5}, std::pair{5, 0}}) {
    ReadAheadSource ahead(std::make_unique<ScriptedSource>("ggbgbgfg", std::chrono::milliseconds(read_ms)), 2);
    EXPECT_EQ(drain(ahead, std::chrono::milliseconds(consume_ms)), expected) << read_ms << " " << consume_ms;
    // The source ended with the error: it is thrown again, and nothing after it is read.
    EXPECT_THAT(test::error_of([&] { ahead.next(); }), HasSubstr("line 6 unreadable"));
  }
}

TEST(ReadAheadSource, ReadsNoMoreThanItsBoundAhead) {
  auto inner = std::make_unique<ScriptedSource>(std::string(100, 'g'));
  const ScriptedSource& counted = *inner;
  ReadAheadSource ahead(std::move(inner), 3);
  ASSERT_EQ(ahead.next()->index, 0);
  // The reader fills the queue (polled: a loaded machine may be slow to run it), then has time
  // enough to read far ahead, were it allowed.
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (counted.reads() < 1 + 3 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  std::this_thread::sleep_for(50ms);
  // Frame 0, 3 queued and one read that waits for room.
  EXPECT_GE(counted.reads(), 1 + 3);
  EXPECT_LE(counted.reads(), 1 + 3 + 1);
  EXPECT_EQ(ahead.next()->index, 1);
}

// A run stopped early (a signal, an error) destroys the source while its reader waits for room,
// or while the reader is inside a slow read: neither hangs.
TEST(ReadAheadSource, DestroyedEarlyStopsItsReader) {
  for (const auto read_time : {0ms, 100ms}) {
    const auto start = std::chrono::steady_clock::now();
    {
      ReadAheadSource ahead(std::make_unique<ScriptedSource>(std::string(100000, 'g'), read_time), 2);
      ASSERT_TRUE(ahead.next());
      std::this_thread::sleep_for(20ms);
    }
    EXPECT_LT(std::chrono::steady_clock::now() - start, read_time * 4 + 500ms) << read_time.count();
  }
}

TEST(ReadAheadSource, ABoundBelowOneIsRefused) {
  EXPECT_THAT(test::error_of([] { ReadAheadSource(std::make_unique<ScriptedSource>("g"), 0); }),
              HasSubstr("1 or more"));
}

}  // namespace
}  // namespace cofusion

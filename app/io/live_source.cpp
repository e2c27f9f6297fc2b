#include "io/live_source.h"

namespace cofusion {
namespace {
std::unique_ptr<FrameSource> require_source(std::unique_ptr<FrameSource> source) {
  if (!source) throw Error("LiveSource: no source given");
  return source;
}
}  // namespace

LiveSource::LiveSource(std::unique_ptr<FrameSource> inner)
    : inner_(require_source(std::move(inner))),
      intrinsics_(inner_->intrinsics()),
      description_(inner_->describe()),
      reader_([this] { read_loop(); }) {}

LiveSource::~LiveSource() {
  stop_ = true;
  mailbox_.close();
  reader_.join();
}

void LiveSource::read_loop() {
  try {
    while (!stop_) {
      try {
        auto frame = inner_->next();
        if (!frame) break;
        mailbox_.put(std::move(*frame));
      } catch (const BadFrame& bad) {
        mailbox_.put(bad);
      }
    }
    mailbox_.close();
  } catch (...) {
    mailbox_.close(std::current_exception());
  }
}

std::optional<Frame> LiveSource::next() {
  auto item = mailbox_.take();
  if (!item) return std::nullopt;
  if (auto* bad = std::get_if<BadFrame>(&*item)) throw *bad;
  return std::move(std::get<Frame>(*item));
}

}  // namespace cofusion

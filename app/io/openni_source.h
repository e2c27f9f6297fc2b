#pragma once
// OpenNI2 input: a live device (the first found, or a URI) or an .oni recording played through
// OpenNI2's file driver. Depth (millimetres or 100 um) becomes metres; colour RGB888 / YUV422 /
// YUYV / GRAY8 becomes R,G,B. OpenNI types stay inside the .cpp (pimpl), so including this header
// needs no OpenNI2 headers.
#include <filesystem>
#include <memory>
#include <string>

#include "io/frame.h"

namespace cofusion {

struct OpenNiSourceOptions {
  // --intrinsics ("fx,fy,cx,cy[,w,h]", preset or file); empty = from the stream's field of view:
  // fx = w / (2 tan(hfov/2)), fy = h / (2 tan(vfov/2)), cx = (w-1)/2, cy = (h-1)/2.
  std::string intrinsics;
  // Longest wait for one frame before giving up, milliseconds. Recordings play as fast as they
  // are read, so a timeout there means the file is damaged; live devices deliver at 30 Hz.
  int frame_timeout_ms = 5000;
  // Live devices: preferred stream size and rate (the closest supported mode is used).
  int live_width = 640;
  int live_height = 480;
  int live_fps = 30;
};

class OpenNiSource : public FrameSource {
 public:
  // An .oni recording. Playback runs as fast as frames are read (speed -1), without repeat.
  // Throws cofusion::Error naming the file when it is missing or holds no usable depth stream.
  static std::unique_ptr<OpenNiSource> open_recording(const std::filesystem::path& path,
                                                      const OpenNiSourceOptions& options = {});
  // A live device: `uri` empty = the first device OpenNI2 finds.
  static std::unique_ptr<OpenNiSource> open_device(const std::string& uri, const OpenNiSourceOptions& options = {});

  ~OpenNiSource() override;
  OpenNiSource(const OpenNiSource&) = delete;
  OpenNiSource& operator=(const OpenNiSource&) = delete;

  // Recordings: each depth frame is paired with the colour frame of the same frame index (the
  // file driver numbers both streams from 1 in recording order). When the colour stream has fewer
  // frames, the last colour frame is reused; a recording without colour gives black images.
  // Live: the newest colour frame is taken with each depth frame (depth/colour sync is requested).
  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override;
  std::optional<int> size() const override;
  std::string describe() const override;

  struct Impl;

 private:
  explicit OpenNiSource(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace cofusion

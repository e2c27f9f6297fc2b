#include "io/openni_source.h"

#include <OpenNI.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "io/intrinsics_option.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {

constexpr double kPi = 3.14159265358979323846;

// How long the driver (a recording's file player, a camera's reader) is given to finish handing
// over a frame before the device is closed (see OpenNiSource::Impl::~Impl). The hand-over itself
// takes microseconds; the margin is for a driver thread that the scheduler has set aside on a
// loaded machine.
constexpr auto kDriverSettleTime = std::chrono::milliseconds(50);

// OpenNI2 keeps one process-wide context: initialize() loads every driver from disk. Sources
// share it through this function-local static, initialized on first use (thread-safe). It is
// private to this file and holds no project state. Re-initializing per source instead would
// reload all drivers each time (~0.4 s). OpenNI::shutdown() is deliberately never called: it
// deletes the drivers, and Debian's driver set (the Dummy driver never joins its threads)
// crashed there in about 1 % of test runs; every device and stream is closed by its source, and
// the process exit releases the rest.
void ensure_openni_initialized() {
  struct Library {
    openni::Status status;
    std::string error;
    Library() : status(openni::OpenNI::initialize()), error(openni::OpenNI::getExtendedError()) {}
  };
  static const Library library;
  if (library.status != openni::STATUS_OK) throw Error("OpenNI2 initialization failed: " + library.error);
}

std::string openni_error() {
  std::string e = openni::OpenNI::getExtendedError();
  for (char& c : e)
    if (c == '\n' || c == '\t') c = ' ';
  e.erase(0, e.find_first_not_of(' '));
  e.erase(e.find_last_not_of(' ') + 1);
  return e;
}

const char* format_name(openni::PixelFormat f) {
  switch (f) {
    case openni::PIXEL_FORMAT_DEPTH_1_MM: return "depth 1 mm";
    case openni::PIXEL_FORMAT_DEPTH_100_UM: return "depth 100 um";
    case openni::PIXEL_FORMAT_SHIFT_9_2: return "shift 9.2";
    case openni::PIXEL_FORMAT_SHIFT_9_3: return "shift 9.3";
    case openni::PIXEL_FORMAT_RGB888: return "RGB888";
    case openni::PIXEL_FORMAT_YUV422: return "YUV422";
    case openni::PIXEL_FORMAT_GRAY8: return "GRAY8";
    case openni::PIXEL_FORMAT_GRAY16: return "GRAY16";
    case openni::PIXEL_FORMAT_JPEG: return "JPEG";
    case openni::PIXEL_FORMAT_YUYV: return "YUYV";
  }
  return "unknown";
}

// Metres per unit of a depth pixel format; 0 when the format is not a depth in length units.
double depth_scale_m(openni::PixelFormat f) {
  if (f == openni::PIXEL_FORMAT_DEPTH_1_MM) return 1e-3;
  if (f == openni::PIXEL_FORMAT_DEPTH_100_UM) return 1e-4;
  return 0.0;
}

bool colour_supported(openni::PixelFormat f) {
  return f == openni::PIXEL_FORMAT_RGB888 || f == openni::PIXEL_FORMAT_YUV422 || f == openni::PIXEL_FORMAT_YUYV ||
         f == openni::PIXEL_FORMAT_GRAY8;
}

// The supported mode of `sensor` closest to w x h @ fps among `formats` (in preference order).
std::optional<openni::VideoMode> pick_mode(const openni::SensorInfo* sensor, std::initializer_list<openni::PixelFormat> formats,
                                           int w, int h, int fps) {
  if (!sensor) return std::nullopt;
  const auto& modes = sensor->getSupportedVideoModes();
  std::optional<openni::VideoMode> best;
  long best_cost = 0;
  for (int i = 0; i < modes.getSize(); ++i) {
    long rank = 0;
    bool ok = false;
    for (auto f : formats) {
      if (modes[i].getPixelFormat() == f) {
        ok = true;
        break;
      }
      ++rank;
    }
    if (!ok) continue;
    const long cost = 1000000L * rank + 100L * (std::abs(modes[i].getResolutionX() - w) + std::abs(modes[i].getResolutionY() - h)) +
                      std::abs(modes[i].getFps() - fps);
    if (!best || cost < best_cost) {
      best = modes[i];
      best_cost = cost;
    }
  }
  return best;
}

}  // namespace

struct OpenNiSource::Impl {
  std::string name;  // "oni:PATH" or "openni2:URI", prefix of every message
  bool is_file = false;
  int frame_timeout_ms = 5000;
  openni::Device device;
  openni::VideoStream depth;
  openni::VideoStream colour;
  bool has_colour = false;
  bool registered = false;
  std::string registration_note;
  int depth_frames_total = -1;  // recordings only
  int colour_frames_total = -1;
  int depth_read = 0;
  int colour_read = 0;
  int last_colour_index = -1;
  cv::Mat last_rgb;
  IntrinsicsChoice intrinsics;
  int next_index = 0;

  bool started = false;  // a stream was started, so the driver may be handing over a frame

  // Order matters for recordings.
  // - The file driver's player thread walks its stream list without a lock and spins on it once
  //   the file has ended, so destroying a stream while the device is open races with it. Closing
  //   the device first joins the player thread; the streams destroyed afterwards no longer call
  //   into the driver (OpenNI2 skips the driver when the device handle is gone), at the cost of
  //   the driver's two small stream objects per recording never being freed.
  // - Device::close() deletes OpenNI2's per-sensor objects before it joins the player thread,
  //   and the player hands a frame over by waking the reader first and releasing the frame
  //   through that sensor object afterwards. A close between the two frees the object under the
  //   player (a crash in about 1 close in 200 on a loaded machine). Stopped streams make the
  //   player drop every later frame before it reaches OpenNI2; the pause lets a hand-over already
  //   under way finish. The player offers no handshake that is safe here: a seek, its one
  //   synchronous call, crashes it near the end of the file. Live devices get the same pause:
  //   their drivers also hand frames over from their own threads.
  ~Impl() {
    depth.stop();
    colour.stop();
    if (started) std::this_thread::sleep_for(kDriverSettleTime);
    device.close();
    depth.destroy();
    colour.destroy();
  }

  void open(const char* uri, const OpenNiSourceOptions& options);
  void open_device(const char* uri);
  void configure_playback();
  void configure_live(const OpenNiSourceOptions& options);
  void register_depth_to_colour();
  void check_modes(int& width, int& height) const;
  void set_intrinsics(const std::string& option, int width, int height);
  Intrinsics intrinsics_from_field_of_view(int width, int height);
  cv::Mat convert_colour(const openni::VideoFrameRef& f) const;
  void wait_for(openni::VideoStream& stream, int timeout_ms, const std::string& what) const;
};

void OpenNiSource::Impl::wait_for(openni::VideoStream& stream, int timeout_ms, const std::string& what) const {
  openni::VideoStream* streams[] = {&stream};
  int ready = -1;
  const openni::Status st = openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms);
  if (st != openni::STATUS_OK)
    throw Error(name + " frame " + std::to_string(next_index) + ": no " + what + " frame within " +
                std::to_string(timeout_ms) + " ms" + (is_file ? " (damaged recording?)" : " (device disconnected?)"));
}

void OpenNiSource::Impl::open(const char* uri, const OpenNiSourceOptions& options) {
  frame_timeout_ms = options.frame_timeout_ms;
  ensure_openni_initialized();
  open_device(uri);
  if (is_file)
    configure_playback();
  else
    configure_live(options);
  register_depth_to_colour();
  int w = 0, h = 0;
  check_modes(w, h);
  set_intrinsics(options.intrinsics, w, h);
  require_plausible(intrinsics.intrinsics, name + " (" + intrinsics.origin + ")");
  if (depth.start() != openni::STATUS_OK) throw Error(name + ": cannot start the depth stream: " + openni_error());
  started = true;
  if (has_colour && colour.start() != openni::STATUS_OK)
    throw Error(name + ": cannot start the colour stream: " + openni_error());
}

// The device or recording with its depth stream (required) and colour stream (when there is one).
void OpenNiSource::Impl::open_device(const char* uri) {
  if (device.open(uri) != openni::STATUS_OK) {
    const std::string why = openni_error();
    throw Error(name + ": OpenNI2 cannot open " + (is_file ? "the recording" : "the device") +
                (why.empty() ? (is_file ? " (not an .oni file, or it holds no usable streams)" : "") : ": " + why));
  }
  if (!device.hasSensor(openni::SENSOR_DEPTH)) throw Error(name + ": no depth stream");
  if (depth.create(device, openni::SENSOR_DEPTH) != openni::STATUS_OK)
    throw Error(name + ": cannot create the depth stream: " + openni_error());
  has_colour = device.hasSensor(openni::SENSOR_COLOR) && colour.create(device, openni::SENSOR_COLOR) == openni::STATUS_OK;
}

// A recording plays as fast as it is read, once; a colour stream without frames is dropped.
void OpenNiSource::Impl::configure_playback() {
  openni::PlaybackControl* playback = device.getPlaybackControl();
  if (!playback) throw Error(name + ": OpenNI2 gives no playback control for the recording");
  playback->setSpeed(-1.0f);  // as fast as frames are read; the player waits for the reader
  playback->setRepeatEnabled(false);
  depth_frames_total = playback->getNumberOfFrames(depth);
  if (depth_frames_total <= 0) throw Error(name + ": the recording holds no depth frames");
  if (has_colour) {
    colour_frames_total = playback->getNumberOfFrames(colour);
    if (colour_frames_total <= 0) {
      colour.destroy();
      has_colour = false;
    }
  }
}

// Live: the nearest mode to the preferred size in a format we can read.
void OpenNiSource::Impl::configure_live(const OpenNiSourceOptions& options) {
  if (auto mode = pick_mode(device.getSensorInfo(openni::SENSOR_DEPTH),
                            {openni::PIXEL_FORMAT_DEPTH_1_MM, openni::PIXEL_FORMAT_DEPTH_100_UM}, options.live_width,
                            options.live_height, options.live_fps))
    depth.setVideoMode(*mode);
  if (has_colour) {
    if (auto mode = pick_mode(device.getSensorInfo(openni::SENSOR_COLOR),
                              {openni::PIXEL_FORMAT_RGB888, openni::PIXEL_FORMAT_YUYV, openni::PIXEL_FORMAT_YUV422},
                              depth.getVideoMode().getResolutionX(), depth.getVideoMode().getResolutionY(),
                              options.live_fps))
      colour.setVideoMode(*mode);
  }
  device.setDepthColorSyncEnabled(true);  // best effort: not every driver supports it
}

// Depth registered to colour so pixels correspond; recordings keep whatever was recorded.
void OpenNiSource::Impl::register_depth_to_colour() {
  if (has_colour && device.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR)) {
    registered = device.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) == openni::STATUS_OK;
    registration_note = registered ? "depth registered to colour" : "depth registration to colour failed";
  } else {
    registration_note = has_colour ? "depth not registered to colour (not supported by the driver)" : "no colour stream";
  }
}

// Pixel formats we can read and streams of one size; returns that size.
void OpenNiSource::Impl::check_modes(int& w, int& h) const {
  const openni::VideoMode depth_mode = depth.getVideoMode();
  w = depth_mode.getResolutionX(), h = depth_mode.getResolutionY();
  if (depth_scale_m(depth_mode.getPixelFormat()) == 0.0)
    throw Error(name + ": depth pixel format '" + format_name(depth_mode.getPixelFormat()) + "' is not supported");
  if (w <= 0 || h <= 0) throw Error(name + ": depth stream reports size " + std::to_string(w) + "x" + std::to_string(h));
  if (!has_colour) return;
  const openni::VideoMode colour_mode = colour.getVideoMode();
  if (!colour_supported(colour_mode.getPixelFormat()))
    throw Error(name + ": colour pixel format '" + format_name(colour_mode.getPixelFormat()) + "' is not supported");
  if (colour_mode.getResolutionX() != w || colour_mode.getResolutionY() != h)
    throw Error(name + ": colour stream is " + std::to_string(colour_mode.getResolutionX()) + "x" +
                std::to_string(colour_mode.getResolutionY()) + " but depth is " + std::to_string(w) + "x" +
                std::to_string(h));
}

// From --intrinsics when given (their size must match the streams'), else from the streams'
// fields of view.
void OpenNiSource::Impl::set_intrinsics(const std::string& option, int w, int h) {
  if (option.empty()) {
    intrinsics.intrinsics = intrinsics_from_field_of_view(w, h);
    intrinsics.size_known = true;
    return;
  }
  intrinsics = parse_intrinsics_option(option);
  if (intrinsics.size_known && (intrinsics.intrinsics.width != w || intrinsics.intrinsics.height != h))
    throw Error(name + ": --intrinsics are for " + std::to_string(intrinsics.intrinsics.width) + "x" +
                std::to_string(intrinsics.intrinsics.height) + " images but the streams are " + std::to_string(w) +
                "x" + std::to_string(h));
  intrinsics.intrinsics.width = w;
  intrinsics.intrinsics.height = h;
}

// Registered depth lives in the colour camera: its field of view is preferred when it reports one.
Intrinsics OpenNiSource::Impl::intrinsics_from_field_of_view(int w, int h) {
  openni::VideoStream& fov_stream =
      (registered && colour.getHorizontalFieldOfView() > 0 && colour.getVerticalFieldOfView() > 0) ? colour : depth;
  const double hfov = fov_stream.getHorizontalFieldOfView(), vfov = fov_stream.getVerticalFieldOfView();
  const std::string stream_name = &fov_stream == &colour ? "colour" : "depth";
  if (!(hfov > 0 && hfov < kPi && vfov > 0 && vfov < kPi))
    throw Error(name + ": the " + stream_name + " stream reports no usable field of view (" + std::to_string(hfov) +
                ", " + std::to_string(vfov) + " rad); give --intrinsics");
  Intrinsics k;
  k.width = w;
  k.height = h;
  k.fx = w / (2.0 * std::tan(hfov / 2.0));
  k.fy = h / (2.0 * std::tan(vfov / 2.0));
  k.cx = (w - 1) / 2.0;
  k.cy = (h - 1) / 2.0;
  char fov[96];
  std::snprintf(fov, sizeof fov, "hfov %.2f deg, vfov %.2f deg", hfov * 180.0 / kPi, vfov * 180.0 / kPi);
  intrinsics.origin = "field of view of the " + stream_name + " stream (" + fov + ")";
  return k;
}

cv::Mat OpenNiSource::Impl::convert_colour(const openni::VideoFrameRef& f) const {
  const int w = f.getWidth(), h = f.getHeight();
  const auto stride = static_cast<std::size_t>(f.getStrideInBytes());
  void* data = const_cast<void*>(f.getData());
  cv::Mat rgb;
  switch (f.getVideoMode().getPixelFormat()) {
    case openni::PIXEL_FORMAT_RGB888: rgb = cv::Mat(h, w, CV_8UC3, data, stride).clone(); break;
    case openni::PIXEL_FORMAT_YUV422:  // OpenNI's YUV422 is UYVY
      cv::cvtColor(cv::Mat(h, w, CV_8UC2, data, stride), rgb, cv::COLOR_YUV2RGB_UYVY);
      break;
    case openni::PIXEL_FORMAT_YUYV: cv::cvtColor(cv::Mat(h, w, CV_8UC2, data, stride), rgb, cv::COLOR_YUV2RGB_YUYV); break;
    case openni::PIXEL_FORMAT_GRAY8: cv::cvtColor(cv::Mat(h, w, CV_8UC1, data, stride), rgb, cv::COLOR_GRAY2RGB); break;
    default:
      throw Error(name + " frame " + std::to_string(next_index) + ": colour pixel format '" +
                  format_name(f.getVideoMode().getPixelFormat()) + "' is not supported");
  }
  return rgb;
}

OpenNiSource::OpenNiSource(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
OpenNiSource::~OpenNiSource() = default;

std::unique_ptr<OpenNiSource> OpenNiSource::open_recording(const fs::path& path, const OpenNiSourceOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->name = "oni:" + path.string();
  impl->is_file = true;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw Error("OpenNI recording " + path.string() + " does not exist");
  impl->open(path.c_str(), options);
  return std::unique_ptr<OpenNiSource>(new OpenNiSource(std::move(impl)));
}

std::unique_ptr<OpenNiSource> OpenNiSource::open_device(const std::string& uri, const OpenNiSourceOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->name = "openni2:" + (uri.empty() ? std::string("(first device)") : uri);
  impl->open(uri.empty() ? openni::ANY_DEVICE : uri.c_str(), options);
  return std::unique_ptr<OpenNiSource>(new OpenNiSource(std::move(impl)));
}

std::optional<Frame> OpenNiSource::next() {
  Impl& s = *impl_;
  if (s.is_file && s.depth_read >= s.depth_frames_total) return std::nullopt;
  const Intrinsics& k = s.intrinsics.intrinsics;
  const std::string where = s.name + " frame " + std::to_string(s.next_index);

  s.wait_for(s.depth, s.frame_timeout_ms, "depth");
  openni::VideoFrameRef df;
  if (s.depth.readFrame(&df) != openni::STATUS_OK || !df.isValid())
    throw Error(where + ": cannot read the depth frame: " + openni_error());
  ++s.depth_read;
  if (df.getWidth() != k.width || df.getHeight() != k.height)
    throw Error(where + ": depth frame is " + std::to_string(df.getWidth()) + "x" + std::to_string(df.getHeight()) +
                ", expected " + std::to_string(k.width) + "x" + std::to_string(k.height));
  const double scale = depth_scale_m(df.getVideoMode().getPixelFormat());
  if (scale == 0.0)
    throw Error(where + ": depth pixel format '" + format_name(df.getVideoMode().getPixelFormat()) + "' is not supported");

  Frame frame;
  frame.index = s.next_index;
  frame.timestamp_s = static_cast<double>(df.getTimestamp()) * 1e-6;
  frame.intrinsics = k;
  cv::Mat(df.getHeight(), df.getWidth(), CV_16UC1, const_cast<void*>(df.getData()),
          static_cast<std::size_t>(df.getStrideInBytes()))
      .convertTo(frame.depth_m, CV_32F, scale);

  if (s.has_colour) {
    if (s.is_file) {
      // Catch up to the colour frame with this depth frame's index (both number from 1).
      while (s.colour_read < s.colour_frames_total && s.last_colour_index < df.getFrameIndex()) {
        s.wait_for(s.colour, s.frame_timeout_ms, "colour");
        openni::VideoFrameRef cf;
        if (s.colour.readFrame(&cf) != openni::STATUS_OK || !cf.isValid())
          throw Error(where + ": cannot read the colour frame: " + openni_error());
        ++s.colour_read;
        s.last_colour_index = cf.getFrameIndex();
        s.last_rgb = s.convert_colour(cf);
      }
    } else {
      // Live: the newest colour frame; block only until the first one arrives.
      openni::VideoStream* streams[] = {&s.colour};
      int ready = -1;
      const int timeout = s.last_rgb.empty() ? s.frame_timeout_ms : 0;
      if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout) == openni::STATUS_OK) {
        openni::VideoFrameRef cf;
        if (s.colour.readFrame(&cf) == openni::STATUS_OK && cf.isValid()) s.last_rgb = s.convert_colour(cf);
      } else if (s.last_rgb.empty()) {
        throw Error(where + ": no colour frame within " + std::to_string(s.frame_timeout_ms) + " ms");
      }
    }
  }
  if (!s.last_rgb.empty()) {
    if (s.last_rgb.cols != k.width || s.last_rgb.rows != k.height)
      throw Error(where + ": colour frame is " + std::to_string(s.last_rgb.cols) + "x" + std::to_string(s.last_rgb.rows) +
                  ", expected " + std::to_string(k.width) + "x" + std::to_string(k.height));
    frame.rgb = s.last_rgb.clone();
  } else {
    frame.rgb = cv::Mat(k.height, k.width, CV_8UC3, cv::Scalar::all(0));
  }
  ++s.next_index;
  return frame;
}

Intrinsics OpenNiSource::intrinsics() const { return impl_->intrinsics.intrinsics; }

std::optional<int> OpenNiSource::size() const {
  if (impl_->is_file) return impl_->depth_frames_total;
  return std::nullopt;
}

std::string OpenNiSource::describe() const {
  const Impl& s = *impl_;
  std::string d = s.name + " (";
  if (s.is_file) d += std::to_string(s.depth_frames_total) + " frames, ";
  const auto dm = s.depth.getVideoMode();
  d += std::to_string(dm.getResolutionX()) + "x" + std::to_string(dm.getResolutionY()) + " " +
       format_name(dm.getPixelFormat());
  if (s.has_colour) d += std::string(" + ") + format_name(s.colour.getVideoMode().getPixelFormat()) + " colour";
  d += ", " + s.registration_note + ", " + s.intrinsics.origin + ": " + s.intrinsics.intrinsics.to_string() + ")";
  return d;
}

}  // namespace cofusion

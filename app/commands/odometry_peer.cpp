#include "commands/odometry_peer.h"

#include <algorithm>
#include <chrono>
#include <opencv2/imgproc.hpp>
#include <opencv2/rgbd.hpp>

#include "common/error.h"

namespace cofusion::commands {

OdometryPeerFigure time_opencv_odometry(const std::vector<Frame>& frames) {
  if (frames.size() < 2) throw Error("OpenCV odometry figure: needs at least 2 frames");
  const Intrinsics& k = frames[0].intrinsics;
  const cv::Mat camera_matrix = (cv::Mat_<float>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  const cv::Ptr<cv::rgbd::RgbdICPOdometry> odometry = cv::rgbd::RgbdICPOdometry::create(camera_matrix);
  const auto make_frame = [](const Frame& f) {
    cv::Mat grey;
    cv::cvtColor(f.rgb, grey, cv::COLOR_RGB2GRAY);
    return cv::rgbd::OdometryFrame::create(grey, f.depth_m);
  };
  cv::Ptr<cv::rgbd::OdometryFrame> previous = make_frame(frames[0]);
  OdometryPeerFigure figure;
  std::vector<double> ms;
  for (size_t i = 1; i < frames.size(); ++i) {
    const auto start = std::chrono::steady_clock::now();
    cv::Ptr<cv::rgbd::OdometryFrame> current = make_frame(frames[i]);
    cv::Mat Rt;  // the motion between the frames; only the time is used
    const bool tracked = odometry->compute(previous, current, Rt);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    figure.failures += tracked ? 0 : 1;
    previous = current;
  }
  std::sort(ms.begin(), ms.end());
  const size_t n = ms.size();
  figure.median_ms = n % 2 ? ms[n / 2] : 0.5 * (ms[n / 2 - 1] + ms[n / 2]);
  figure.frames = static_cast<int>(n);
  return figure;
}

const char* opencv_odometry_name() {
  return "RgbdICPOdometry (OpenCV " CV_VERSION ", default parameters, frame to frame)";
}

}  // namespace cofusion::commands

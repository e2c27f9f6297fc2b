#pragma once
// The figure `cofusion bench` divides its pipeline figures by: OpenCV's frame-to-frame RGB-D
// odometry on the same frames, timed in the same run. This machine's speed drifts by tens of
// percent within minutes, so a ratio to a peer measured moments apart says more than milliseconds.
#include <vector>

#include "io/frame.h"

namespace cofusion::commands {

struct OdometryPeerFigure {
  double median_ms = 0;  // median wall-clock milliseconds per frame
  int frames = 0;        // frames timed: every frame but the first (it has nothing to be tracked against)
  int failures = 0;      // frames for which compute() reported no pose
};

// cv::rgbd::RgbdICPOdometry with its default parameters, frame to frame over `frames` (at least
// 2, all of one size), the camera matrix from the first frame's intrinsics. A frame's time covers
// what the odometry needs from our in-memory frame, as the pipeline's figure covers upload and
// preprocessing: the grey image (from RGB), its OdometryFrame (over the depth in metres, CV_32F)
// and compute() against the previous frame, which builds the pyramids, points and normals it
// lacks and runs the ICP. OpenCV runs with its default threads (cv::getNumThreads()).
OdometryPeerFigure time_opencv_odometry(const std::vector<Frame>& frames);

// "RgbdICPOdometry (OpenCV x.y, default parameters, frame to frame)".
const char* opencv_odometry_name();

}  // namespace cofusion::commands

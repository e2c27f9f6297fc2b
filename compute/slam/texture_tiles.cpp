#include "slam/texture_tiles.h"

#include <algorithm>

#include <opencv2/imgproc.hpp>

#include "shared/host_device.h"

namespace cofusion::slam {

std::vector<float> texture_tile_weights(const uint8_t* rgb, int width, int height, double cap) {
  std::vector<float> weights(ICP_RGB_TILES_X * ICP_RGB_TILES_Y, 1.0f);
  if (cap <= 0 || width < 3 || height < 3) return weights;
  const cv::Mat colour(height, width, CV_8UC3, const_cast<uint8_t*>(rgb));
  cv::Mat colour_f, intensity, gx, gy;
  colour.convertTo(colour_f, CV_32FC3);
  cv::transform(colour_f, intensity, cv::Matx13f(1.0f / 3, 1.0f / 3, 1.0f / 3));
  cv::Sobel(intensity, gx, CV_32F, 1, 0, 3, 0.125, 0, cv::BORDER_REPLICATE);
  cv::Sobel(intensity, gy, CV_32F, 0, 1, 3, 0.125, 0, cv::BORDER_REPLICATE);
  std::vector<double> energy(weights.size(), 0.0);
  for (int y = 0; y < height; ++y) {
    const float* ax = gx.ptr<float>(y);
    const float* ay = gy.ptr<float>(y);
    for (int x = 0; x < width; ++x)
      energy[size_t(gpu_layout::icp_rgb_tile(x, y, width, height))] += ax[x] * ax[x] + ay[x] * ay[x];
  }
  std::vector<double> sorted = energy;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  if (!(median > 0)) return weights;
  for (size_t i = 0; i < energy.size(); ++i)
    if (energy[i] > cap * median) weights[i] = static_cast<float>(cap * median / energy[i]);
  return weights;
}

}  // namespace cofusion::slam

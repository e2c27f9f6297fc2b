#pragma once
// Reading and writing the images of RGB-D frames with the checks every reader needs: the file
// exists and decodes, has the expected pixel type, and depth carries no NaN/inf/negative values.
// Every error is a cofusion::Error naming the file.
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

namespace cofusion {

// 8-bit colour image as CV_8UC3 in R,G,B byte order (grey and RGBA inputs are converted).
cv::Mat read_rgb_image(const std::filesystem::path& path);

// Depth image in metres (CV_32FC1, 0 = no reading). 16-bit images are divided by
// `units_per_metre` (TUM: 5000, millimetre formats: 1000); 32-bit float images (EXR, TIFF) are
// taken as metres already. NaN, inf and negative readings become 0.
cv::Mat read_depth_image(const std::filesystem::path& path, double units_per_metre);

// Instance-id mask as CV_16UC1 (8-bit and 16-bit single-channel inputs accepted; JPEG files are
// rejected: lossy compression changes ids).
cv::Mat read_mask_image(const std::filesystem::path& path);

// In place: NaN, inf and negative values of a CV_32FC1 depth image become 0 (no reading).
void sanitize_depth(cv::Mat& depth_m);

// Throws cofusion::Error "<what>: image is WxH, expected WxH" unless `image` has that size.
void require_image_size(const cv::Mat& image, int width, int height, const std::string& what);

// Metres -> 16-bit fixed point (round(depth_m * units_per_metre)). Readings that do not fit
// (beyond 65535 units) become 0 = no reading rather than being clamped to a wrong distance.
cv::Mat depth_to_u16(const cv::Mat& depth_m, double units_per_metre);

// RGB (CV_8UC3, R,G,B order) -> PNG/JPEG bytes and files. Files are written atomically.
void write_rgb_image(const std::filesystem::path& path, const cv::Mat& rgb);
// Single-channel images (16-bit depth or mask) as lossless PNG, written atomically.
void write_u16_png(const std::filesystem::path& path, const cv::Mat& image_u16);

}  // namespace cofusion

#pragma once
// An RGBA8 image on the host (R in the low byte of each uint32), as the viewer renders it, and
// its PNG writer.
#include <cstdint>
#include <filesystem>
#include <vector>

namespace cofusion::renderer {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<uint32_t> rgba;  // row-major, width * height

  Image() = default;
  Image(int w, int h, uint32_t fill = 0xFF000000u) : width(w), height(h), rgba(static_cast<size_t>(w) * h, fill) {}
  uint32_t& at(int x, int y) { return rgba[static_cast<size_t>(y) * width + x]; }
  uint32_t at(int x, int y) const { return rgba[static_cast<size_t>(y) * width + x]; }
  bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
};

constexpr uint32_t rgba8(uint32_t r, uint32_t g, uint32_t b, uint32_t a = 255) {
  return r | (g << 8) | (b << 16) | (a << 24);
}

// `image` as the bytes of an 8-bit RGB PNG file (the caller writes them, e.g. atomically: the
// renderer does no file output of its own). Throws cofusion::Error when the image is empty.
std::vector<uint8_t> encode_png(const Image& image);

// Reads an RGB(A) PNG back into an Image (alpha forced opaque). Throws cofusion::Error naming the
// path when it is missing or not an image.
Image read_png(const std::filesystem::path& path);

}  // namespace cofusion::renderer

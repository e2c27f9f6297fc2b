// texture_tile_weights: a tile with far more gradient energy than the median tile is weighed down
// to `cap` typical tiles' worth; the rest, and views without texture, keep weight 1.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include "slam/texture_tiles.h"

namespace cofusion::slam {
namespace {

// A width x height RGB8 image of grey noise (standard deviation `noise` levels) with an 8-pixel
// black-and-white checker inside [x0, x1) x [y0, y1).
std::vector<uint8_t> textured_image(int width, int height, double noise, int x0, int y0, int x1, int y1) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, noise);
  std::vector<uint8_t> rgb(size_t(width) * height * 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const bool checker = x >= x0 && x < x1 && y >= y0 && y < y1;
      const double v = checker ? (((x / 8) + (y / 8)) % 2 ? 230.0 : 25.0) : 128.0 + n(rng);
      for (int c = 0; c < 3; ++c) rgb[(size_t(y) * width + x) * 3 + c] = uint8_t(std::clamp(v, 0.0, 255.0));
    }
  return rgb;
}

TEST(TextureTiles, ACheckerTileIsCappedAtTypicalTilesWorth) {
  const int w = 640, h = 480;
  // The checker fills tile (2, 1) of 8 x 6 (80 x 80 pixels each) and nothing else.
  const auto rgb = textured_image(w, h, 4.0, 160, 80, 240, 160);
  const std::vector<float> weights = texture_tile_weights(rgb.data(), w, h, 8.0);
  ASSERT_EQ(weights.size(), 48u);
  for (size_t i = 0; i < weights.size(); ++i) {
    if (i == 1 * 8 + 2) {
      // Checker edges: gradients of about 100 levels on 1 of 4 pixels against noise gradients of
      // a few levels everywhere: hundreds of typical tiles' energy, weighed down to 8.
      EXPECT_GT(weights[i], 0.0f) << i;
      EXPECT_LT(weights[i], 0.1f) << i;
    } else {
      EXPECT_EQ(weights[i], 1.0f) << i;
    }
  }
  // A cap above the checker's share leaves it at 1; no cap leaves every tile at 1.
  for (double cap : {1e6, 0.0}) {
    const std::vector<float> all = texture_tile_weights(rgb.data(), w, h, cap);
    EXPECT_EQ(all, std::vector<float>(48, 1.0f)) << cap;
  }
}

TEST(TextureTiles, EvenTextureAndNoTextureKeepEveryTile) {
  for (const auto& [w, h] : {std::pair{640, 480}, std::pair{37, 23}, std::pair{3, 3}, std::pair{1, 1}}) {
    const auto noise = textured_image(w, h, 6.0, 0, 0, 0, 0);
    const auto flat = textured_image(w, h, 0.0, 0, 0, 0, 0);
    // Noise is even, so every tile is within 8 typical ones (tiles of a 37 x 23 image differ in
    // pixel count by at most a third); a flat image has no texture to weigh.
    EXPECT_EQ(texture_tile_weights(noise.data(), w, h, 8.0), std::vector<float>(48, 1.0f)) << w << "x" << h;
    EXPECT_EQ(texture_tile_weights(flat.data(), w, h, 8.0), std::vector<float>(48, 1.0f)) << w << "x" << h;
  }
}

}  // namespace
}  // namespace cofusion::slam

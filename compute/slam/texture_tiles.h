#pragma once
// How the view's texture is spread over the image: the photometric term's information grows with
// the intensity gradient's square, so one strongly textured region (a checker box) can hold most
// of it and pull the camera along when it starts to move, before any segmentation can tell it
// apart (docs/experiments.md, "Capping a region's share of the camera's colour term").
#include <cstdint>
#include <vector>

namespace cofusion::slam {

// The weight of each of the tracker's tiles (gpu_layout::icp_rgb_tile: ICP_RGB_TILES_X x
// ICP_RGB_TILES_Y, row-major) of a width x height RGB8 image: 1 where the tile's gradient energy
// (the sum of |grad I|^2 over its pixels, I = (r + g + b) / 3, Sobel) is at most `cap` times the
// median tile's, else cap * median / energy, so that no tile counts for more than `cap` typical
// ones. All 1 where the median tile has no texture at all or cap <= 0.
std::vector<float> texture_tile_weights(const uint8_t* rgb, int width, int height, double cap);

}  // namespace cofusion::slam

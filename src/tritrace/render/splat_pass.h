// SplatPass: light tracing's sample counts in one pass of adaptive sampling (bdpt with
// --noise-threshold): which pixels the pass's splats may land on, and for each pixel the ratio of
// the light subpaths that may splat onto it to the camera samples it takes, which its MIS weights
// and the normalisation of its splats use. docs/BDPT.md ("Adaptive sampling") derives it.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>

namespace tritrace {

struct SplatPass {
  int width = 0, height = 0;
  // Adaptive sampling's neighbourhood (renderer.h: kPartTileSize, kAdaptiveRadius): a pixel's
  // budget is set by the pilot samples of the pixels within `radius` of it in its `tile` x `tile`
  // tile.
  int tile = 16;
  int radius = 2;
  // The pilot (samples below kAdaptivePilotSpp): every pixel takes them, and a pixel's light image
  // takes no splats from its neighbours' light subpaths, whose pilot sets its budget (so its
  // pilot estimate stays independent of its budget: unbiased).
  bool pilot = false;
  // After the pilot: per pixel (row-major) whether it takes this pass's samples (null: all), and
  // the share A / P of the image's pixels that do.
  const uint8_t* active = nullptr;
  float active_share = 1.0f;

  // Whether a splat from a light subpath of pixel `from` (row-major index) onto pixel (x, y)
  // counts: not onto a pixel that takes no samples in this pass (it is finished), and in the
  // pilot not onto a neighbour of `from`.
  bool keeps(uint32_t from, int x, int y) const {
    if (active &&
        !active[static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)]) {
      return false;
    }
    if (!pilot) return true;
    const int fx = static_cast<int>(from % static_cast<uint32_t>(width));
    const int fy = static_cast<int>(from / static_cast<uint32_t>(width));
    if (fx == x && fy == y) return true;
    const bool same_tile = fx / tile == x / tile && fy / tile == y / tile;
    const bool near = std::abs(fx - x) <= radius && std::abs(fy - y) <= radius;
    return !(same_tile && near);
  }

  // Pixel (x, y)'s light subpaths in this pass over the image's pixel count times its camera
  // samples in this pass (every active pixel takes the same count m in a pass, and each camera
  // sample traces one light subpath): the pass's A / P, and in the pilot (P - its neighbours) / P.
  // 1 for a render that takes every sample of every pixel.
  float count_ratio(int x, int y) const {
    if (!pilot) return active_share;
    const auto span = [this](int c, int size) {
      const int lo = c / tile * tile, hi = std::min(lo + tile, size) - 1;
      return std::min(c + radius, hi) - std::max(c - radius, lo) + 1;
    };
    const double pixels = static_cast<double>(width) * static_cast<double>(height);
    const double neighbours = static_cast<double>(span(x, width) * span(y, height) - 1);
    return static_cast<float>((pixels - neighbours) / pixels);
  }
};

}  // namespace tritrace

// Parts: their description, their tile groups' pixels, and the packed films that hold only them.
#include "tritrace/distributed/part.h"

#include <algorithm>
#include <numeric>

#include "tritrace/error.h"
#include "tritrace/render/renderer.h"

namespace tritrace {

std::string PartRange::describe() const {
  std::string s = "samples [" + std::to_string(first) + ", " + std::to_string(end) + ")";
  if (tiles > 1) s += " of tile " + std::to_string(tile) + "/" + std::to_string(tiles);
  return s;
}

std::string describe_part(const PartInfo& info) {
  const RenderIdentity& r = info.render;
  std::string s;
  s += "partial film: " + info.range.describe() + " of " + std::to_string(r.spp) + " spp\n";
  s += "render: " + r.hash + "\n";
  s += "integrator: " + r.integrator + "\n";
  s += "seed: " + std::to_string(r.seed) + "\n";
  s += "spp: " + std::to_string(r.spp) + "\n";
  s += "size: " + std::to_string(r.width) + "x" + std::to_string(r.height) + "\n";
  s += "samples: " + std::to_string(info.range.first) + ":" + std::to_string(info.range.end) + "\n";
  s += "tile: " + std::to_string(info.range.tile) + "/" + std::to_string(info.range.tiles) + "\n";
  s += "aovs: " + (r.aovs.any() ? aov_list(r.aovs) : std::string("none")) + "\n";
  s += "settings: " + r.settings + "\n";
  s += "build: " + r.build + "\n";
  return s;
}

std::vector<size_t> tile_group_pixels(int width, int height, int tile, int tiles) {
  std::vector<size_t> pixels;
  if (tiles == 1) {
    pixels.resize(static_cast<size_t>(width) * static_cast<size_t>(height));
    std::iota(pixels.begin(), pixels.end(), size_t{0});
    return pixels;
  }
  const int tiles_x = (width + kPartTileSize - 1) / kPartTileSize;
  const int tiles_y = (height + kPartTileSize - 1) / kPartTileSize;
  for (int t = tile; t < tiles_x * tiles_y; t += tiles) {
    const int x0 = (t % tiles_x) * kPartTileSize, y0 = (t / tiles_x) * kPartTileSize;
    for (int y = y0; y < std::min(y0 + kPartTileSize, height); ++y) {
      for (int x = x0; x < std::min(x0 + kPartTileSize, width); ++x) {
        pixels.push_back(static_cast<size_t>(y) * static_cast<size_t>(width) +
                         static_cast<size_t>(x));
      }
    }
  }
  return pixels;
}

PackedShape packed_shape(int width, int height, int tile, int tiles) {
  if (tiles == 1) {
    return {width, height, static_cast<size_t>(width) * static_cast<size_t>(height)};
  }
  // The pixel count without listing the pixels: full tiles plus the clipped ones at the edges.
  const int tiles_x = (width + kPartTileSize - 1) / kPartTileSize;
  const int tiles_y = (height + kPartTileSize - 1) / kPartTileSize;
  size_t pixels = 0;
  for (int t = tile; t < tiles_x * tiles_y; t += tiles) {
    const int x0 = (t % tiles_x) * kPartTileSize, y0 = (t / tiles_x) * kPartTileSize;
    pixels += static_cast<size_t>(std::min(kPartTileSize, width - x0)) *
              static_cast<size_t>(std::min(kPartTileSize, height - y0));
  }
  constexpr size_t kRow = size_t{kPartTileSize} * kPartTileSize;
  const size_t rows = std::max<size_t>(1, (pixels + kRow - 1) / kRow);
  return {static_cast<int>(kRow), static_cast<int>(rows), pixels};
}

Film pack_part(const Film& film, int tile, int tiles) {
  const PackedShape shape = packed_shape(film.width(), film.height(), tile, tiles);
  const std::vector<size_t> pixels = tile_group_pixels(film.width(), film.height(), tile, tiles);
  Film packed(shape.width, shape.height, film.aovs());
  packed.set_layout(film.first_sample(), film.end_sample(), film.nodes());
  for (size_t k = 0; k < film.layer_count(); ++k) {
    const glm::vec4* src = film.sums(k);
    glm::vec4* dst = packed.sums(k);
    for (size_t j = 0; j < pixels.size(); ++j) dst[j] = src[pixels[j]];
    if (film.aovs().any()) {
      const AovSums* asrc = film.aov_sums(k);
      AovSums* adst = packed.aov_sums(k);
      for (size_t j = 0; j < pixels.size(); ++j) adst[j] = asrc[pixels[j]];
    }
  }
  if (film.has_splats()) {
    // Splats land anywhere in the image: only a whole-image part holds them (RenderJob refuses
    // --tile with bdpt's light tracing).
    if (tiles != 1) {
      throw Error("part", "a tile part cannot hold a light image (bdpt's light tracing)");
    }
    packed.enable_splats();
    packed.splats().data() = film.splats().data();
  }
  return packed;
}

}  // namespace tritrace

// Assembling a film from its tile parts (film_parts.h).
#include "film_parts.h"

#include <algorithm>

#include "tritrace/error.h"
#include "tritrace/render/renderer.h"

namespace tritrace::view {

bool in_tile_part(int x, int y, int width, int part, int parts) {
  const int tiles_x = (width + kPartTileSize - 1) / kPartTileSize;
  const int tile = (y / kPartTileSize) * tiles_x + x / kPartTileSize;
  return tile % parts == part;
}

void copy_tile_part(const Film& part_film, int part, int parts, Film& whole) {
  const int w = part_film.width(), h = part_film.height();
  if (whole.first_sample() == whole.end_sample()) {
    whole = Film(w, h, part_film.aovs());
    whole.set_layout(part_film.first_sample(), part_film.end_sample(), part_film.nodes());
  } else if (whole.width() != w || whole.height() != h || !(whole.aovs() == part_film.aovs()) ||
             whole.first_sample() != part_film.first_sample() ||
             whole.end_sample() != part_film.end_sample()) {
    throw Error("film", "a tile part's film differs from the others in size, AOVs or samples");
  }
  for (size_t layer = 0; layer < part_film.layer_count(); ++layer) {
    const glm::vec4* from = part_film.sums(layer);
    glm::vec4* to = whole.sums(layer);
    const AovSums* from_aovs = part_film.aov_sums(layer);
    AovSums* to_aovs = whole.aov_sums(layer);
    // Whole tiles at a time: a tile row of a part is contiguous in every layer.
    for (int y0 = 0; y0 < h; y0 += kPartTileSize) {
      for (int x0 = 0; x0 < w; x0 += kPartTileSize) {
        if (!in_tile_part(x0, y0, w, part, parts)) continue;
        const int x1 = std::min(x0 + kPartTileSize, w), y1 = std::min(y0 + kPartTileSize, h);
        for (int y = y0; y < y1; ++y) {
          const size_t row = static_cast<size_t>(y) * static_cast<size_t>(w);
          std::copy(from + row + x0, from + row + x1, to + row + x0);
          if (from_aovs != nullptr) {
            std::copy(from_aovs + row + x0, from_aovs + row + x1, to_aovs + row + x0);
          }
        }
      }
    }
  }
}

}  // namespace tritrace::view

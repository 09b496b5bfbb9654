// A part of a render (a sample range of a tile part) and its film, which holds only the part's
// pixels: a tile part's pixels packed tile after tile, so that N tile parts together hold one
// image's worth of sums, not N.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "tritrace/distributed/render_identity.h"
#include "tritrace/render/film.h"

namespace tritrace {

// Which part of the render a partial film holds: samples [first, end) of the tiles of part
// tile / tiles (RenderOptions::tile_part; 0 / 1 is the whole image).
struct PartRange {
  uint32_t first = 0;
  uint32_t end = 0;
  int tile = 0;
  int tiles = 1;
  std::string describe() const;  // "samples [0, 64) of tile 1/4"
};

struct PartInfo {
  RenderIdentity render;
  PartRange range;
};

// The lines `tritrace info` prints for a part: "key: value".
std::string describe_part(const PartInfo& info);

// The pixels (y * width + x) of tile part `tile` of `tiles`, tile by tile, row by row in a tile.
std::vector<size_t> tile_group_pixels(int width, int height, int tile, int tiles);

// How a part's film lays out its pixels: pixel j of tile_group_pixels at (j % width, j / width),
// the last row padded with zeros. The whole image (tiles == 1) keeps its own shape; a tile part is
// packed 256 pixels to a row, so that every full 16 x 16 tile is one row.
struct PackedShape {
  int width = 0;
  int height = 0;
  size_t pixels = 0;  // the part's pixels, at most width x height
};
PackedShape packed_shape(int width, int height, int tile, int tiles);

// The part's pixels of `film` (an image-sized film), in a film of packed_shape's size.
Film pack_part(const Film& film, int tile, int tiles);

}  // namespace tritrace

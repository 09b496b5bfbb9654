// A whole film assembled from the films of its tile parts (RenderOptions::tile_part), in the
// viewer's memory: how it renders an adaptive level a few tiles per frame and still shows exactly
// the film one adaptive render makes.
#pragma once

#include "tritrace/render/film.h"

namespace tritrace::view {

// Whether pixel (x, y) of an image `width` wide belongs to tile part `part` of `parts`: the
// renderer's interleaving of its kPartTileSize tiles (row-major tile t is in part t % parts).
bool in_tile_part(int x, int y, int width, int part, int parts);

// Copies the pixels of tile part `part` of `parts` from `part_film` (a render of that part alone,
// from sample 0) into `whole`, every layer with its AOV sums. An empty `whole` (no samples) takes
// part_film's size, AOVs and sample layout first; otherwise they must match (throws
// Error("film", ...)). Once every part is copied, `whole` holds the sums the render of all parts
// at once makes, bit for bit: each pixel's sums depend only on its own samples.
void copy_tile_part(const Film& part_film, int part, int parts, Film& whole);

}  // namespace tritrace::view

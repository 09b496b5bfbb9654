// The partial-film file: a part's packed film (distributed/part.h) as an OpenEXR file, one 32-bit
// float channel per layer and value, with tritrace.* attributes naming the render and the part.
// Every header is checked before anything is allocated for it: image size, data window, channels
// and block nodes against each other and the data window against the file's size.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "tritrace/distributed/part.h"
#include "tritrace/render/film.h"

namespace tritrace {

// The file's bytes: channels layerK.R/G/B/W, layerK.albedo.R ..., layerK.normal.X ..., layerK.Z,
// ZIP compressed. `packed` is pack_part's film of the part. Throws Error("exr", ...) if OpenEXR
// fails.
std::vector<uint8_t> encode_partial_film(const Film& packed, const PartInfo& info);

struct PartialFilm {
  PartInfo info;
  Film film;  // packed: pixel j is tile_group_pixels(...)[j]
};

// Reads a partial film; Error(name, reason) when the bytes are not a tritrace partial film, its
// header is inconsistent or impossible for its size, or OpenEXR cannot decode it.
PartialFilm decode_partial_film(std::span<const uint8_t> bytes, const std::string& name);
PartialFilm read_partial_film(const std::string& path);
// Only the header (the file's first bytes, fully checked).
PartInfo read_part_info(const std::string& path);

}  // namespace tritrace

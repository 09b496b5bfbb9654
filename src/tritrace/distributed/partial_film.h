// Partial films: the unnormalised block sums of one part of a render (a sample range, a set of
// tiles, or both) in an OpenEXR file with metadata naming the render, and their merge into the
// one-process image. Distributed code sits at the edge: it calls the renderer, never the reverse.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "tritrace/render/film.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/loaded_scene.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// What names a render: everything that changes its pixels. Two parts merge only when their
// identities are equal.
struct RenderIdentity {
  std::string hash;      // 16 hex digits over the scene's data and `settings`
  std::string settings;  // "integrator=path spp=64 ...", every pixel-changing setting
  std::string integrator;
  uint64_t seed = 0;
  uint32_t spp = 1;  // the render's total samples per pixel (1 for the lab integrator)
  int width = 0;
  int height = 0;
  AovSet aovs;

  bool operator==(const RenderIdentity& o) const {
    return hash == o.hash && settings == o.settings && aovs.albedo == o.aovs.albedo &&
           aovs.normal == o.aovs.normal && aovs.depth == o.aovs.depth;
  }
};

// The identity of rendering `scene` with `spec` and `options` through the named accel and kernel
// (kernels differ in which edge hits they report, so they are part of it).
RenderIdentity render_identity(const Scene& scene, const IntegratorSpec& spec,
                               const RenderOptions& options, std::string_view accel,
                               std::string_view kernel, const AovSet& aovs);

// Which part of the render a partial film holds: samples [first, end) of the tiles of part
// tile / tiles (RenderOptions::tile_part; 0 / 1 is the whole image).
struct PartRange {
  uint32_t first = 0;
  uint32_t end = 0;
  int tile = 0;
  int tiles = 1;
  std::string describe() const;  // "samples [0, 64), tile 1/4"
};

struct PartInfo {
  RenderIdentity render;
  PartRange range;
};

// The file's bytes: one float channel per layer and value (layerK.R/G/B/W, layerK.albedo.R ...,
// layerK.normal.X ..., layerK.Z), ZIP compressed, with the identity, the range and the film's block
// nodes as tritrace.* string attributes. Throws Error("exr", ...) if OpenEXR fails.
std::vector<uint8_t> encode_partial_film(const Film& film, const PartInfo& info);

struct PartialFilm {
  PartInfo info;
  Film film;
};
// Reads a partial film; Error(path, reason) when the file cannot be read, is not a tritrace partial
// film, or its metadata and channels disagree.
PartInfo read_part_info(const std::string& path);
PartialFilm read_partial_film(const std::string& path);

// The lines `tritrace info` prints for a part: "key: value".
std::string describe_part(const PartInfo& info);

// Checks that `parts` (their infos, in the order given, with their paths) are of one render and
// cover every tile's samples [0, spp) exactly once; throws Error naming the foreign part, the
// overlap or what is missing. Returns the parts' indices in merge order (tile, then first sample).
std::vector<size_t> plan_merge(const std::vector<std::string>& paths,
                               const std::vector<PartInfo>& parts);

// Reads the parts one at a time and combines their layers in the fixed order of the block tree: the
// film of the whole render, bit for bit what one process makes.
Film merge_parts(const std::vector<std::string>& paths);

// The merge itself, for parts already planned (plan_merge's order): load(i) gives part i's film.
// MPI's rank 0 merges the units it gathered through it.
Film merge_planned(const std::vector<PartInfo>& infos, const std::vector<size_t>& order,
                   const std::function<Film(size_t)>& load);

// The pixels (y * width + x) of tile part `tile` of `tiles`, tile by tile, row by row in a tile.
std::vector<size_t> tile_group_pixels(int width, int height, int tile, int tiles);

}  // namespace tritrace

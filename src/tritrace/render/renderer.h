// Renderer: splits the image into tiles and shades them on all cores with TBB, one batch per tile
// and sample index. Every sample depends only on (seed, pixel, sample index), never on the thread
// or tile, so the image is the same bit for bit whatever the thread count and tile size.
#pragma once

#include <cstdint>

#include "tritrace/accel/accel.h"
#include "tritrace/image/image.h"
#include "tritrace/render/film.h"
#include "tritrace/render/integrator.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// Told after every finished tile, from the worker thread that finished it: an implementation must
// be thread-safe, must not throw, and should return quickly (a clock read and a compare), since it
// runs once per tile inside the render loop.
class RenderProgress {
 public:
  virtual ~RenderProgress() = default;
  virtual void tiles_done(int done, int total) noexcept = 0;
};

struct RenderOptions {
  int threads = 0;                     // 0: all cores
  int tile_size = 16;                  // tile_size^2 must not exceed kMaxBatch
  RenderProgress* progress = nullptr;  // optional, not owned
  // Samples [first_sample, first_sample + spp) of every pixel. An integrator that takes one sample
  // through the pixel corner (the lab's) renders exactly one whatever these say.
  uint32_t spp = 1;
  uint32_t first_sample = 0;
  uint64_t seed = 0;                          // the Sampler's seed
  SamplerKind sampler = SamplerKind::kSobol;  // and its kind
  FilterKind filter = FilterKind::kBox;       // where in the pixel samples land, and their weights
  // Part tile_part of tile_parts (`--tile I/N`): only the 16 x 16 tiles t (row-major) with
  // t % tile_parts == tile_part are rendered (tile_size is then 16); the other pixels get no
  // samples. Interleaved tiles balance the parts' work, since neighbouring tiles cost about the
  // same.
  int tile_part = 0;
  int tile_parts = 1;
};

// The tile size of --tile parts.
inline constexpr int kPartTileSize = 16;

struct RenderStats {
  double milliseconds = 0.0;
  uint64_t rays = 0;     // primary and secondary rays traced
  uint64_t samples = 0;  // camera samples (paths): pixels x spp
  uint32_t spp = 0;      // samples per pixel rendered
  // Threads that rendered at least one tile: RenderOptions::threads for an image with enough
  // tiles, fewer for a tiny one (or, rarely, when a thread started after the last tile was taken).
  int threads = 0;

  double mrays_per_second() const {
    return milliseconds > 0.0 ? static_cast<double>(rays) / (milliseconds * 1e3) : 0.0;
  }
  double samples_per_second() const {
    return milliseconds > 0.0 ? static_cast<double>(samples) / (milliseconds * 1e-3) : 0.0;
  }
};

// The number of threads "all cores" means on this machine.
int default_thread_count();

// The image of `scene`: the film of options' samples, resolved (bit for bit, without the film's
// memory). options.first_sample must be a multiple of 8 (throws Error otherwise).
Image render(const Scene& scene, const Accel& accel, const Integrator& integrator,
             const RenderOptions& options = {}, RenderStats* stats = nullptr);

// Adds options' samples of every pixel to `film` (the camera's size), with the film's AOVs: how the
// viewer accumulates frame after frame, and how sample ranges are rendered apart. An empty film
// starts at options.first_sample, which must be a multiple of 8; a film that holds samples is
// continued at its end_sample() only. Throws Error("film", ...) otherwise.
void render_to_film(const Scene& scene, const Accel& accel, const Integrator& integrator,
                    Film& film, const RenderOptions& options = {}, RenderStats* stats = nullptr);

}  // namespace tritrace

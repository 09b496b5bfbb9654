// Renderer: splits the image into tiles and shades them on all cores with TBB. Every pixel depends
// only on its own ray, so the image is the same bit for bit whatever the thread count.
#pragma once

#include <cstdint>

#include "tritrace/accel/accel.h"
#include "tritrace/image/image.h"
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
};

struct RenderStats {
  double milliseconds = 0.0;
  uint64_t rays = 0;  // primary and secondary rays traced
  // Threads that rendered at least one tile: RenderOptions::threads for an image with enough
  // tiles, fewer for a tiny one (or, rarely, when a thread started after the last tile was taken).
  int threads = 0;

  double mrays_per_second() const {
    return milliseconds > 0.0 ? static_cast<double>(rays) / (milliseconds * 1e3) : 0.0;
  }
};

// The number of threads "all cores" means on this machine.
int default_thread_count();

Image render(const Scene& scene, const Accel& accel, const Integrator& integrator,
             const RenderOptions& options = {}, RenderStats* stats = nullptr);

}  // namespace tritrace

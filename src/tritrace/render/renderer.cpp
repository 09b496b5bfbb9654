// Tiles over a TBB task arena limited to the requested thread count.
#include "tritrace/render/renderer.h"

#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <chrono>

namespace tritrace {

namespace {

// Visits a tile's pixels in 4 x 4 blocks, row by row within a block, so that consecutive rays of a
// batch are neighbours in both directions: packets of 8 or 16 of them stay coherent.
template <typename Fn>
void for_each_pixel_in_blocks(int x0, int y0, int x1, int y1, Fn&& fn) {
  constexpr int kBlock = 4;
  for (int by = y0; by < y1; by += kBlock) {
    for (int bx = x0; bx < x1; bx += kBlock) {
      const int ey = std::min(by + kBlock, y1), ex = std::min(bx + kBlock, x1);
      for (int y = by; y < ey; ++y) {
        for (int x = bx; x < ex; ++x) fn(x, y);
      }
    }
  }
}

}  // namespace

int default_thread_count() {
  return std::max(1, tbb::info::default_concurrency());
}

Image render(const Scene& scene, const Accel& accel, const Integrator& integrator,
             const RenderOptions& options, RenderStats* stats) {
  const Camera& camera = scene.camera;
  const int width = camera.width();
  const int height = camera.height();
  const int tile = std::clamp(options.tile_size, 1, 16);
  static_assert(16 * 16 <= kMaxBatch);
  const int tiles_x = (width + tile - 1) / tile;
  const int tiles_y = (height + tile - 1) / tile;
  const int threads = options.threads > 0 ? options.threads : default_thread_count();

  Image image(width, height);
  std::atomic<uint64_t> rays{0};
  std::atomic<int> tiles_done{0};
  const int tiles_total = tiles_x * tiles_y;
  const auto start = std::chrono::steady_clock::now();

  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y), [&](const auto& range) {
      thread_local std::array<Ray, kMaxBatch> batch;  // per thread: Ray initialises its members
      std::array<glm::vec3, kMaxBatch> radiance;
      uint64_t traced = 0;
      for (int t = range.begin(); t != range.end(); ++t) {
        const int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
        const int x1 = std::min(x0 + tile, width), y1 = std::min(y0 + tile, height);
        size_t n = 0;
        for_each_pixel_in_blocks(x0, y0, x1, y1,
                                 [&](int x, int y) { batch[n++] = camera.primary_ray(x, y); });
        traced += integrator.radiance(std::span<const Ray>(batch.data(), n),
                                      std::span(radiance).first(n), scene, accel);
        n = 0;
        for_each_pixel_in_blocks(x0, y0, x1, y1,
                                 [&](int x, int y) { image.at(x, y) = radiance[n++]; });
        if (options.progress) {
          options.progress->tiles_done(tiles_done.fetch_add(1, std::memory_order_relaxed) + 1,
                                       tiles_total);
        }
      }
      rays.fetch_add(traced, std::memory_order_relaxed);
    });
  });

  const auto stop = std::chrono::steady_clock::now();
  if (stats) {
    stats->milliseconds = std::chrono::duration<double, std::milli>(stop - start).count();
    stats->rays = rays.load();
    stats->threads = threads;
  }
  return image;
}

}  // namespace tritrace

// Tiles over a TBB task arena of the requested thread count.
#include "tritrace/render/renderer.h"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <chrono>
#include <optional>
#include <vector>

#include "tritrace/parallel.h"

namespace tritrace {
namespace {

// Visits a tile in 4 x 4 pixel blocks (smaller at the tile's edges), fn(bx, by, ex, ey) for the
// block [bx, ex) x [by, ey), whose pixels are taken row by row: consecutive rays of a batch are
// neighbours in both directions, so packets of 8 or 16 of them stay coherent.
template <typename Fn>
void for_each_block(int x0, int y0, int x1, int y1, Fn&& fn) {
  constexpr int kBlock = 4;
  for (int by = y0; by < y1; by += kBlock) {
    for (int bx = x0; bx < x1; bx += kBlock) {
      fn(bx, by, std::min(bx + kBlock, x1), std::min(by + kBlock, y1));
    }
  }
}

}  // namespace

int default_thread_count() {
  return std::max(1, tbb::info::default_concurrency());
}

namespace {

// Renders every tile of the image once per sample index of options' range and hands each sample
// to sink(x, y, sample, weight), from the thread that owns the sample's tile: tiles are disjoint,
// so a sink may write its pixel without locking. Samples of a pixel arrive in sample order.
template <typename Sink>
void render_tiles(const Scene& scene, const Accel& accel, const Integrator& integrator,
                  const RenderOptions& options, const AovSet& aovs, Sink&& sink,
                  RenderStats* stats) {
  const Camera& camera = scene.camera;
  const int width = camera.width();
  const int height = camera.height();
  const int tile = std::clamp(options.tile_size, 1, 16);
  static_assert(size_t{16} * 16 <= kMaxBatch);
  const int tiles_x = (width + tile - 1) / tile;
  const int tiles_y = (height + tile - 1) / tile;
  const int threads = options.threads > 0 ? options.threads : default_thread_count();
  const bool corner = integrator.pixel_corner_only();
  const uint32_t first = corner ? 0 : options.first_sample;
  const uint32_t spp = corner ? 1 : options.spp;
  const PixelFilter filter(options.filter);

  std::atomic<uint64_t> rays{0};
  std::atomic<int> tiles_done{0};
  const int tiles_total = tiles_x * tiles_y;
  const auto start = std::chrono::steady_clock::now();

  // One task per thread, each taking tiles from a shared counter until none are left: tiles go to
  // whichever thread is free (balanced whatever each tile costs), and every pixel is still written
  // by exactly one tile.
  std::atomic<int> next_tile{0};
  // Marks the arena slots (threads) that rendered at least one tile, for the statistics: a thread
  // that joins after the last tile was taken did no work.
  std::vector<std::atomic<uint8_t>> slot_rendered(static_cast<size_t>(threads));
  auto run_tiles = [&] {
    // Per thread, reused by every tile: Ray and Sampler initialise their members.
    thread_local std::array<Ray, kMaxBatch> batch;
    thread_local std::array<Sampler, kMaxBatch> samplers;
    std::array<glm::vec3, kMaxBatch> radiance, albedo, normal;
    std::array<float, kMaxBatch> depth, weight;
    uint64_t traced = 0;
    bool rendered = false;
    for (int t = next_tile.fetch_add(1, std::memory_order_relaxed); t < tiles_total;
         t = next_tile.fetch_add(1, std::memory_order_relaxed)) {
      const int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
      const int x1 = std::min(x0 + tile, width), y1 = std::min(y0 + tile, height);
      for (uint32_t s = first; s < first + spp; ++s) {
        size_t n = 0;
        if (corner) {
          for_each_block(x0, y0, x1, y1, [&](int bx, int by, int ex, int ey) {
            camera.primary_rays(bx, by, ex, ey, batch.data() + n);
            n += static_cast<size_t>((ex - bx) * (ey - by));
          });
        } else {
          for_each_block(x0, y0, x1, y1, [&](int bx, int by, int ex, int ey) {
            for (int y = by; y < ey; ++y) {
              for (int x = bx; x < ex; ++x) {
                Sampler& sampler = samplers[n];
                if (sampler.seed() != options.seed || sampler.kind() != options.sampler) {
                  sampler = Sampler(options.seed, options.sampler);
                }
                sampler.start_pixel_sample(x, y, s);
                const glm::vec2 u = sampler.get_pixel_2d();
                const PixelFilter::Sample f = filter.sample(u.x, u.y);
                batch[n] =
                    camera.ray_through(static_cast<float>(x) + f.x, static_cast<float>(y) + f.y);
                weight[n] = f.weight;
                ++n;
              }
            }
          });
        }
        const size_t count = n;
        const SampleBatch in{std::span<const Ray>(batch.data(), count),
                             corner ? std::span<Sampler>() : std::span(samplers).first(count)};
        const SampleOutput out{
            std::span(radiance).first(count),
            aovs.albedo ? std::span(albedo).first(count) : std::span<glm::vec3>(),
            aovs.normal ? std::span(normal).first(count) : std::span<glm::vec3>(),
            aovs.depth ? std::span(depth).first(count) : std::span<float>()};
        traced += integrator.radiance(in, out, scene, accel);
        // The same block order as the rays: sample i of the batch is pixel (x, y).
        size_t i = 0;
        for_each_block(x0, y0, x1, y1, [&](int bx, int by, int ex, int ey) {
          for (int y = by; y < ey; ++y) {
            for (int x = bx; x < ex; ++x, ++i) {
              FilmSample sample;
              sample.radiance = radiance[i];
              if (aovs.albedo) sample.albedo = albedo[i];
              if (aovs.normal) sample.normal = normal[i];
              if (aovs.depth) sample.depth = depth[i];
              sink(x, y, sample, corner ? 1.0f : weight[i]);
            }
          }
        });
      }
      rendered = true;
      if (options.progress) {
        options.progress->tiles_done(tiles_done.fetch_add(1, std::memory_order_relaxed) + 1,
                                     tiles_total);
      }
    }
    rays.fetch_add(traced, std::memory_order_relaxed);
    const int slot = tbb::this_task_arena::current_thread_index();
    if (rendered && slot >= 0 && slot < threads) {
      slot_rendered[static_cast<size_t>(slot)].store(1, std::memory_order_relaxed);
    }
  };
  // TBB gives all arenas together at most max_allowed_parallelism threads, by default the number of
  // cores; an arena asked for more prints "number of workers is currently limited" and gets fewer.
  // Raised for as long as the render runs, the limit lets the arena have every thread asked for.
  std::optional<tbb::global_control> allow_threads;
  const size_t limit =
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  if (static_cast<size_t>(threads) > limit) {
    allow_threads.emplace(tbb::global_control::max_allowed_parallelism,
                          static_cast<size_t>(threads));
  }
  tbb::task_arena arena(threads);
  arena.execute([&] {
    parallel::TaskGroup group;
    for (int t = 1; t < threads; ++t) group.run(run_tiles);
    run_tiles();
    group.wait();
  });

  const auto stop = std::chrono::steady_clock::now();
  if (stats) {
    stats->milliseconds = std::chrono::duration<double, std::milli>(stop - start).count();
    stats->rays = rays.load();
    stats->samples = static_cast<uint64_t>(width) * static_cast<uint64_t>(height) * spp;
    stats->spp = spp;
    stats->threads = static_cast<int>(std::count_if(
        slot_rendered.begin(), slot_rendered.end(),
        [](const std::atomic<uint8_t>& r) { return r.load(std::memory_order_relaxed) != 0; }));
  }
}

}  // namespace

void render_to_film(const Scene& scene, const Accel& accel, const Integrator& integrator,
                    Film& film, const RenderOptions& options, RenderStats* stats) {
  render_tiles(
      scene, accel, integrator, options, film.aovs(),
      [&](int x, int y, const FilmSample& sample, float weight) { film.add(x, y, sample, weight); },
      stats);
}

Image render(const Scene& scene, const Accel& accel, const Integrator& integrator,
             const RenderOptions& options, RenderStats* stats) {
  if (integrator.pixel_corner_only()) {
    // One unit-weight sample per pixel: the pixel is the sample, written straight to the image
    // (what a film would resolve to, bit for bit, without its sums).
    Image image(scene.camera.width(), scene.camera.height());
    render_tiles(
        scene, accel, integrator, options, AovSet{},
        [&](int x, int y, const FilmSample& sample, float) { image.at(x, y) = sample.radiance; },
        stats);
    return image;
  }
  Film film(scene.camera.width(), scene.camera.height());
  render_to_film(scene, accel, integrator, film, options, stats);
  return film.resolve();
}

}  // namespace tritrace

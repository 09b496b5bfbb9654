// Tiles over a TBB task arena of the requested thread count.
#include "tritrace/render/renderer.h"

#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "tritrace/error.h"
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

// Visits the pixels of [x0, x1) x [y0, y1) in the batch's block order: fn(slot, film index).
template <typename Fn>
void for_each_slot(int x0, int y0, int x1, int y1, int width, Fn&& fn) {
  size_t i = 0;
  for_each_block(x0, y0, x1, y1, [&](int bx, int by, int ex, int ey) {
    for (int y = by; y < ey; ++y) {
      for (int x = bx; x < ex; ++x, ++i) {
        fn(i, static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x));
      }
    }
  });
}

}  // namespace

int default_thread_count() {
  return std::max(1, tbb::info::default_concurrency());
}

double adaptive_error(const PixelMoments& m, uint32_t n) {
  if (n < 2 || !(m.w > 0.0)) return std::numeric_limits<double>::infinity();
  const double mean = m.x / m.w;
  const double spread = std::max(0.0, m.xx - 2.0 * mean * m.xw + mean * mean * m.ww);
  const double variance = spread / (m.w * m.w) * static_cast<double>(n) / (n - 1.0);
  return std::sqrt(variance / std::max(mean, kAdaptiveDarkFloor));
}

double neighbourhood_error(std::span<const PixelMoments* const> neighbours) {
  if (neighbours.empty()) return std::numeric_limits<double>::infinity();
  double sum = 0.0;
  for (const PixelMoments* m : neighbours) {
    const double e = adaptive_error(*m, kAdaptivePilotSpp);
    sum += e * e;
  }
  return std::sqrt(sum / static_cast<double>(neighbours.size()));
}

uint32_t adaptive_budget(double error, double threshold) {
  uint32_t n = kAdaptivePilotSpp;
  // The first n = kAdaptivePilotSpp 2^k with n >= kAdaptivePilotSpp e / T (strictly above).
  while (n < kAdaptiveMostBudget &&
         !(error * (static_cast<double>(kAdaptivePilotSpp) / n) < threshold)) {
    n *= 2;
  }
  return n;
}

size_t AdaptiveState::active_pixels() const {
  return static_cast<size_t>(std::count_if(budget.begin(), budget.end(),
                                           [&](uint32_t b) { return b == 0 || b > end_sample; }));
}

namespace {

// A thread's sums for the pixels of the tile it renders: slot k of pixel i (in the batch's block
// order) is the value of the tile's BlockCounter node k, and the slot after the last node the
// block being summed.
struct TileSlots {
  static constexpr size_t kSlots = BlockCounter::kMaxNodes + 1;
  std::vector<glm::vec4> sums;
  std::vector<AovSums> aovs;

  void reserve(bool with_aovs) {
    if (sums.empty()) sums.resize(kSlots * kMaxBatch);
    if (with_aovs && aovs.empty()) aovs.resize(kSlots * kMaxBatch);
  }
  glm::vec4* slot(size_t k) { return sums.data() + k * kMaxBatch; }
  AovSums* aov_slot(size_t k) { return aovs.data() + k * kMaxBatch; }
};

// Renders every tile of options' part of the image once per sample index of [first, first + spp)
// and sums the samples of each pixel by the block tree (render/sample_blocks.h), starting from the
// counter `nodes_before` (the nodes a film already holds; the partial block too when first is not a
// multiple of 8). target.load(x0, y0, x1, y1, slots) fills a tile's slots before its samples,
// target.store(x0, y0, x1, y1, slots, layers) takes them after, from the thread that owns the
// tile: tiles are disjoint, so neither needs a lock.
template <typename Target>
void render_tiles(const Scene& scene, const Accel& accel, const Integrator& integrator,
                  const RenderOptions& options, const AovSet& aovs,
                  const BlockCounter& nodes_before, uint32_t first, uint32_t spp, Target& target,
                  SplatBuffer* splats, const SplatPass* splat_pass, RenderStats* stats) {
  const Camera& camera = scene.camera;
  const int width = camera.width();
  const int height = camera.height();
  const bool corner = integrator.pixel_corner_only();
  const bool adaptive = options.noise_threshold > 0.0f && !corner;
  const bool tile_part = options.tile_parts > 1;
  // Adaptive sampling's decisions read a pixel's neighbours within its 16 x 16 tile.
  const int tile =
      tile_part || adaptive ? kPartTileSize : std::clamp(options.tile_size, 1, kPartTileSize);
  static_assert(size_t{16} * 16 <= kMaxBatch);
  const int tiles_x = (width + tile - 1) / tile;
  const int tiles_y = (height + tile - 1) / tile;
  const int threads = options.threads > 0 ? options.threads : default_thread_count();
  const bool lens = camera.has_lens();
  const uint32_t end = first + spp;
  const PixelFilter filter(options.filter);
  AdaptiveState* const state = adaptive ? options.adaptive_state : nullptr;
  assert(!adaptive || first == 0 || (state && state->end_sample == first));
  // A part renders tiles part, part + parts, ...: neighbouring tiles cost about the same, so
  // interleaving them balances the parts' work whatever the scene.
  const int part = tile_part ? options.tile_part : 0;
  const int stride = tile_part ? options.tile_parts : 1;
  std::atomic<uint64_t> rays{0};
  std::atomic<uint64_t> samples_taken{0};
  std::atomic<int> tiles_done{0};
  const int tiles_all = tiles_x * tiles_y;
  const int tiles_total = tiles_all > part ? (tiles_all - part + stride - 1) / stride : 0;
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
    thread_local TileSlots slots;
    slots.reserve(aovs.any());
    std::array<glm::vec3, kMaxBatch> radiance, albedo, normal;
    std::array<float, kMaxBatch> depth, weight;
    // Adaptive sampling: which of the tile's pixels (by slot) still take samples, their running
    // sums, and the slot of each ray of the batch.
    thread_local std::array<uint8_t, kMaxBatch> active;
    thread_local std::array<PixelMoments, kMaxBatch> moments;  // over the pilot
    thread_local std::array<uint32_t, kMaxBatch> budget;       // 0: not yet set
    thread_local std::array<uint16_t, kMaxBatch> slot_xy;      // slot of tile pixel (x, y)
    thread_local std::array<uint16_t, kMaxBatch> slot_of;
    thread_local std::array<uint32_t, kMaxBatch> pixel_of;  // sample i's pixel, for splats
    // The camera's numbers, drawn for the whole batch: row r holds dimension r of every sample
    // (rows 2 and 3 only with a lens); get_2d_groups_batch writes up to 8 cells past the batch.
    constexpr size_t kCameraStride = kMaxBatch + 8;
    thread_local std::array<float, 4 * kCameraStride> camera_u;
    thread_local std::array<Sampler*, kMaxBatch> drawing;
    thread_local std::array<int, kMaxBatch> sample_x, sample_y;
    uint64_t traced = 0, taken = 0;
    bool rendered = false;
    for (int k = next_tile.fetch_add(1, std::memory_order_relaxed); k < tiles_total;
         k = next_tile.fetch_add(1, std::memory_order_relaxed)) {
      const int t = part + k * stride;
      const int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
      const int x1 = std::min(x0 + tile, width), y1 = std::min(y0 + tile, height);
      const size_t pixels = static_cast<size_t>((x1 - x0) * (y1 - y0));
      BlockCounter counter = nodes_before;
      target.load(x0, y0, x1, y1, slots);
      if (adaptive && state && first > 0) {
        for_each_slot(x0, y0, x1, y1, width, [&](size_t i, size_t p) {
          moments[i] = state->moments[p];
          budget[i] = state->budget[p];
          active[i] = budget[i] == 0 || first < budget[i];
        });
      } else {
        std::fill_n(active.begin(), pixels, uint8_t{1});
        if (adaptive) {
          std::fill_n(moments.begin(), pixels, PixelMoments{});
          std::fill_n(budget.begin(), pixels, 0u);
        }
      }
      if (first % kSampleBlock == 0) {
        std::fill_n(slots.slot(counter.size()), pixels, glm::vec4(0.0f));
        if (aovs.any()) std::fill_n(slots.aov_slot(counter.size()), pixels, AovSums{});
      }
      for (uint32_t s = first; s < end; ++s) {
        size_t n = 0;
        if (corner) {
          for_each_block(x0, y0, x1, y1, [&](int bx, int by, int ex, int ey) {
            camera.primary_rays(bx, by, ex, ey, batch.data() + n);
            n += static_cast<size_t>((ex - bx) * (ey - by));
          });
        } else {
          size_t slot = 0;
          for_each_block(x0, y0, x1, y1, [&](int bx, int by, int ex, int ey) {
            for (int y = by; y < ey; ++y) {
              for (int x = bx; x < ex; ++x, ++slot) {
                if (!active[slot]) continue;
                slot_of[n] = static_cast<uint16_t>(slot);
                Sampler& sampler = samplers[n];
                if (sampler.seed() != options.seed || sampler.kind() != options.sampler) {
                  sampler = Sampler(options.seed, options.sampler);
                }
                sampler.start_pixel_sample(x, y, s);
                drawing[n] = &sampler;
                sample_x[n] = x;
                sample_y[n] = y;
                pixel_of[n] = static_cast<uint32_t>(y) * static_cast<uint32_t>(width) +
                              static_cast<uint32_t>(x);
                ++n;
              }
            }
          });
          // The pixel position (get_pixel_2d) and, with a lens, the lens point (get_lens_2d) of
          // every sample at once: the same numbers as drawing them sample by sample.
          if (lens) {
            Sampler::get_2d_groups_batch<2>(drawing.data(), n, camera_u.data(), kCameraStride);
          } else {
            Sampler::get_2d_groups_batch<1>(drawing.data(), n, camera_u.data(), kCameraStride);
          }
          for (size_t i = 0; i < n; ++i) {
            const PixelFilter::Sample f = filter.sample(camera_u[i], camera_u[kCameraStride + i]);
            const float px = static_cast<float>(sample_x[i]) + f.x;
            const float py = static_cast<float>(sample_y[i]) + f.y;
            batch[i] = lens ? camera.lens_ray(px, py,
                                              glm::vec2(camera_u[2 * kCameraStride + i],
                                                        camera_u[3 * kCameraStride + i]))
                            : camera.ray_through(px, py);
            weight[i] = f.weight;
          }
        }
        const size_t count = n;
        taken += count;
        // The slot of ray i: i itself unless adaptive sampling has stopped pixels of the tile.
        const bool all = count == pixels;
        const auto slot_at = [&](size_t i) -> size_t { return all ? i : slot_of[i]; };
        const SampleBatch in{std::span<const Ray>(batch.data(), count),
                             corner ? std::span<Sampler>() : std::span(samplers).first(count),
                             corner ? std::span<const uint32_t>()
                                    : std::span<const uint32_t>(pixel_of).first(count)};
        const SampleOutput out{
            std::span(radiance).first(count),
            aovs.albedo ? std::span(albedo).first(count) : std::span<glm::vec3>(),
            aovs.normal ? std::span(normal).first(count) : std::span<glm::vec3>(),
            aovs.depth ? std::span(depth).first(count) : std::span<float>(),
            splats,
            splat_pass};
        if (count > 0) traced += integrator.radiance(in, out, scene, accel);
        // The same block order as the rays: sample i of the batch is slot i.
        glm::vec4* open = slots.slot(counter.size());
        if (corner) {
          // The lab's one unit-weight sample is the pixel: kept as it is, not added to zero.
          for (size_t i = 0; i < count; ++i) open[i] = glm::vec4(radiance[i], 1.0f);
        } else {
          for (size_t i = 0; i < count; ++i) {
            open[slot_at(i)] += glm::vec4(weight[i] * radiance[i], weight[i]);
          }
          if (adaptive && s < kAdaptivePilotSpp) {
            for (size_t i = 0; i < count; ++i) {
              const glm::vec3 l = radiance[i];
              moments[slot_at(i)].add(weight[i], 0.2126 * l.x + 0.7152 * l.y + 0.0722 * l.z);
            }
          }
        }
        if (aovs.any()) {
          AovSums* open_aovs = slots.aov_slot(counter.size());
          const float* w = corner ? nullptr : weight.data();
          for (size_t i = 0; i < count; ++i) {
            const float wi = w ? w[i] : 1.0f;
            AovSums& a = open_aovs[slot_at(i)];
            if (aovs.albedo) a.albedo += wi * albedo[i];
            if (aovs.normal) a.normal += wi * normal[i];
            if (aovs.depth) a.depth += wi * depth[i];
            if (aovs.spp) a.samples += 1.0f;
          }
          // The even half buffer, by the parity of the global sample index (a part starting at
          // sample 8 continues the same split), summed exactly as the total is above.
          if (aovs.variance && s % 2 == 0) {
            for (size_t i = 0; i < count; ++i) {
              const float wi = w ? w[i] : 1.0f;
              open_aovs[slot_at(i)].even += glm::vec4(wi * radiance[i], wi);
            }
          }
        }
        if ((s + 1) % kSampleBlock == 0) {
          // The block is complete: it becomes a node, and pairs of siblings merge.
          const int merges = counter.push(BlockNode{0, s / kSampleBlock});
          size_t n = counter.size() + static_cast<size_t>(merges);
          for (int m = 0; m < merges; ++m, --n) {
            glm::vec4* left = slots.slot(n - 2);
            const glm::vec4* right = slots.slot(n - 1);
            for (size_t i = 0; i < pixels; ++i) left[i] = left[i] + right[i];
            if (aovs.any()) {
              AovSums* left_aovs = slots.aov_slot(n - 2);
              const AovSums* right_aovs = slots.aov_slot(n - 1);
              for (size_t i = 0; i < pixels; ++i) left_aovs[i] = left_aovs[i] + right_aovs[i];
            }
          }
          std::fill_n(slots.slot(counter.size()), pixels, glm::vec4(0.0f));
          if (aovs.any()) std::fill_n(slots.aov_slot(counter.size()), pixels, AovSums{});
        }
        const uint32_t taken_so_far = s + 1;
        // After the pilot, each pixel's budget from its neighbours' pilot samples (never its
        // own). Set at the last sample too when a later pass continues from it.
        if (adaptive && taken_so_far == kAdaptivePilotSpp && (taken_so_far < end || state)) {
          const int w = x1 - x0, h = y1 - y0;
          size_t k = 0;
          for_each_block(x0, y0, x1, y1, [&](int bx, int by, int ex, int ey) {
            for (int y = by; y < ey; ++y) {
              for (int x = bx; x < ex; ++x, ++k) {
                slot_xy[static_cast<size_t>((y - y0) * w + (x - x0))] = static_cast<uint16_t>(k);
              }
            }
          });
          for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
              constexpr int r = kAdaptiveRadius;
              std::array<const PixelMoments*, (2 * r + 1) * (2 * r + 1) - 1> around;
              size_t n_around = 0;
              for (int dy = -r; dy <= r; ++dy) {
                for (int dx = -r; dx <= r; ++dx) {
                  const int nx = x + dx, ny = y + dy;
                  if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
                  around[n_around++] = &moments[slot_xy[static_cast<size_t>(ny * w + nx)]];
                }
              }
              const size_t i = slot_xy[static_cast<size_t>(y * w + x)];
              budget[i] = adaptive_budget(neighbourhood_error(std::span(around.data(), n_around)),
                                          options.noise_threshold);
            }
          }
        }
        if (adaptive && taken_so_far >= kAdaptivePilotSpp) {
          for (size_t i = 0; i < pixels; ++i) {
            if (budget[i] != 0 && taken_so_far >= budget[i]) active[i] = 0;
          }
        }
      }
      if (adaptive && state) {
        for_each_slot(x0, y0, x1, y1, width, [&](size_t i, size_t p) {
          state->moments[p] = moments[i];
          state->budget[p] = budget[i];
        });
      }
      const size_t layers = counter.size() + (end % kSampleBlock != 0 ? 1 : 0);
      target.store(x0, y0, x1, y1, slots, layers);
      rendered = true;
      if (options.progress) {
        options.progress->tiles_done(tiles_done.fetch_add(1, std::memory_order_relaxed) + 1,
                                     tiles_total);
      }
    }
    rays.fetch_add(traced, std::memory_order_relaxed);
    samples_taken.fetch_add(taken, std::memory_order_relaxed);
    const int slot = tbb::this_task_arena::current_thread_index();
    if (rendered && slot >= 0 && slot < threads) {
      slot_rendered[static_cast<size_t>(slot)].store(1, std::memory_order_relaxed);
    }
  };
  parallel::on_threads(threads, run_tiles);

  const auto stop = std::chrono::steady_clock::now();
  if (stats) {
    stats->milliseconds = std::chrono::duration<double, std::milli>(stop - start).count();
    stats->rays = rays.load();
    uint64_t pixels = 0;
    for (int k = 0; k < tiles_total; ++k) {
      const int t = part + k * stride;
      const int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
      pixels += static_cast<uint64_t>(std::min(tile, width - x0)) *
                static_cast<uint64_t>(std::min(tile, height - y0));
    }
    stats->samples = samples_taken.load();
    stats->pixels = pixels;
    stats->spp = spp;
    stats->threads = static_cast<int>(std::count_if(
        slot_rendered.begin(), slot_rendered.end(),
        [](const std::atomic<uint8_t>& r) { return r.load(std::memory_order_relaxed) != 0; }));
  }
}

}  // namespace

namespace {

// Tiles whose sums continue a film's layers (read from the old layout) and replace them (written
// in the new one, whose layers the film has already allocated).
struct FilmTarget {
  Film& film;
  size_t old_layers;

  void load(int x0, int y0, int x1, int y1, TileSlots& slots) const {
    for (size_t k = 0; k < old_layers; ++k) {
      const glm::vec4* sums = film.sums(k);
      glm::vec4* slot = slots.slot(k);
      for_each_slot(x0, y0, x1, y1, film.width(), [&](size_t i, size_t p) { slot[i] = sums[p]; });
      if (const AovSums* aovs = film.aov_sums(k)) {
        AovSums* aov_slot = slots.aov_slot(k);
        for_each_slot(x0, y0, x1, y1, film.width(),
                      [&](size_t i, size_t p) { aov_slot[i] = aovs[p]; });
      }
    }
  }
  void store(int x0, int y0, int x1, int y1, TileSlots& slots, size_t layers) const {
    for (size_t k = 0; k < layers; ++k) {
      glm::vec4* sums = film.sums(k);
      const glm::vec4* slot = slots.slot(k);
      for_each_slot(x0, y0, x1, y1, film.width(), [&](size_t i, size_t p) { sums[p] = slot[i]; });
      if (AovSums* aovs = film.aov_sums(k)) {
        const AovSums* aov_slot = slots.aov_slot(k);
        for_each_slot(x0, y0, x1, y1, film.width(),
                      [&](size_t i, size_t p) { aovs[p] = aov_slot[i]; });
      }
    }
  }
};

// Tiles resolved straight into an image: each pixel's layers added from the right, divided by the
// weight (what a film of the same samples resolves to, bit for bit, without its memory).
struct ImageTarget {
  Image& image;

  void load(int, int, int, int, TileSlots&) const {}
  void store(int x0, int y0, int x1, int y1, TileSlots& slots, size_t layers) const {
    size_t i = 0;
    for_each_block(x0, y0, x1, y1, [&](int bx, int by, int ex, int ey) {
      for (int y = by; y < ey; ++y) {
        for (int x = bx; x < ex; ++x, ++i) {
          image.at(x, y) = resolve_pixel(fold_from_right(slots.sums.data() + i, layers, kMaxBatch));
        }
      }
    });
  }
};

// Integrators that splat estimate each pixel's light image from every pixel's samples together
// (Integrator::splats): every pixel must take the same samples, uniformly over its area.
void check_splats(const Integrator& integrator, const RenderOptions& options) {
  if (!integrator.splats()) return;
  if (options.tile_parts > 1) {
    throw Error("render",
                "light tracing (bdpt) splats onto every pixel; a tile part cannot hold them");
  }
  if (options.filter != FilterKind::kBox) {
    throw Error("render", "light tracing (bdpt) has the camera's density for the box filter only");
  }
}

// render_to_film's work for samples that need no split into passes (below).
void render_film_samples(const Scene& scene, const Accel& accel, const Integrator& integrator,
                         Film& film, const RenderOptions& options, const SplatPass* splat_pass,
                         RenderStats* stats) {
  const bool corner = integrator.pixel_corner_only();
  const uint32_t first = corner ? 0 : options.first_sample;
  const uint32_t spp = corner ? 1 : options.spp;
  const bool empty = film.first_sample() == film.end_sample();
  if (empty ? first % kSampleBlock != 0 : first != film.end_sample()) {
    throw Error("film", empty
                            ? "samples must start at a multiple of " +
                                  std::to_string(kSampleBlock) + ", got " + std::to_string(first)
                            : "the film holds samples up to " + std::to_string(film.end_sample()) +
                                  ", not " + std::to_string(first));
  }
  AdaptiveState* const state =
      options.noise_threshold > 0.0f && !corner ? options.adaptive_state : nullptr;
  if (options.noise_threshold > 0.0f && !corner) {
    // A film continues only with the state its earlier passes left (its sums and decisions).
    const size_t pixels = static_cast<size_t>(film.width()) * static_cast<size_t>(film.height());
    const bool continues = state && !empty && first == film.end_sample() &&
                           state->end_sample == first && film.first_sample() == 0 &&
                           state->budget.size() == pixels;
    if (!continues && (first != 0 || !empty)) {
      throw Error("film",
                  "adaptive sampling renders a pixel's samples from 0, continued only with the "
                  "state of the passes before, not from " +
                      std::to_string(first));
    }
    if (state && first == 0) {
      *state =
          AdaptiveState{0, std::vector<PixelMoments>(pixels), std::vector<uint32_t>(pixels, 0)};
    }
  }
  if (empty) film.set_layout(first, first, {});
  const BlockCounter start(film.nodes());
  BlockCounter after = start;
  after.push_blocks(film.end_sample() / kSampleBlock, (first + spp) / kSampleBlock);
  const size_t old_layers = film.layer_count();
  film.reserve_layers(after.size() + 1);
  FilmTarget target{film, old_layers};
  if (integrator.splats()) film.enable_splats();
  render_tiles(scene, accel, integrator, options, film.aovs(), start, first, spp, target,
               integrator.splats() ? &film.splats() : nullptr, splat_pass, stats);
  if (state) state->end_sample = first + spp;
  film.set_layout(film.first_sample(), first + spp,
                  std::vector<BlockNode>(after.nodes().begin(), after.nodes().end()));
}

// The end of adaptive sampling's pass that sample `s` belongs to: the pilot [0, P), then
// [P 2^(k - 1), P 2^k) (P = kAdaptivePilotSpp), the counts at which budgets end, so that every
// pixel takes all of a pass's samples or none.
uint32_t adaptive_pass_end(uint32_t s) {
  uint32_t end = kAdaptivePilotSpp;
  while (end <= s && end < kAdaptiveMostBudget) end *= 2;
  return end;
}

// Adaptive sampling with an integrator that splats: a pixel's light image is an estimate over
// the light subpaths of every pixel that takes samples with it, so the samples are rendered pass
// by pass (adaptive_pass_end), the whole image's pilot before any budget is used, and each pass
// gets the counts of the pixels that take it (SplatPass; docs/BDPT.md, "Adaptive sampling").
// Passes continue the film and the state exactly as --time-limit's passes do, so the image is
// the same bits as one pass would give.
void render_film_in_passes(const Scene& scene, const Accel& accel, const Integrator& integrator,
                           Film& film, const RenderOptions& options, RenderStats* stats) {
  AdaptiveState own;
  RenderOptions pass = options;
  if (!pass.adaptive_state) pass.adaptive_state = &own;
  const AdaptiveState& state = *pass.adaptive_state;
  const size_t pixels = static_cast<size_t>(film.width()) * static_cast<size_t>(film.height());
  std::vector<uint8_t> active;
  RenderStats total;
  const uint32_t end = options.first_sample + options.spp;
  for (uint32_t at = options.first_sample; at < end;) {
    const uint32_t stop = std::min(end, adaptive_pass_end(at));
    SplatPass counts{.width = film.width(),
                     .height = film.height(),
                     .tile = kPartTileSize,
                     .radius = kAdaptiveRadius,
                     .pilot = at < kAdaptivePilotSpp};
    if (!counts.pilot) {
      // Every budget is set (the pilot is complete): the pixels whose budget goes past `at`.
      active.assign(pixels, 0);
      size_t taking = 0;
      for (size_t p = 0; p < pixels; ++p) {
        active[p] = state.budget[p] == 0 || at < state.budget[p];
        taking += active[p];
      }
      counts.active = active.data();
      counts.active_share =
          static_cast<float>(static_cast<double>(taking) / static_cast<double>(pixels));
    }
    pass.first_sample = at;
    pass.spp = stop - at;
    RenderStats one;
    render_film_samples(scene, accel, integrator, film, pass, &counts, &one);
    total.milliseconds += one.milliseconds;
    total.rays += one.rays;
    total.samples += one.samples;
    total.pixels = one.pixels;
    total.threads = std::max(total.threads, one.threads);
    at = stop;
  }
  total.spp = options.spp;
  if (stats) *stats = total;
}

}  // namespace

void render_to_film(const Scene& scene, const Accel& accel, const Integrator& integrator,
                    Film& film, const RenderOptions& options, RenderStats* stats) {
  check_splats(integrator, options);
  if (integrator.splats() && options.noise_threshold > 0.0f && !integrator.pixel_corner_only() &&
      options.spp > 0) {
    render_film_in_passes(scene, accel, integrator, film, options, stats);
  } else {
    render_film_samples(scene, accel, integrator, film, options, nullptr, stats);
  }
}

Image render(const Scene& scene, const Accel& accel, const Integrator& integrator,
             const RenderOptions& options, RenderStats* stats) {
  const bool corner = integrator.pixel_corner_only();
  const uint32_t first = corner ? 0 : options.first_sample;
  if (first % kSampleBlock != 0) {
    throw Error("render", "samples must start at a multiple of " + std::to_string(kSampleBlock) +
                              ", got " + std::to_string(first));
  }
  if (options.noise_threshold > 0.0f && !corner && first != 0) {
    throw Error("render", "adaptive sampling renders a pixel's samples from 0, not from " +
                              std::to_string(first));
  }
  check_splats(integrator, options);
  if (integrator.splats() && options.noise_threshold > 0.0f && !corner) {
    // Pass by pass through a film (render_film_in_passes), resolved as Film::resolve does.
    Film film(scene.camera.width(), scene.camera.height());
    RenderOptions one_go = options;
    one_go.adaptive_state = nullptr;
    render_to_film(scene, accel, integrator, film, one_go, stats);
    return film.resolve();
  }
  Image image(scene.camera.width(), scene.camera.height());
  ImageTarget target{image};
  RenderOptions one_go = options;
  one_go.adaptive_state = nullptr;  // no film to continue
  SplatBuffer splats;
  if (integrator.splats()) splats = SplatBuffer(image.width(), image.height());
  render_tiles(scene, accel, integrator, one_go, AovSet{}, BlockCounter(), first,
               corner ? 1 : options.spp, target, integrator.splats() ? &splats : nullptr, nullptr,
               stats);
  if (integrator.splats()) {
    // What Film::resolve adds, in the same operations.
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x) {
        image.at(x, y) = add_splats(image.at(x, y), splats.raw(x, y), options.spp);
      }
    }
  }
  return image;
}

}  // namespace tritrace

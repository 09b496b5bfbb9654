// The hot paths allocate nothing per ray and per tile. This binary replaces the global operator
// new with a counting one (so it is separate from the unit tests) and counts allocations around
// the calls that run per tile.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "tritrace/accel/make_accel.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/procedural.h"

namespace {
std::atomic<long> g_allocations{0};
}

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, std::align_val_t align) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  const std::size_t a = static_cast<std::size_t>(align);
  if (void* p = std::aligned_alloc(a, (size + a - 1) / a * a)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}

namespace tritrace {
namespace {

class HotPath : public ::testing::TestWithParam<AccelKind> {};

// Every 16 x 16 tile of the image, as the renderer runs them, through `integrator`.
uint64_t trace_all_tiles(const Scene& scene, const Accel& accel, const Integrator& integrator,
                         std::vector<Ray>& rays, std::vector<Sampler>& samplers,
                         std::vector<glm::vec3>& radiance, SplatBuffer* splats = nullptr) {
  uint64_t traced = 0;
  for (int ty = 0; ty < 128; ty += 16) {
    for (int tx = 0; tx < 128; tx += 16) {
      size_t n = 0;
      for (int y = ty; y < ty + 16; ++y) {
        for (int x = tx; x < tx + 16; ++x) {
          samplers[n].start_pixel_sample(x, y, 0);
          rays[n++] = scene.camera.primary_ray(x, y);
        }
      }
      const SampleBatch batch{rays, integrator.pixel_corner_only() ? std::span<Sampler>()
                                                                   : std::span<Sampler>(samplers)};
      traced += integrator.radiance(batch, SampleOutput{.radiance = radiance, .splats = splats},
                                    scene, accel);
    }
  }
  return traced;
}

TEST_P(HotPath, TileLoopAllocatesNothing) {
  const Scene scene = make_builtin_scene("terrain:20k", {.width = 128, .height = 128});
  const std::unique_ptr<Accel> accel = make_accel(GetParam(), scene.mesh, kDefaultKernel);
  const LabIntegrator integrator;
  std::vector<Ray> rays(kMaxBatch);
  std::vector<Sampler> samplers(kMaxBatch);
  std::vector<glm::vec3> radiance(kMaxBatch);
  const long before = g_allocations.load();
  const uint64_t traced = trace_all_tiles(scene, *accel, integrator, rays, samplers, radiance);
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_GT(traced, 128u * 128u);  // the loop really traced primary and shadow rays
}

TEST_P(HotPath, PathTracerTileLoopAllocatesNothing) {
  const Scene scene = make_builtin_scene("cornell-area", {.width = 128, .height = 128});
  const std::unique_ptr<Accel> accel = make_accel(GetParam(), scene.mesh, kDefaultKernel);
  const PathIntegrator integrator(scene);
  std::vector<Ray> rays(kMaxBatch);
  std::vector<Sampler> samplers(kMaxBatch);
  std::vector<glm::vec3> radiance(kMaxBatch);
  trace_all_tiles(scene, *accel, integrator, rays, samplers, radiance);  // thread-locals first
  const long before = g_allocations.load();
  const uint64_t traced = trace_all_tiles(scene, *accel, integrator, rays, samplers, radiance);
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_GT(traced, 3u * 128u * 128u);  // camera rays, shadow rays and bounces
}

// The bidirectional path tracer keeps its subpaths in per-thread arrays that grow only when a
// longer subpath than any before needs it: after the first tiles, none of its work allocates.
TEST_P(HotPath, BdptTileLoopAllocatesNothing) {
  const Scene scene = make_builtin_scene("cornell-area", {.width = 32, .height = 32});
  const std::unique_ptr<Accel> accel = make_accel(GetParam(), scene.mesh, kDefaultKernel);
  const BdptIntegrator integrator(scene);
  std::vector<Ray> rays(kMaxBatch);
  std::vector<Sampler> samplers(kMaxBatch);
  std::vector<glm::vec3> radiance(kMaxBatch);
  // Light tracing's splats go to the film's light image, allocated with the film.
  SplatBuffer splats(32, 32);
  trace_all_tiles(scene, *accel, integrator, rays, samplers, radiance, &splats);  // thread-locals
  const long before = g_allocations.load();
  const uint64_t traced =
      trace_all_tiles(scene, *accel, integrator, rays, samplers, radiance, &splats);
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_GT(traced, 3u * 32u * 32u);
}

TEST_P(HotPath, WholeRenderAllocationsDoNotGrowWithTheImage) {
  auto count = [&](int side) {
    const Scene scene = make_builtin_scene("cornell", {.width = side, .height = side});
    const std::unique_ptr<Accel> accel = make_accel(GetParam(), scene.mesh, kDefaultKernel);
    const long before = g_allocations.load();
    const Image image = render(scene, *accel, LabIntegrator{}, {.threads = 2});
    return g_allocations.load() - before;
  };
  count(64);                                         // let the thread pool start
  const long small = count(64), large = count(512);  // 16 tiles, then 1024 tiles
  std::printf("allocations per render: 64x64 %ld, 512x512 %ld\n", small, large);
  EXPECT_LE(large, small + 32);
}

INSTANTIATE_TEST_SUITE_P(Accels, HotPath, ::testing::Values(AccelKind::kBrute, AccelKind::kBvh),
                         [](const auto& info) { return std::string(accel_name(info.param)); });

}  // namespace
}  // namespace tritrace

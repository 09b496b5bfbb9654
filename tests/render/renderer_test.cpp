// Whole images: bit-identical for any thread count and tile size, through brute force and through
// the BVH's packet path, and the same for every kernel except at edge pixels, where float rounding
// may pick a different triangle or flip a shadow; the threads a render really ran.
#include "tritrace/render/renderer.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include "lab_view.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

bool identical(const Image& a, const Image& b) {
  return a.width() == b.width() && a.height() == b.height() &&
         std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)) ==
             0;
}

Image render_with(const Scene& scene, Kernel kernel, RenderOptions options,
                  RenderStats* stats = nullptr) {
  const BruteForceAccel accel(scene.mesh, kernel);
  return render(scene, accel, LabIntegrator{}, options, stats);
}

TEST(Renderer, SameBitsForAnyThreadCountAndTileSize) {
  CornellOptions o;
  o.width = 203;  // not a multiple of the tile size
  o.height = 157;
  o.yaw = 0.3;
  const Scene scene = make_cornell_box(o);
  for (Kernel k : kAllKernels) {
    const Image one = render_with(scene, k, {.threads = 1});
    EXPECT_TRUE(identical(one, render_with(scene, k, {.threads = 2}))) << kernel_name(k);
    EXPECT_TRUE(identical(one, render_with(scene, k, {.threads = 5}))) << kernel_name(k);
    EXPECT_TRUE(identical(one, render_with(scene, k, {.threads = 2, .tile_size = 7})))
        << kernel_name(k);
  }
}

// The BVH traces a tile's coherent camera rays as packets: tiles of other sizes (1, 5, 7, 13
// pixels) cut the batches into other packets, and threads take other tiles, yet every pixel must
// come out as brute force computes it with the same kernel.
TEST(Renderer, BvhSameBitsForAnyThreadCountAndTileSizeAndAsBruteForce) {
  const Scene cornell = make_cornell_box({.width = 203, .height = 157, .yaw = 0.3});
  const Scene terrain = make_terrain_scene(5000, {.width = 97, .height = 61, .yaw = -0.4});
  struct Split {
    int threads, tile_size;
  };
  constexpr Split kSplits[] = {{1, 16}, {2, 16}, {5, 16}, {2, 7}, {5, 13}, {1, 5}, {5, 1}};
  for (const Scene* scene : {&cornell, &terrain}) {
    for (Kernel k : kAllKernels) {
      SCOPED_TRACE(testing::Message()
                   << (scene == &cornell ? "cornell " : "terrain ") << kernel_name(k));
      const Image brute = render_with(*scene, k, {.threads = 2});
      // Built by this thread alone (the parallel build has tests of its own), so that under
      // ThreadSanitizer, whose view of TBB's hand-overs needs src/tritrace/parallel.h, the tree
      // reaches the render threads only through the renderer's hand-over.
      std::optional<BvhAccel> bvh;
      tbb::task_arena(1).execute([&] { bvh.emplace(scene->mesh, k); });
      for (const Split& split : kSplits) {
        const Image image = render(*scene, *bvh, LabIntegrator{},
                                   {.threads = split.threads, .tile_size = split.tile_size});
        EXPECT_TRUE(identical(image, brute))
            << split.threads << " threads, tiles of " << split.tile_size;
      }
    }
  }
}

// Embree is called from every render thread at once (rtcIntersect and rtcOccluded on a committed
// scene); each of its modes must give the same image for any thread count and tile size.
TEST(Renderer, EmbreeSameBitsForAnyThreadCountAndTileSize) {
  if (!accel_available(AccelKind::kEmbree)) GTEST_SKIP() << "built without Embree";
  const Scene scene = make_terrain_scene(5000, {.width = 97, .height = 61, .yaw = -0.4});
  for (AccelKind kind : {AccelKind::kEmbree, AccelKind::kEmbree8, AccelKind::kEmbreeSingle}) {
    SCOPED_TRACE(accel_name(kind));
    const std::unique_ptr<Accel> accel = make_accel(kind, scene.mesh, kDefaultKernel);
    const Image one = render(scene, *accel, LabIntegrator{}, {.threads = 1});
    EXPECT_TRUE(identical(one, render(scene, *accel, LabIntegrator{}, {.threads = 2})));
    EXPECT_TRUE(
        identical(one, render(scene, *accel, LabIntegrator{}, {.threads = 5, .tile_size = 7})));
    EXPECT_TRUE(
        identical(one, render(scene, *accel, LabIntegrator{}, {.threads = 3, .tile_size = 13})));
  }
}

// Notes which threads finish tiles (the renderer tells RenderProgress from the thread that finished
// one). Each thread's first tile is held until `expected` threads have finished one, or 20 s have
// passed, so that every thread of the arena takes part however late the system starts some of
// them; an arena with fewer threads than expected shows as a count below it.
class ThreadRendezvous final : public RenderProgress {
 public:
  explicit ThreadRendezvous(int expected) : expected_(expected) {}
  void tiles_done(int /*done*/, int /*total*/) noexcept override {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!ids_.insert(std::this_thread::get_id()).second) return;
    arrived_.notify_all();
    arrived_.wait_for(lock, std::chrono::seconds(20),
                      [&] { return static_cast<int>(ids_.size()) >= expected_; });
  }
  int count() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return static_cast<int>(ids_.size());
  }

 private:
  const int expected_;
  mutable std::mutex mutex_;
  std::condition_variable arrived_;
  std::set<std::thread::id> ids_;
};

// TBB runs at most as many threads as there are cores unless told otherwise: asked for more (one
// more than the cores here), the renderer must still run them all, and its statistics must count
// the threads that really rendered, as the tiles' own thread ids show.
TEST(Renderer, RunsAndCountsTheThreadsAskedFor) {
  const Scene scene = make_cornell_box({.width = 96, .height = 96});  // 36 tiles
  for (int threads : {1, 2, 3, default_thread_count() + 1}) {
    ThreadRendezvous rendezvous(threads);
    RenderStats stats;
    render_with(scene, kDefaultKernel, {.threads = threads, .progress = &rendezvous}, &stats);
    EXPECT_EQ(rendezvous.count(), threads) << threads << " threads asked for";
    EXPECT_EQ(stats.threads, rendezvous.count()) << threads << " threads asked for";
  }
  // An image of one tile is rendered by one thread, whatever the count asked for.
  ThreadRendezvous one(1);
  RenderStats stats;
  render_with(make_cornell_box({.width = 8, .height = 8}), kDefaultKernel,
              {.threads = 4, .progress = &one}, &stats);
  EXPECT_EQ(one.count(), 1);
  EXPECT_EQ(stats.threads, 1);
}

TEST(Renderer, CountsPrimaryAndShadowRays) {
  const Scene scene = make_cornell_box({.width = 64, .height = 48});
  RenderStats stats;
  render_with(scene, kDefaultKernel, {.threads = 2}, &stats);
  // 12 tiles: the second thread may start after the first took them all.
  EXPECT_GE(stats.threads, 1);
  EXPECT_LE(stats.threads, 2);
  // Every pixel sees the room, and most surfaces face the light: one primary ray each, plus a
  // shadow ray for most.
  EXPECT_GT(stats.rays, 64u * 48u * 3 / 2);
  EXPECT_LE(stats.rays, 64u * 48u * 2);
  EXPECT_GT(stats.milliseconds, 0.0);
  EXPECT_GT(stats.mrays_per_second(), 0.0);
}

// Pixels whose 3 x 3 neighbourhood (in the reference image) is not uniform sit on a triangle edge
// or a shadow boundary; only there may kernels disagree.
bool is_edge_pixel(const Image& ref, const std::vector<uint32_t>& prim, int x, int y) {
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const int nx = std::clamp(x + dx, 0, ref.width() - 1);
      const int ny = std::clamp(y + dy, 0, ref.height() - 1);
      const size_t a = static_cast<size_t>(y) * ref.width() + x;
      const size_t b = static_cast<size_t>(ny) * ref.width() + nx;
      if (prim[a] != prim[b]) return true;
      const glm::vec3 d = glm::abs(ref.at(x, y) - ref.at(nx, ny));
      if (d.x + d.y + d.z > 0.05f) return true;  // a shadow edge
    }
  }
  return false;
}

TEST(Renderer, KernelsAgreeExceptAtEdgePixels) {
  const Scene scene = make_cornell_box();
  const Image ref = render_with(scene, Kernel::kMollerTrumbore, {});
  // The triangle each primary ray hits, per the reference kernel.
  const BruteForceAccel ref_accel(scene.mesh, Kernel::kMollerTrumbore);
  std::vector<uint32_t> prim;
  for (int y = 0; y < ref.height(); ++y) {
    for (int x = 0; x < ref.width(); ++x) {
      prim.push_back(ref_accel.intersect(scene.camera.primary_ray(x, y)).prim);
    }
  }
  for (Kernel k : kAllKernels) {
    if (k == Kernel::kMollerTrumbore) continue;
    const Image img = render_with(scene, k, {});
    int differing = 0, off_edge = 0, off_corners = 0;
    for (int y = 0; y < ref.height(); ++y) {
      for (int x = 0; x < ref.width(); ++x) {
        const glm::vec3 d = glm::abs(img.at(x, y) - ref.at(x, y));
        // Away from edges the same surface point is shaded; t differs only in the last bits.
        if (std::max({d.x, d.y, d.z}) <= 1e-5f) continue;
        ++differing;
        if (!is_edge_pixel(ref, prim, x, y)) ++off_edge;
        if (!testing_lab::on_room_corner_edge(x, y)) ++off_corners;
      }
    }
    std::printf(
        "%s vs moller-trumbore: %d of %d pixels differ, %d away from edges, %d off the "
        "room's corner edges\n",
        std::string(kernel_name(k)).c_str(), differing, ref.width() * ref.height(), off_edge,
        off_corners);
    EXPECT_EQ(off_edge, 0) << kernel_name(k);
    EXPECT_LE(off_corners, ref.width() * ref.height() / 1000) << kernel_name(k);  // at most 0.1%
  }
}

}  // namespace
}  // namespace tritrace

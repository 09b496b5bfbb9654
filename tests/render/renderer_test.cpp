// Whole images: bit-identical for any thread count and tile size, and the same for every
// kernel except at edge pixels, where float rounding may pick a different triangle or flip a
// shadow.
#include "tritrace/render/renderer.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>

#include "lab_view.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/scene/cornell_box.h"

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

TEST(Renderer, CountsPrimaryAndShadowRays) {
  const Scene scene = make_cornell_box({.width = 64, .height = 48});
  RenderStats stats;
  render_with(scene, kDefaultKernel, {.threads = 2}, &stats);
  EXPECT_EQ(stats.threads, 2);
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

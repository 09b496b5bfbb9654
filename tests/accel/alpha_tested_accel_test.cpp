// AlphaTestedAccel: rays pass a cut-out's transparent texels and a blended surface with probability
// 1 - alpha, for every backend, with the shares computed by hand from the texture (alpha_scene.h).
#include "tritrace/accel/alpha_tested_accel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "alpha_scene.h"
#include "tritrace/accel/make_accel.h"

namespace tritrace {
namespace {

using alpha_test::kTransparentShare;
using alpha_test::quad_before_wall;

constexpr int kGrid = 64;

// Parallel rays along +z from z = 0 through the centres of a kGrid x kGrid grid over the quad.
std::vector<Ray> parallel_rays(float tmax = kRayTMax) {
  std::vector<Ray> rays;
  for (int j = 0; j < kGrid; ++j) {
    for (int i = 0; i < kGrid; ++i) {
      rays.push_back({{(i + 0.5f) / kGrid, (j + 0.5f) / kGrid, 0.0f}, {0, 0, 1}, 0.0f, tmax});
    }
  }
  return rays;
}

// Rays from one point behind the quad through a grid of points (each a different direction),
// none on the quad's diagonal, which its two triangles share.
std::vector<Ray> diverging_rays() {
  std::vector<Ray> rays;
  const glm::vec3 eye{0.5f, 0.5f, -1.0f};
  for (int j = 0; j < kGrid; ++j) {
    for (int i = 0; i < kGrid; ++i) {
      const glm::vec3 target{(i + 0.5f) / kGrid, (j + 0.25f) / kGrid, 1.0f};
      rays.push_back({eye, glm::normalize(target - eye)});
    }
  }
  return rays;
}

std::vector<AccelKind> kinds() {
  std::vector<AccelKind> out = {AccelKind::kBrute, AccelKind::kBvh, AccelKind::kBvhSingle};
  if (accel_available(AccelKind::kEmbree)) {
    out.insert(out.end(), {AccelKind::kEmbree, AccelKind::kEmbreeSingle});
  }
  return out;
}

// The wall's triangles are the scene's third and fourth.
bool on_wall(const Hit& h) {
  return h.prim == 2 || h.prim == 3;
}

TEST(AlphaTestedAccel, MaskedQuadPassesExactlyItsTransparentColumns) {
  const Scene s = quad_before_wall(AlphaMode::kMask, true);
  const std::vector<Ray> rays = parallel_rays();
  for (AccelKind kind : kinds()) {
    SCOPED_TRACE(std::string(accel_name(kind)));
    const auto accel = make_accel(kind, s, default_kernel_for(kind));
    ASSERT_NE(dynamic_cast<const AlphaTestedAccel*>(accel.get()), nullptr);
    std::vector<Hit> hits(rays.size());
    accel->intersect(rays, hits);
    int passed = 0;
    for (size_t k = 0; k < rays.size(); ++k) {
      const float x = rays[k].origin.x;
      const bool hole = x > 2.0f / 8 && x < 5.0f / 8;
      ASSERT_TRUE(hits[k].found());
      EXPECT_EQ(on_wall(hits[k]), hole) << "x = " << x;
      EXPECT_FLOAT_EQ(hits[k].t, hole ? 2.0f : 1.0f);
      passed += on_wall(hits[k]);
    }
    EXPECT_EQ(passed, static_cast<int>(kTransparentShare * kGrid * kGrid));
  }
}

// Shadow rays that end between the quad and the wall: unblocked exactly through the holes.
TEST(AlphaTestedAccel, ShadowRaysPassTheMaskWhereItIsTransparent) {
  const Scene s = quad_before_wall(AlphaMode::kMask, true);
  for (AccelKind kind : kinds()) {
    SCOPED_TRACE(std::string(accel_name(kind)));
    const auto accel = make_accel(kind, s, default_kernel_for(kind));
    const std::vector<Ray> short_rays = parallel_rays(1.5f);
    std::vector<uint8_t> blocked(short_rays.size());
    accel->occluded(short_rays, blocked);
    int unblocked = 0;
    for (size_t k = 0; k < short_rays.size(); ++k) {
      const float x = short_rays[k].origin.x;
      EXPECT_EQ(blocked[k] == 0, x > 2.0f / 8 && x < 5.0f / 8) << "x = " << x;
      unblocked += blocked[k] == 0;
    }
    EXPECT_EQ(unblocked, static_cast<int>(kTransparentShare * kGrid * kGrid));
    // The incoherent query agrees, and every ray that reaches the wall is blocked by it.
    std::vector<uint8_t> again(short_rays.size());
    accel->occluded_incoherent(short_rays, again);
    EXPECT_EQ(again, blocked);
    const std::vector<Ray> long_rays = parallel_rays();
    accel->occluded(long_rays, blocked);
    for (uint8_t b : blocked) EXPECT_EQ(b, 1);
  }
}

// A ray starting on the far side of a hole, or inside [t_quad, t_wall], meets only the wall: the
// re-trace starts beyond the skipped hit and never returns it twice.
TEST(AlphaTestedAccel, IntervalsStartingAtTheQuadSeeOnlyWhatIsBeyond) {
  const Scene s = quad_before_wall(AlphaMode::kMask, true);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  const Hit through = accel->intersect(Ray{{0.45f, 0.5f, 0.0f}, {0, 0, 1}, 1.0f, kRayTMax});
  EXPECT_TRUE(on_wall(through));
  const Hit opaque = accel->intersect(Ray{{0.1f, 0.5f, 0.0f}, {0, 0, 1}, 1.0f, kRayTMax});
  EXPECT_EQ(opaque.prim < 2, true);  // the quad, at t = tmin exactly
  EXPECT_FALSE(accel->intersect(Ray{{0.45f, 0.5f, 0.0f}, {0, 0, 1}, 0.0f, 1.9f}).found());
}

// BLEND with alpha 0.3: each ray passes with probability 0.7, independently of the others; two
// such quads one behind the other pass 0.7^2 = 0.49. Bounds: 4 binomial standard deviations.
TEST(AlphaTestedAccel, BlendedQuadPassesOneMinusAlphaOfTheRays) {
  Scene s = quad_before_wall(AlphaMode::kBlend, false, 0.3f);
  const std::vector<Ray> rays = diverging_rays();
  const double n = static_cast<double>(rays.size());
  auto passed_share = [&](const Scene& scene, AccelKind kind) {
    const auto accel = make_accel(kind, scene, default_kernel_for(kind));
    std::vector<Hit> hits(rays.size());
    accel->intersect(rays, hits);
    std::vector<uint8_t> blocked(rays.size());
    std::vector<Ray> shadow = rays;
    for (Ray& r : shadow) r.tmax = 2.99f / r.dir.z;  // ends just before the wall (z = 1.99)
    accel->occluded(shadow, blocked);
    int through = 0, unblocked = 0;
    for (size_t k = 0; k < rays.size(); ++k) {
      through += on_wall(hits[k]);
      unblocked += blocked[k] == 0;
    }
    // The same decision for the same ray, whichever query asks.
    EXPECT_EQ(through, unblocked);
    return through / n;
  };
  for (AccelKind kind : kinds()) {
    SCOPED_TRACE(std::string(accel_name(kind)));
    const double one = passed_share(s, kind);
    EXPECT_NEAR(one, 0.7, 4.0 * std::sqrt(0.7 * 0.3 / n));
  }
  // A second blended quad at z = 1.5, wide enough for every ray to cross it.
  alpha_test::add_square(s.mesh, -1.0f, -1.0f, 3.0f, 1.5f, 1);
  const double two = passed_share(s, AccelKind::kBvh);
  EXPECT_NEAR(two, 0.49, 4.0 * std::sqrt(0.49 * 0.51 / n));
}

// Where a backend's kernel and brute force's agree on which triangle a ray meets (rays away from
// edges, as these are), the alpha-tested hits agree too: bvh and embree see the same cut-out.
TEST(AlphaTestedAccel, BackendsAgreeOnTheMaskedScene) {
  const Scene s = quad_before_wall(AlphaMode::kMask, true);
  const std::vector<Ray> rays = diverging_rays();
  const auto oracle = make_accel(AccelKind::kBrute, s, kDefaultKernel);
  std::vector<Hit> want(rays.size());
  oracle->intersect(rays, want);
  for (AccelKind kind : kinds()) {
    SCOPED_TRACE(std::string(accel_name(kind)));
    const auto accel = make_accel(kind, s, default_kernel_for(kind));
    std::vector<Hit> got(rays.size());
    accel->intersect_incoherent(rays, got);
    for (size_t k = 0; k < rays.size(); ++k) {
      EXPECT_EQ(on_wall(got[k]), on_wall(want[k])) << k;
      EXPECT_NEAR(got[k].t, want[k].t, 1e-5f * want[k].t) << k;
    }
  }
}

TEST(AlphaTestedAccel, OnlyScenesWithCutOutsAreWrapped) {
  const auto opaque =
      make_accel(AccelKind::kBvh, quad_before_wall(AlphaMode::kOpaque, true), kDefaultKernel);
  EXPECT_EQ(dynamic_cast<const AlphaTestedAccel*>(opaque.get()), nullptr);
  // A mask without an alpha texture whose factor passes the cutoff hides nothing.
  const auto full =
      make_accel(AccelKind::kBvh, quad_before_wall(AlphaMode::kMask, false, 0.6f), kDefaultKernel);
  EXPECT_EQ(dynamic_cast<const AlphaTestedAccel*>(full.get()), nullptr);
  const auto blend =
      make_accel(AccelKind::kBvh, quad_before_wall(AlphaMode::kBlend, false, 0.9f), kDefaultKernel);
  EXPECT_NE(dynamic_cast<const AlphaTestedAccel*>(blend.get()), nullptr);
}

TEST(AlphaTestedAccel, BlendThresholdIsUniform) {
  // Ten bins over the diverging rays' thresholds: each within 4 standard deviations of n / 10.
  const std::vector<Ray> rays = diverging_rays();
  int bins[10] = {};
  for (const Ray& r : rays) {
    const float u = blend_threshold(r, 7);
    ASSERT_GE(u, 0.0f);
    ASSERT_LT(u, 1.0f);
    ++bins[static_cast<int>(u * 10)];
  }
  const double n = static_cast<double>(rays.size());
  for (int b : bins) EXPECT_NEAR(b, n / 10, 4.0 * std::sqrt(n * 0.1 * 0.9));
}

}  // namespace
}  // namespace tritrace

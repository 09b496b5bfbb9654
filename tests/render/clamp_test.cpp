// The path tracer's clamp on indirect light (PathSettings::clamp_indirect), against an oracle made
// of two unclamped renders: the direct part of every sample is the image of the same samples at
// max depth 1 (a path cut after the first hit's light sample and bounce), and at one sample per
// pixel (box filter) a pixel is its one sample, so the unclamped image minus the direct one is
// each sample's indirect light. The clamped image must be the direct part plus that indirect light
// scaled so that its largest channel is at most the clamp: changed only where a sample exceeded it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "example_scene.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/distributed/render_identity.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

using testing_scenes::example_scene;

Image render_with(const Scene& scene, const Accel& accel, PathSettings settings,
                  const RenderOptions& options) {
  const PathIntegrator pt(scene, settings);
  return render(scene, accel, pt, options);
}

float largest(glm::vec3 c) {
  return std::max({c.x, c.y, c.z});
}

struct ClampCounts {
  int clamped = 0;    // pixels whose sample's indirect light exceeded the clamp
  int unchanged = 0;  // pixels whose sample's indirect light stayed below it
};

// Checks every pixel of a one-sample render of `scene` clamped at `clamp` against the oracle.
ClampCounts expect_clamped_like_the_oracle(const Scene& scene, float clamp) {
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const RenderOptions one{.spp = 1, .seed = 5};
  const Image full = render_with(scene, accel, {}, one);
  const Image direct = render_with(scene, accel, {.max_depth = 1}, one);
  const Image clamped = render_with(scene, accel, {.clamp_indirect = clamp}, one);
  ClampCounts counts;
  for (size_t k = 0; k < full.pixels().size(); ++k) {
    const glm::vec3 d = direct.pixels()[k];
    const glm::vec3 indirect = full.pixels()[k] - d;
    const glm::vec3 got = clamped.pixels()[k];
    // The subtraction's rounding: a few ulps of the larger of the two terms.
    const float slack = 1e-5f * (1.0f + largest(full.pixels()[k]));
    const float m = largest(indirect);
    EXPECT_GE(largest(got - d), -slack) << "pixel " << k;
    EXPECT_LE(largest(got - d), clamp + slack) << "pixel " << k << ": indirect beyond the clamp";
    if (m > clamp + slack) {
      ++counts.clamped;
      const glm::vec3 want = d + indirect * (clamp / m);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 2 * slack) << "pixel " << k;
    } else if (m < clamp - slack) {
      ++counts.unchanged;
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], full.pixels()[k][c], slack) << "pixel " << k;
    }
  }
  return counts;
}

TEST(ClampIndirect, GlassCausticSamplesAreScaledToTheClampAndNoOthers) {
  const ClampCounts counts = expect_clamped_like_the_oracle(example_scene("glass.json", 128), 0.5f);
  // Both kinds occur, so the test tells a clamp that does nothing from one that clamps all (at
  // one sample per pixel, a few dozen of the 16384 samples go through the sphere to the light
  // with more than 0.5, up to about 13).
  EXPECT_GT(counts.clamped, 10);
  EXPECT_GT(counts.unchanged, 1000);
}

TEST(ClampIndirect, DiffuseBoxLosesOnlyTheSamplesAboveTheClamp) {
  const ClampCounts counts =
      expect_clamped_like_the_oracle(make_cornell_area({.width = 48, .height = 48}), 0.5f);
  EXPECT_GT(counts.clamped, 0);
  EXPECT_GT(counts.unchanged, 1000);
}

// The light itself, bright and seen by the camera, is direct: never clamped.
TEST(ClampIndirect, EmittersTheCameraSeesAreNotClamped) {
  const Scene scene = make_cornell_area({.width = 32, .height = 32});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image image = render_with(scene, accel, {.clamp_indirect = 0.01f}, {.spp = 4});
  float brightest = 0.0f;
  for (const glm::vec3& p : image.pixels()) brightest = std::max(brightest, largest(p));
  EXPECT_GE(brightest, largest(kAreaLightRadiance));
}

// Where no sample's indirect light comes near the clamp, the image is the unclamped one but for
// the order of the additions (the image mean within a millionth), at many samples per pixel.
TEST(ClampIndirect, HighClampLeavesTheDiffuseBoxsMeanAsItWas) {
  const Scene scene = make_cornell_area({.width = 32, .height = 32});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const RenderOptions options{.spp = 64, .seed = 9};
  const Image full = render_with(scene, accel, {}, options);
  const Image clamped = render_with(scene, accel, {.clamp_indirect = 1e6f}, options);
  double a = 0.0, b = 0.0;
  for (size_t k = 0; k < full.pixels().size(); ++k) {
    a += full.pixels()[k].x + full.pixels()[k].y + full.pixels()[k].z;
    b += clamped.pixels()[k].x + clamped.pixels()[k].y + clamped.pixels()[k].z;
  }
  EXPECT_NEAR(b / a, 1.0, 1e-6);
  // A low clamp removes energy: the mean drops (and the test above can tell).
  const Image low = render_with(scene, accel, {.clamp_indirect = 0.05f}, options);
  double c = 0.0;
  for (const glm::vec3& p : low.pixels()) c += p.x + p.y + p.z;
  EXPECT_LT(c, 0.99 * a);
}

// Parts rendered with different clamps are different renders: they must not merge.
TEST(ClampIndirect, IsPartOfTheRenderIdentity) {
  const Scene scene = make_cornell_area({.width = 8, .height = 8});
  const RenderOptions options{.spp = 8};
  IntegratorSpec off, one, two;
  one.clamp = 1.0f;
  two.clamp = 2.0f;
  const auto id = [&](const IntegratorSpec& spec) {
    return render_identity(scene, spec, options, "bvh", "watertight", {});
  };
  EXPECT_EQ(id(off).settings.find("clamp"), std::string::npos) << "unclamped: the text as before";
  EXPECT_NE(id(one).settings.find(" clamp=1"), std::string::npos) << id(one).settings;
  EXPECT_NE(id(one).hash, id(two).hash);
  EXPECT_NE(id(one).hash, id(off).hash);
  EXPECT_FALSE(identity_difference(id(one), id(two)).empty());
}

}  // namespace
}  // namespace tritrace

// The thin lens under the path tracer, against the thin-lens formula worked out by hand: an
// emitting half-plane's edge seen through the lens. In the plane of focus the edge is as sharp as
// a pinhole draws it; off focus a point spreads over a disk whose diameter in pixels is
// c = A |d - f| / d * (F / f) (aperture diameter A = 2R, depth d, focus distance f, focal length F
// in pixels), so the edge's profile is the fraction of that disk on the lit side of a line,
// averaged over each pixel. A uniform scene stays uniform, whatever the blur.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/scene_file.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

constexpr int kWidth = 64, kHeight = 16;
constexpr float kFocalPx = 64.0f;
constexpr float kEdgePx = 32.3f;  // where the edge's pinhole image lies, in pixels from the left

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

// A camera at the origin looking along +z (right +x, down +y, as the lab's) with the given lens,
// and an emitting (radiance 1) half-plane x > x0 at depth `depth`, x0 chosen so that the edge's
// pinhole image falls at kEdgePx. Black elsewhere.
Scene edge_scene(double depth, double aperture, double focus, bool whole_plane = false) {
  const double x0 = whole_plane ? -1e3 : (kEdgePx - kWidth / 2) * depth / kFocalPx;
  const std::string z = num(depth), x = num(x0);
  std::string text = R"({"camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "up": [0, -1, 0],
      "focal_length": )" +
                     num(kFocalPx) + ", \"width\": " + std::to_string(kWidth) +
                     ", \"height\": " + std::to_string(kHeight);
  if (aperture > 0.0) {
    text += ", \"aperture_radius\": " + num(aperture) + ", \"focus_distance\": " + num(focus);
  }
  text += R"(},
      "materials": [{"name": "glow", "albedo": [0, 0, 0], "emission": [1, 1, 1],
                     "two_sided": true}],
      "meshes": [{"positions": [[)" +
          x + ", -1000, " + z + "], [1000, -1000, " + z + "], [1000, 1000, " + z + "], [" + x +
          ", 1000, " + z + R"(]],
                  "triangles": [[0, 1, 2], [0, 2, 3]], "material": "glow"}]})";
  LoadedScene loaded = parse_scene_json(text, "edge.json");
  apply_overrides(loaded, {});
  return std::move(loaded.scene);
}

Image render_edge(const Scene& scene, uint32_t spp, bool bdpt = false,
                  SamplerKind sampler = SamplerKind::kSobol) {
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const RenderOptions options{.spp = spp, .seed = 3, .sampler = sampler};
  if (bdpt) {
    // Without light tracing (t = 1), which connects to a pinhole only and is refused with a lens
    // by the render job: camera subpaths start on the lens.
    const BdptIntegrator integrator(scene, BdptSettings{.max_depth = 0, .light_tracing = false});
    return render(scene, accel, integrator, options);
  }
  const PathIntegrator integrator(scene, PathSettings{.max_depth = 0});
  return render(scene, accel, integrator, options);
}

// Column x's mean over the image's rows (the edge is vertical, so every row sees the same).
double column_mean(const Image& image, int x) {
  double sum = 0.0;
  for (int y = 0; y < image.height(); ++y) sum += image.at(x, y).x;
  return sum / image.height();
}

// The fraction of a uniform disk of radius r (centred at 0) with x-coordinate below t.
double disk_fraction_below(double t, double r) {
  if (t <= -r) return 0.0;
  if (t >= r) return 1.0;
  return 0.5 +
         (t * std::sqrt(r * r - t * t) + r * r * std::asin(t / r)) / (std::numbers::pi * r * r);
}

// The expected value of pixel column x: a point at image position u is lit when the disk the lens
// spreads it over (radius r, centred on u) falls on the lit side, x - kEdgePx > s for the disk's
// x-offset s; averaged over the pixel's width (the box filter) by the midpoint rule.
double expected_column(int x, double r) {
  constexpr int kSteps = 4000;
  double sum = 0.0;
  for (int i = 0; i < kSteps; ++i) {
    const double u = x + (i + 0.5) / kSteps;
    sum += r > 0.0 ? disk_fraction_below(u - kEdgePx, r) : (u > kEdgePx ? 1.0 : 0.0);
  }
  return sum / kSteps;
}

TEST(DepthOfField, EdgeInThePlaneOfFocusIsAsSharpAsThePinholes) {
  const double depth = 4.0;
  const Image pinhole = render_edge(edge_scene(depth, 0.0, 0.0), 64);
  const Image lens = render_edge(edge_scene(depth, 0.5, depth), 64);
  // Only the column the edge crosses is partly lit, by the share of it right of the edge.
  for (int x = 0; x < kWidth; ++x) {
    const double want = expected_column(x, 0.0);
    if (x == 32) {
      EXPECT_NEAR(column_mean(lens, x), 0.7, 0.01);
      EXPECT_NEAR(column_mean(lens, x), column_mean(pinhole, x), 0.01);
    } else {
      EXPECT_EQ(column_mean(lens, x), want) << "column " << x;
      EXPECT_EQ(column_mean(pinhole, x), want) << "column " << x;
    }
  }
}

TEST(DepthOfField, EdgeOffFocusBlursByTheCircleOfConfusion) {
  // Depth 8, focus 4, R = 0.5: c = 2 * 0.5 * |8 - 4| / 8 * (64 / 4) = 8 pixels, radius 4.
  const double depth = 8.0, focus = 4.0, radius = 0.5;
  const double blur_radius_px = radius * std::abs(depth - focus) / depth * (kFocalPx / focus);
  ASSERT_DOUBLE_EQ(blur_radius_px, 4.0);
  // Measured over seeds 1-8: the largest column error is 0.005.
  const Image image = render_edge(edge_scene(depth, radius, focus), 256);
  int partial = 0;
  for (int x = 0; x < kWidth; ++x) {
    const double got = column_mean(image, x);
    EXPECT_NEAR(got, expected_column(x, blur_radius_px), 0.01) << "column " << x;
    partial += got > 0.0 && got < 1.0;
  }
  // The blur spans the disk's diameter: columns 28 to 36 (8.6 pixels of a 4-pixel radius about
  // 32.3), against the pinhole's one.
  EXPECT_EQ(partial, 9);
  EXPECT_EQ(column_mean(image, 27), 0.0);
  EXPECT_EQ(column_mean(image, 37), 1.0);
}

TEST(DepthOfField, SobolStratifiesTheLens) {
  // The lens point is one 2-D group of the Sobol sampler (dimensions 2 and 3), so over a wide blur
  // (radius 4 pixels, where the lens, not the position in the pixel, decides what a sample sees)
  // its error is well below plain Monte Carlo's at the same spp (measured: RMS 0.0020 against
  // 0.0044, a ratio of 0.45; a lens drawn from unstratified numbers would be near 1).
  const Scene scene = edge_scene(8.0, 0.5, 4.0);
  const auto rms = [](const Image& image) {
    double sum = 0.0;
    for (int x = 26; x < 39; ++x) {
      const double e = column_mean(image, x) - expected_column(x, 4.0);
      sum += e * e;
    }
    return std::sqrt(sum / 13.0);
  };
  const double sobol = rms(render_edge(scene, 256));
  const double independent = rms(render_edge(scene, 256, false, SamplerKind::kIndependent));
  EXPECT_LT(sobol, 0.7 * independent) << sobol << " vs " << independent;
}

TEST(DepthOfField, BdptBlursAsThePathTracerDoes) {
  // bdpt's camera subpaths start from the same lens rays: the same profile within noise.
  // At 64 spp its largest column error over seeds 1-8 was 0.018; 256 spp about halves that.
  const Image image = render_edge(edge_scene(8.0, 0.5, 4.0), 256, true);
  for (int x = 24; x < 40; ++x) {
    EXPECT_NEAR(column_mean(image, x), expected_column(x, 4.0), 0.015) << "column " << x;
  }
}

TEST(DepthOfField, BlurKeepsAUniformScenesMean) {
  // An emitter filling the view, far off focus: every lens ray still sees radiance 1.
  const Image image = render_edge(edge_scene(2.0, 1.0, 50.0, true), 16);
  for (const glm::vec3& p : image.pixels()) ASSERT_EQ(p, glm::vec3(1.0f));
}

TEST(DepthOfField, ApertureZeroIsThePinholeBitForBit) {
  Scene pinhole = edge_scene(8.0, 0.0, 0.0);
  Scene zero = pinhole;
  zero.camera = zero.camera.with_lens(0.0f, 4.0f);
  const Image a = render_edge(pinhole, 8), b = render_edge(zero, 8);
  EXPECT_EQ(a.pixels(), b.pixels());
}

}  // namespace
}  // namespace tritrace

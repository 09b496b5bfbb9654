// bdpt's light tracing (t = 1) against oracles that do not use it: the film's light image is an
// integer sum that does not depend on the order of its splats; each unweighted (s, 1) strategy
// alone converges to the path tracer's light of the same path length; the image is the same bit
// for bit for any thread count, tile size, pass split and front end; and a point light's caustic
// under a glass sphere carries the energy that an analytic trace of the sphere (Fresnel
// transmittance in and out, integrated numerically here) says, where the path tracer is black.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <random>
#include <vector>

#include "mean_and_error.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/error.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

using testing_mc::luminance_mean;
using testing_mc::same_bits;

// Integer sums: any order of the same splats gives the same bits.
TEST(SplatBuffer, SumsDoNotDependOnTheOrderOfSplats) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> value(-3.0f, 1000.0f), u(0.0f, 1.0f);
  struct Splat {
    int x, y;
    glm::vec3 v;
    float u;
  };
  std::vector<Splat> splats;
  for (int i = 0; i < 2000; ++i) {
    splats.push_back({static_cast<int>(rng() % 3), static_cast<int>(rng() % 2),
                      glm::vec3(value(rng), value(rng) * 1e-6f, value(rng) * 1e3f), u(rng)});
  }
  SplatBuffer forward(3, 2), backward(3, 2), halves(3, 2), second(3, 2);
  for (const Splat& s : splats) forward.add(s.x, s.y, s.v, s.u);
  for (size_t i = splats.size(); i-- > 0;)
    backward.add(splats[i].x, splats[i].y, splats[i].v, splats[i].u);
  for (size_t i = 0; i < splats.size(); ++i) {
    (i % 2 ? halves : second).add(splats[i].x, splats[i].y, splats[i].v, splats[i].u);
  }
  halves.add(second);
  EXPECT_EQ(forward.data(), backward.data());
  EXPECT_EQ(forward.data(), halves.data());
}

// Stochastic rounding: a value below the unit is kept in expectation, not lost.
TEST(SplatBuffer, RoundingIsUnbiased) {
  SplatBuffer buffer(1, 1);
  const float tiny = static_cast<float>(0.3 * SplatBuffer::kSplatUnit);
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    buffer.add(0, 0, glm::vec3(tiny, -tiny, 0.0f), (static_cast<float>(i) + 0.5f) / n);
  }
  const double units = static_cast<double>(tiny) / SplatBuffer::kSplatUnit;
  EXPECT_NEAR(static_cast<double>(static_cast<int64_t>(buffer.raw(0, 0)[0])), units * n, 2.0);
  EXPECT_NEAR(static_cast<double>(static_cast<int64_t>(buffer.raw(0, 0)[1])), -units * n, 2.0);
  EXPECT_EQ(buffer.raw(0, 0)[2], 0u);
}

using testing_mc::expect_same_mean;
using testing_mc::mean_of;
using testing_mc::MeanAndError;

// Each light tracing strategy (s, 1) alone, unweighted, estimates every path of s + 1 vertices
// (s - 1 bounces) on the diffuse cornell-area: the path tracer's image at --max-depth s - 1 less
// its image at s - 2 (the same seed, so the difference is the band of that length).
TEST(BdptLightTracing, EachUnweightedStrategyAloneConvergesToThePathTracersBand) {
  const Scene scene = make_cornell_area({.width = 16, .height = 16});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  for (int s : {2, 3}) {
    const BdptIntegrator alone(scene,
                               {.max_depth = s - 1, .only_s = s, .only_t = 1, .unweighted = true});
    const MeanAndError light = mean_of(8, [&](int i) {
      return luminance_mean(render(scene, accel, alone, {.spp = 32, .seed = 20u + i}));
    });
    const PathIntegrator longer(scene, {.max_depth = s - 1});
    const PathIntegrator shorter(scene, {.max_depth = s - 2});
    const MeanAndError path = mean_of(8, [&](int i) {
      const RenderOptions o{.spp = 64, .seed = 40u + i};
      return luminance_mean(render(scene, accel, longer, o)) -
             luminance_mean(render(scene, accel, shorter, o));
    });
    std::printf("  (%d, 1) alone vs path's band of %d bounces:\n", s, s - 1);
    expect_same_mean(light, path, 0.02);
  }
}

// The same for (2, 1) through a thin lens and through an orthographic camera with a lens, where
// light tracing joins a lens point of its own (the perspective lens: the camera subpath's; the
// orthographic one: the vertex's foot plus the lens offset scaled by depth over focus distance).
TEST(BdptLightTracing, UnweightedStrategyThroughLensesConvergesToThePathTracersBand) {
  Scene perspective = make_cornell_area({.width = 16, .height = 16});
  perspective.camera = perspective.camera.with_lens(0.2f, 2.5f);
  Scene orthographic = make_cornell_area({.width = 16, .height = 16});
  orthographic.camera = orthographic.camera.orthographic(2.2f / 16.0f).with_lens(0.2f, 2.5f);
  for (const Scene* scene : {&perspective, &orthographic}) {
    const BvhAccel accel(scene->mesh, kDefaultKernel);
    const BdptIntegrator alone(*scene,
                               {.max_depth = 1, .only_s = 2, .only_t = 1, .unweighted = true});
    const MeanAndError light = mean_of(8, [&](int i) {
      return luminance_mean(render(*scene, accel, alone, {.spp = 32, .seed = 80u + i}));
    });
    const PathIntegrator longer(*scene, {.max_depth = 1});
    const PathIntegrator shorter(*scene, {.max_depth = 0});
    const MeanAndError path = mean_of(8, [&](int i) {
      const RenderOptions o{.spp = 64, .seed = 90u + i};
      return luminance_mean(render(*scene, accel, longer, o)) -
             luminance_mean(render(*scene, accel, shorter, o));
    });
    std::printf("  (2, 1) alone through %s lens vs path's direct light:\n",
                scene->camera.is_orthographic() ? "an orthographic" : "a perspective");
    expect_same_mean(light, path, 0.02);
  }
}

// Splats are integer sums: the image is the same bits for any thread count and tile size,
// rendered straight to an image or through a film in one go or in passes (the viewer's and
// --time-limit's way), on the lab's point-light box where light tracing carries light paths
// onto other pixels.
TEST(BdptLightTracing, ImageIsTheSameForThreadsTilesPassesAndFilms) {
  const Scene scene = make_cornell_box({.width = 24, .height = 20});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene);
  ASSERT_TRUE(bdpt.splats());
  const Image want = render(scene, accel, bdpt, {.threads = 1, .tile_size = 16, .spp = 19});
  for (int threads : {2, 3}) {
    for (int tile : {1, 5, 16}) {
      const Image got =
          render(scene, accel, bdpt, {.threads = threads, .tile_size = tile, .spp = 19});
      EXPECT_TRUE(same_bits(want, got)) << threads << " threads, tile " << tile;
    }
  }
  Film one(24, 20), passes(24, 20);
  render_to_film(scene, accel, bdpt, one, {.threads = 2, .tile_size = 7, .spp = 19});
  EXPECT_TRUE(same_bits(want, one.resolve()));
  for (uint32_t at = 0; at < 19; at += 8) {
    render_to_film(scene, accel, bdpt, passes,
                   {.threads = 3, .spp = std::min(8u, 19 - at), .first_sample = at});
  }
  EXPECT_TRUE(same_bits(want, passes.resolve()));
  // The viewer's frames: passes of any size, continued at the film's end.
  Film frames(24, 20);
  uint32_t taken = 0;
  for (uint32_t n : {1u, 2u, 5u, 11u}) {
    render_to_film(scene, accel, bdpt, frames, {.threads = 2, .spp = n, .first_sample = taken});
    taken += n;
  }
  EXPECT_TRUE(same_bits(want, frames.resolve()));
  // Light tracing added something: without it the image differs.
  const BdptIntegrator without(scene, {.light_tracing = false});
  EXPECT_FALSE(same_bits(want, render(scene, accel, without, {.spp = 19})));
}

// What light tracing cannot estimate is refused, not rendered wrong: tile parts (splats land
// outside them) and filters other than the box (the camera density is the box filter's).
// (Adaptive sampling is rendered pass by pass: bdpt_adaptive_test.cpp.)
TEST(BdptLightTracing, RendererRefusesTilePartsAndOtherFilters) {
  const Scene scene = make_cornell_box({.width = 16, .height = 16});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene);
  EXPECT_THROW(render(scene, accel, bdpt, {.spp = 8, .tile_part = 0, .tile_parts = 2}), Error);
  EXPECT_THROW(render(scene, accel, bdpt, {.spp = 8, .filter = FilterKind::kGaussian}), Error);
  Film film(16, 16);
  EXPECT_THROW(
      render_to_film(scene, accel, bdpt, film, {.spp = 8, .tile_part = 1, .tile_parts = 2}), Error);
  // Without light tracing they are the first version's, and allowed.
  const BdptIntegrator without(scene, {.light_tracing = false});
  EXPECT_NO_THROW(render(scene, accel, without, {.spp = 8, .tile_part = 0, .tile_parts = 2}));
}

// ---- The caustic of a point light under a glass sphere ----
//
// A point light of intensity I at height D above the centre of a glass sphere (radius 1, index
// 1.5, a fine mesh with vertex normals), a diffuse disk of albedo 0.5 and radius 0.9 at gap 1
// below the sphere, nothing else. The disk lies in the sphere's shadow, and light reflected off
// the sphere's outside cannot reach it (a ray leaving a convex body downward from its upper half
// stays at least the body's radius from the axis), so with --max-depth 3 its only light is the
// light refracted into the sphere and out again. Its flux is I times the integral, over the
// directions from the light that meet the sphere and whose twice-refracted ray lands on the disk,
// of the two Fresnel transmittances: integrated here by tracing the analytic sphere. The camera
// sees the disk from 30 degrees above the horizon, clear of the sphere; E = pi L / albedo per
// pixel, times the disk area the pixel covers, sums to the flux.
constexpr double kLightHeight = 4.0;  // above the sphere's centre
constexpr double kFloorY = -2.0;      // the disk's plane (gap 1 below the sphere)
constexpr double kDiskRadius = 0.9;
constexpr int kDiskSides = 256;
constexpr double kIor = 1.5;
constexpr double kIntensity = 10.0;
constexpr float kFloorAlbedo = 0.5f;

// Unpolarised Fresnel reflectance of a dielectric interface (Born and Wolf), cos_i > 0 on the
// incident side, eta = n_transmitted / n_incident.
double fresnel(double cos_i, double eta) {
  const double sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0) return 1.0;
  const double cos_t = std::sqrt(1.0 - sin2_t);
  const double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

// Refracts unit d through unit normal n (facing against d), eta = n_t / n_i.
glm::dvec3 refract_dir(glm::dvec3 d, glm::dvec3 n, double eta) {
  const double cos_i = -glm::dot(d, n);
  const double k = 1.0 - (1.0 - cos_i * cos_i) / (eta * eta);
  return d / eta + (cos_i / eta - std::sqrt(k)) * n;
}

// Whether (x, z) lies in the regular kDiskSides-gon of circumradius kDiskRadius with a corner at
// angle 0 (the mesh's disk).
bool in_disk(double x, double z) {
  const double sector = 2.0 * std::numbers::pi / kDiskSides;
  double a = std::atan2(z, x);
  if (a < 0.0) a += 2.0 * std::numbers::pi;
  const double mid = (std::floor(a / sector) + 0.5) * sector;
  return x * std::cos(mid) + z * std::sin(mid) <= kDiskRadius * std::cos(0.5 * sector);
}

// The oracle: the disk's flux, by the midpoint rule over (cos theta, phi) of the light's
// directions into the sphere's cone.
double analytic_disk_flux() {
  const double cos_max = std::sqrt(1.0 - 1.0 / (kLightHeight * kLightHeight));
  const int n_theta = 4000, n_phi = 64;
  const glm::dvec3 light(0.0, kLightHeight, 0.0);
  double flux = 0.0;
  for (int i = 0; i < n_theta; ++i) {
    const double c = cos_max + (1.0 - cos_max) * (i + 0.5) / n_theta;
    const double s = std::sqrt(1.0 - c * c);
    for (int j = 0; j < n_phi; ++j) {
      const double phi = 2.0 * std::numbers::pi * (j + 0.5) / n_phi;
      const glm::dvec3 d(s * std::cos(phi), -c, s * std::sin(phi));
      // Entry: |light + t d| = 1.
      const double b = glm::dot(light, d);
      const double disc = b * b - (glm::dot(light, light) - 1.0);
      if (disc <= 0.0) continue;
      const glm::dvec3 p1 = light + (-b - std::sqrt(disc)) * d;
      const glm::dvec3 n1 = glm::normalize(p1);
      const double t1 = 1.0 - fresnel(-glm::dot(d, n1), kIor);
      const glm::dvec3 d2 = refract_dir(d, n1, kIor);
      // Exit: the chord's other end.
      const glm::dvec3 p2 = p1 - 2.0 * glm::dot(p1, d2) * d2;
      const glm::dvec3 n2 = glm::normalize(p2);
      const double cos2 = glm::dot(d2, n2);
      const double t2 = 1.0 - fresnel(cos2, 1.0 / kIor);
      if (t2 <= 0.0) continue;
      const glm::dvec3 d3 = refract_dir(d2, -n2, 1.0 / kIor);
      if (d3.y >= 0.0) continue;
      const glm::dvec3 q = p2 + ((kFloorY - p2.y) / d3.y) * d3;
      if (!in_disk(q.x, q.z)) continue;
      flux += t1 * t2;
    }
  }
  return kIntensity * flux * (1.0 - cos_max) / n_theta * (2.0 * std::numbers::pi) / n_phi;
}

Scene caustic_scene(int side) {
  Scene scene;
  scene.materials.push_back(Material{.albedo = glm::vec3(1.0f),
                                     .type = MaterialType::kDielectric,
                                     .roughness = 0.0f,
                                     .ior = static_cast<float>(kIor)});
  scene.materials.push_back(Material{.albedo = glm::vec3(kFloorAlbedo)});
  // The sphere: a latitude-longitude mesh with its vertices on the unit sphere and their normals,
  // each triangle's lab normal (cross(e2, e1)) outward, as the glass's inside needs.
  const int n_lat = 128, n_lon = 256;
  const auto at = [&](int i, int j) {
    const double th = std::numbers::pi * i / n_lat, ph = 2.0 * std::numbers::pi * j / n_lon;
    return glm::vec3(static_cast<float>(std::sin(th) * std::cos(ph)),
                     static_cast<float>(std::cos(th)),
                     static_cast<float>(std::sin(th) * std::sin(ph)));
  };
  const auto add = [&](glm::vec3 a, glm::vec3 b, glm::vec3 c, uint32_t material, bool smooth) {
    if (glm::dot(glm::cross(c - a, b - a), a + b + c) < 0.0f) std::swap(b, c);
    if (glm::length(glm::cross(c - a, b - a)) == 0.0f) return;
    if (smooth) {
      const std::array<glm::vec3, 3> n{glm::normalize(a), glm::normalize(b), glm::normalize(c)};
      scene.mesh.add(a, b, c, material, n);
    } else {
      scene.mesh.add(a, b, c, material);
    }
  };
  for (int i = 0; i < n_lat; ++i) {
    for (int j = 0; j < n_lon; ++j) {
      const glm::vec3 a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      if (i > 0) add(a, b, d, 0, true);
      if (i + 1 < n_lat) add(b, c, d, 0, true);
    }
  }
  const auto floor_add = [&](glm::vec3 a, glm::vec3 b, glm::vec3 c) {
    // Facing up (towards the light): the lab normal's side.
    if (glm::cross(c - a, b - a).y < 0.0f) std::swap(b, c);
    scene.mesh.add(a, b, c, 1);
  };
  const glm::vec3 centre(0.0f, static_cast<float>(kFloorY), 0.0f);
  for (int k = 0; k < kDiskSides; ++k) {
    const double a0 = 2.0 * std::numbers::pi * k / kDiskSides;
    const double a1 = 2.0 * std::numbers::pi * (k + 1) / kDiskSides;
    const auto rim = [&](double a) {
      return glm::vec3(static_cast<float>(kDiskRadius * std::cos(a)), static_cast<float>(kFloorY),
                       static_cast<float>(kDiskRadius * std::sin(a)));
    };
    floor_add(centre, rim(a0), rim(a1));
  }
  scene.lights.push_back({glm::vec3(0.0f, static_cast<float>(kLightHeight), 0.0f),
                          glm::vec3(static_cast<float>(4.0 * std::numbers::pi * kIntensity))});
  const double elevation = std::numbers::pi / 6.0, distance = 4.0;
  const glm::vec3 eye(0.0f, static_cast<float>(kFloorY + distance * std::sin(elevation)),
                      static_cast<float>(distance * std::cos(elevation)));
  scene.camera = Camera::look_at(side, side, eye, centre, glm::vec3(0.0f, 1.0f, 0.0f),
                                 Camera::focal_for_vertical_fov(side, 34.0));
  return scene;
}

// The flux onto the disk read off an image of caustic_scene: per pixel E = pi L / albedo times the
// floor area its solid angle covers (pixels whose centre ray meets the disk's plane within 1.2 of
// the axis: nothing else is lit there, and the sphere is not in front of them).
double image_disk_flux(const Scene& scene, const Image& image) {
  const Camera& cam = scene.camera;
  const double f = cam.focal_px();
  double flux = 0.0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const Ray r = cam.ray_through(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
      const glm::dvec3 o(r.origin), d(r.dir);
      if (d.y >= 0.0) continue;
      const double t = (kFloorY - o.y) / d.y;
      const glm::dvec3 q = o + t * d;
      if (q.x * q.x + q.z * q.z > 1.44) continue;
      const double cos_cam = glm::dot(d, glm::dvec3(cam.forward()));
      const double area = cos_cam * cos_cam * cos_cam / (f * f) * t * t / -d.y;
      const glm::vec3 l = image.at(x, y);
      flux += std::numbers::pi * ((l.x + l.y + l.z) / 3.0) / kFloorAlbedo * area;
    }
  }
  return flux;
}

TEST(BdptLightTracing, PointLightCausticUnderGlassCarriesTheFresnelTransmittedFlux) {
  const double expected = analytic_disk_flux();
  // Sanity of the oracle: at most the light's flux into the sphere's cone, and a good part of it.
  const double cone = kIntensity * 2.0 * std::numbers::pi *
                      (1.0 - std::sqrt(1.0 - 1.0 / (kLightHeight * kLightHeight)));
  ASSERT_GT(expected, 0.2 * cone);
  ASSERT_LT(expected, cone);

  const int side = 64;
  const Scene scene = caustic_scene(side);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene, {.max_depth = 3});
  const MeanAndError got = mean_of(4, [&](int i) {
    return image_disk_flux(scene, render(scene, accel, bdpt, {.spp = 128, .seed = 70u + i}));
  });
  const PathIntegrator path_tracer(scene, {.max_depth = 3});
  const double path = image_disk_flux(scene, render(scene, accel, path_tracer, {.spp = 64}));
  std::printf("  disk flux: bdpt %.5f +- %.5f, analytic %.5f (cone %.5f), path %.5f\n", got.mean,
              got.error, expected, cone, path);
  EXPECT_EQ(path, 0.0);  // no path tracer's sample reaches a point light through glass
  // Within 4 standard errors plus 2% for the mesh (facets inside the sphere, interpolated
  // normals) and the pixels at the disk's rim.
  EXPECT_LT(std::abs(got.mean - expected), 4.0 * got.error + 0.02 * expected);
  EXPECT_LT(got.error, 0.02 * expected);  // the test has power
}

// ---- Light tracing alone from a spot light or the sun onto a plane, through a pinhole or a lens
// ----
//
// A diffuse plane y = 1 (albedo 0.5, half-width 2.6) and a camera at (0.3, -1.2, -0.2) looking
// straight at it (forward +y, 90 degrees), lit by a spot light at (0, -1, 0) aiming at it (+y,
// cones 20 and 40 degrees, pbrt's smoothstep falloff) or by the sun (irradiance (1, 2, 3) on a
// surface facing it, 30 degrees from the normal). A point p of the plane reflects
// L = albedo / pi * E: under the spot E = I falloff(cos a) cos a / r^2, a the angle of p from the
// axis, which is also the plane's normal (r: p's distance from the light); under the sun E cos 30.
// Strategy (2, 1) alone, unweighted, at --max-depth 1 (light tracing only: the light subpath's
// first hit connected to the camera) estimates each pixel's mean of L over the points it sees:
// integrated here by 16 x 16 pinhole rays per pixel. A lens of radius 0.3 focused on the plane
// (distance 2.2) sees every point of it in the pixel the pinhole does, and a diffuse point looks
// the same from every lens point, so the expected image is the pinhole's. The same for an
// orthographic camera with that lens (parallel rays without it, which light tracing cannot reach):
// the plane points under the pixel's square.
constexpr float kPlaneY = 1.0f;
constexpr float kPlaneAlbedo = 0.5f;
const glm::vec3 kEye(0.3f, -1.2f, -0.2f);

struct PlaneCase {
  bool sun;
  bool lens;
  bool orthographic = false;  // showing 3 x 3 of the plane (the perspective view 4.4 x 4.4)
};

Scene plane_scene(const PlaneCase& c, int side) {
  Scene scene;
  scene.materials.push_back({.albedo = glm::vec3(kPlaneAlbedo)});
  const float h = 2.6f;
  scene.mesh.add({-h, kPlaneY, -h}, {h, kPlaneY, -h}, {h, kPlaneY, h}, 0);
  scene.mesh.add({-h, kPlaneY, -h}, {h, kPlaneY, h}, {-h, kPlaneY, h}, 0);
  if (c.sun) {
    const float a = static_cast<float>(std::numbers::pi / 6.0);
    scene.directional_lights.push_back(
        {.direction = {std::sin(a), std::cos(a), 0.0f}, .irradiance = {1.0f, 2.0f, 3.0f}});
  } else {
    scene.spot_lights.push_back(
        {.position = {0.0f, -1.0f, 0.0f},
         .direction = {0.0f, 1.0f, 0.0f},
         .intensity = {3.0f, 6.0f, 9.0f},
         .cos_inner = static_cast<float>(std::cos(20.0 * std::numbers::pi / 180.0)),
         .cos_outer = static_cast<float>(std::cos(40.0 * std::numbers::pi / 180.0)),
         .falloff = SpotFalloff::kSmoothstep});
  }
  scene.camera =
      Camera::look_at(side, side, kEye, kEye + glm::vec3(0.0f, 1.0f, 0.0f),
                      glm::vec3(0.0f, 0.0f, 1.0f), Camera::focal_for_vertical_fov(side, 90.0));
  if (c.orthographic) scene.camera = scene.camera.orthographic(3.0f / static_cast<float>(side));
  if (c.lens) scene.camera = scene.camera.with_lens(0.3f, kPlaneY - kEye.y);
  return scene;
}

// The mean luminance of L over the plane points pixel (x, y) sees, in double.
double expected_pixel(const Scene& scene, const PlaneCase& c, int x, int y) {
  const Camera& cam = scene.camera;
  const glm::dvec3 eye(cam.position()), right(cam.right()), down(cam.down()),
      forward(cam.forward());
  const double f = cam.focal_px();
  const double pi = std::numbers::pi;
  double sum = 0.0;
  constexpr int kSub = 16;
  for (int j = 0; j < kSub; ++j) {
    for (int i = 0; i < kSub; ++i) {
      const double px = x + (i + 0.5) / kSub - cam.width() / 2;
      const double py = y + (j + 0.5) / kSub - cam.height() / 2;
      glm::dvec3 p;
      if (c.orthographic) {
        const double s = cam.ortho_scale();
        p = eye + right * (px * s) + down * (py * s) + forward * (kPlaneY - eye.y);
      } else {
        const glm::dvec3 d = right * px + down * py + forward * f;
        p = eye + d * ((kPlaneY - eye.y) / d.y);
      }
      double e;
      if (c.sun) {
        e = 2.0 * std::cos(pi / 6.0);  // the channels' mean irradiance, 2
      } else {
        const glm::dvec3 to_p = p - glm::dvec3(0.0, -1.0, 0.0);
        const double r2 = glm::dot(to_p, to_p);
        const double cos_a = to_p.y / std::sqrt(r2);
        const double ci = std::cos(20.0 * pi / 180.0), co = std::cos(40.0 * pi / 180.0);
        const double t = std::clamp((cos_a - co) / (ci - co), 0.0, 1.0);
        e = 6.0 * t * t * (3.0 - 2.0 * t) * cos_a / r2;  // the mean intensity, 6
      }
      sum += kPlaneAlbedo / pi * e;
    }
  }
  return sum / (kSub * kSub);
}

class LightTracingOntoAPlane : public ::testing::TestWithParam<PlaneCase> {};

TEST_P(LightTracingOntoAPlane, GivesTheHandComputedRadiance) {
  const PlaneCase c = GetParam();
  const int side = 32, block = 8;
  const Scene scene = plane_scene(c, side);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator alone(scene, {.max_depth = 1, .only_s = 2, .only_t = 1, .unweighted = true});
  ASSERT_TRUE(alone.splats());
  const Image image = render(scene, accel, alone, {.spp = 256, .seed = 3});
  double got_sum = 0.0, want_sum = 0.0, worst = 0.0;
  std::vector<double> got_blocks, want_blocks;
  for (int by = 0; by < side / block; ++by) {
    for (int bx = 0; bx < side / block; ++bx) {
      double got = 0.0, want = 0.0;
      for (int y = by * block; y < (by + 1) * block; ++y) {
        for (int x = bx * block; x < (bx + 1) * block; ++x) {
          const glm::vec3 l = image.at(x, y);
          got += (l.x + l.y + l.z) / 3.0;
          want += expected_pixel(scene, c, x, y);
        }
      }
      got_blocks.push_back(got);
      want_blocks.push_back(want);
      got_sum += got;
      want_sum += want;
    }
  }
  for (size_t k = 0; k < got_blocks.size(); ++k) {
    // Blocks at the cone's rim, which few light subpaths reach, and outside it (black) are compared
    // against a fifth of the mean block.
    const double scale =
        std::max(want_blocks[k], 0.2 * want_sum / static_cast<double>(got_blocks.size()));
    worst = std::max(worst, std::abs(got_blocks[k] - want_blocks[k]) / scale);
  }
  std::printf("  image mean %.6f, hand computed %.6f (ratio %.5f), worst 8 x 8 block %.4f\n",
              got_sum / (side * side), want_sum / (side * side), got_sum / want_sum, worst);
  EXPECT_NEAR(got_sum / want_sum, 1.0, 0.01);
  EXPECT_LT(worst, 0.03);
}

INSTANTIATE_TEST_SUITE_P(SpotAndSun, LightTracingOntoAPlane,
                         ::testing::Values(PlaneCase{false, false}, PlaneCase{false, true},
                                           PlaneCase{true, true}, PlaneCase{false, true, true},
                                           PlaneCase{true, true, true}));

}  // namespace
}  // namespace tritrace

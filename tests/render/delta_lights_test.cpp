// Spot and directional lights in the path tracer against hand-computed irradiance: a diffuse plane
// lit by one delta light reflects radiance albedo / pi * E, where E = I falloff cos / r^2 under a
// spot light and E cos under a directional one. With a single delta light and no environment the
// estimate has no variance (the light is chosen with probability 1 and nothing else is lit), so
// one sample per point is the exact answer up to float rounding. Also: the light sampler's choice
// in proportion to power, scene-file lights and their errors, and the lab integrator's refusal.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "tritrace/accel/brute_force.h"
#include "tritrace/error.h"
#include "tritrace/job/job_settings.h"
#include "tritrace/job/render_job.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/light_sampler.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/scene/io/scene_file.h"
#include "tritrace/scene/io/scene_loader.h"
#include "tritrace/scene/transform.h"

namespace tritrace {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr float kAlbedo = 0.6f;

double radians(double degrees) {
  return degrees * kPi / 180.0;
}

// A square diffuse plane y = 0 of half-width 100 (the lab's world is y-down: "above" is -y).
Scene plane_scene() {
  Scene scene;
  scene.materials.push_back({.albedo = glm::vec3(kAlbedo)});
  scene.mesh.add({-100, 0, -100}, {100, 0, -100}, {100, 0, 100}, 0);
  scene.mesh.add({-100, 0, -100}, {100, 0, 100}, {-100, 0, 100}, 0);
  return scene;
}

// The path tracer's radiance seen at point (x, 0, z) of the plane from above.
glm::vec3 radiance_at(const Scene& scene, float x, float z, int max_depth = 1) {
  const BruteForceAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene, PathSettings{.max_depth = max_depth});
  const glm::vec3 target(x, 0.0f, z);
  const glm::vec3 eye = target + glm::vec3(0.1f, -1.0f, -0.2f);
  Ray ray;
  ray.origin = eye;
  ray.dir = glm::normalize(target - eye);
  ray.tmin = 0.0f;
  ray.tmax = kRayTMax;
  Sampler sampler(5);
  sampler.start_pixel_sample(0, 0, 0);
  glm::vec3 radiance;
  pt.radiance(SampleBatch{std::span<const Ray>(&ray, 1), std::span<Sampler>(&sampler, 1)},
              SampleOutput{std::span<glm::vec3>(&radiance, 1)}, scene, accel);
  return radiance;
}

// A spot light at height h above the origin, pointing down at the plane, cones 20 and 40 degrees.
constexpr double kHeight = 2.0, kInner = 20.0, kOuter = 40.0;
const glm::vec3 kIntensity(3.0f, 6.0f, 9.0f);

SpotLight down_spot(SpotFalloff falloff) {
  return {.position = {0.0f, static_cast<float>(-kHeight), 0.0f},
          .direction = {0.0f, 1.0f, 0.0f},
          .intensity = kIntensity,
          .cos_inner = static_cast<float>(std::cos(radians(kInner))),
          .cos_outer = static_cast<float>(std::cos(radians(kOuter))),
          .falloff = falloff};
}

// The falloff written out from its definition (glTF's KHR_lights_punctual, pbrt-v4's smoothstep)
// in double, at the angle theta from the axis.
double expected_falloff(double theta_degrees, SpotFalloff falloff) {
  const double c = std::cos(radians(theta_degrees));
  const double ci = std::cos(radians(kInner)), co = std::cos(radians(kOuter));
  const double t = std::clamp((c - co) / (ci - co), 0.0, 1.0);
  return falloff == SpotFalloff::kGltf ? t * t : t * t * (3.0 - 2.0 * t);
}

struct SpotCase {
  double theta_degrees;  // of the lit point, from the spot's axis
  SpotFalloff falloff;
};

class SpotOnPlane : public ::testing::TestWithParam<SpotCase> {};

// The point at angle theta from the axis lies at d = h tan(theta) on the plane, r = h / cos(theta)
// from the light, and sees it at the same angle theta from the plane's normal:
// E = I falloff(theta) cos(theta) / r^2.
TEST_P(SpotOnPlane, RadianceIsAlbedoOverPiTimesIcosOverR2TimesFalloff) {
  const SpotCase c = GetParam();
  Scene scene = plane_scene();
  scene.spot_lights.push_back(down_spot(c.falloff));
  const double theta = radians(c.theta_degrees);
  const double d = kHeight * std::tan(theta);
  const double r2 = kHeight * kHeight + d * d;
  const double e_over_i = expected_falloff(c.theta_degrees, c.falloff) * std::cos(theta) / r2;
  // Along a diagonal, so that neither x nor z is special.
  const float x = static_cast<float>(d * std::sqrt(0.5)),
              z = static_cast<float>(-d * std::sqrt(0.5));
  const glm::vec3 l = radiance_at(scene, x, z);
  for (int ch = 0; ch < 3; ++ch) {
    const double want = kAlbedo / kPi * kIntensity[ch] * e_over_i;
    EXPECT_NEAR(l[ch], want, 1e-5 * kIntensity[ch]) << "channel " << ch;
  }
  if (c.theta_degrees > kOuter) {
    EXPECT_EQ(l, glm::vec3(0.0f));
  }
}

INSTANTIATE_TEST_SUITE_P(
    Angles, SpotOnPlane,
    ::testing::Values(SpotCase{0.0, SpotFalloff::kGltf}, SpotCase{12.0, SpotFalloff::kGltf},
                      SpotCase{25.0, SpotFalloff::kGltf}, SpotCase{30.0, SpotFalloff::kGltf},
                      SpotCase{38.0, SpotFalloff::kGltf}, SpotCase{50.0, SpotFalloff::kGltf},
                      SpotCase{12.0, SpotFalloff::kSmoothstep},
                      SpotCase{30.0, SpotFalloff::kSmoothstep},
                      SpotCase{50.0, SpotFalloff::kSmoothstep}));

// The falloff at a few angles, written as numbers: inside the inner cone 1, at the middle of the
// falloff zone (t = 1/2) 1/4 for glTF and 1/2 for smoothstep, outside 0.
TEST(SpotFalloff, IsOneInsideZeroOutsideAndTheDocumentedCurveBetween) {
  SpotLight l;
  l.cos_inner = 0.8f;
  l.cos_outer = 0.4f;
  l.falloff = SpotFalloff::kGltf;
  EXPECT_EQ(spot_falloff(l, 0.9f), 1.0f);
  EXPECT_EQ(spot_falloff(l, 0.8f), 1.0f);
  EXPECT_NEAR(spot_falloff(l, 0.6f), 0.25f, 1e-6f);
  EXPECT_NEAR(spot_falloff(l, 0.5f), 0.0625f, 1e-6f);
  EXPECT_EQ(spot_falloff(l, 0.4f), 0.0f);
  EXPECT_EQ(spot_falloff(l, -1.0f), 0.0f);
  l.falloff = SpotFalloff::kSmoothstep;
  EXPECT_NEAR(spot_falloff(l, 0.6f), 0.5f, 1e-6f);
  EXPECT_NEAR(spot_falloff(l, 0.5f), 3.0f / 16.0f - 2.0f / 64.0f, 1e-6f);
}

// E cos(theta) for a directional light travelling along (0.6, 0.8, 0): the plane's upward normal
// (0, -1, 0) is at cos 0.8 from the direction towards the light.
TEST(DirectionalOnPlane, RadianceIsAlbedoOverPiTimesIrradianceTimesCos) {
  Scene scene = plane_scene();
  const glm::vec3 e(2.0f, 4.0f, 5.0f);
  scene.directional_lights.push_back({.direction = {0.6f, 0.8f, 0.0f}, .irradiance = e});
  for (const glm::vec2 p : {glm::vec2(0.0f), glm::vec2(7.5f, -3.0f), glm::vec2(-60.0f, 80.0f)}) {
    const glm::vec3 l = radiance_at(scene, p.x, p.y);
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_NEAR(l[ch], kAlbedo / kPi * e[ch] * 0.8, 1e-5 * e[ch]) << p.x << "," << p.y;
    }
  }
  // With more bounces nothing changes: the plane sees nothing else.
  EXPECT_NEAR(radiance_at(scene, 1.0f, 1.0f, 5).y, kAlbedo / kPi * 4.0 * 0.8, 4e-5);
}

// A directional light from below the plane lights its other side only, and a spot light pointing
// away lights nothing.
TEST(DeltaLights, LightFromTheOtherSideOrPointingAwayGivesNothing) {
  Scene scene = plane_scene();
  scene.directional_lights.push_back({.direction = {0.0f, -1.0f, 0.0f}, .irradiance = {1, 1, 1}});
  EXPECT_EQ(radiance_at(scene, 0.5f, 0.5f), glm::vec3(0.0f));
  scene.directional_lights.clear();
  SpotLight away = down_spot(SpotFalloff::kGltf);
  away.direction = {0.0f, -1.0f, 0.0f};
  scene.spot_lights.push_back(away);
  EXPECT_EQ(radiance_at(scene, 0.1f, 0.1f), glm::vec3(0.0f));
}

// An occluder between the plane and the light casts a shadow, for each kind: the shadow ray runs
// to the spot's position and to infinity along the directional light's direction.
TEST(DeltaLights, AnOccluderCastsAShadow) {
  for (int kind = 0; kind < 2; ++kind) {
    Scene scene = plane_scene();
    // A small square at height 1 around (0, -1, 0) (a second, black material).
    scene.materials.push_back({.albedo = glm::vec3(0.0f)});
    scene.mesh.add({-0.5f, -1, -0.5f}, {0.5f, -1, -0.5f}, {0.5f, -1, 0.5f}, 1);
    scene.mesh.add({-0.5f, -1, -0.5f}, {0.5f, -1, 0.5f}, {-0.5f, -1, 0.5f}, 1);
    if (kind == 0) {
      scene.spot_lights.push_back(down_spot(SpotFalloff::kGltf));
    } else {
      scene.directional_lights.push_back(
          {.direction = {0.0f, 1.0f, 0.0f}, .irradiance = glm::vec3(1.0f)});
    }
    // Straight under the square: shadowed; beside it (seen past its edge): lit.
    const BruteForceAccel accel(scene.mesh, kDefaultKernel);
    const PathIntegrator pt(scene, PathSettings{.max_depth = 1});
    Ray ray;
    ray.origin = {2.0f, -0.5f, 0.0f};
    ray.dir = glm::normalize(glm::vec3(-2.0f, 0.5f, 0.0f));  // to (0, 0, 0), under the square
    ray.tmin = 0.0f;
    ray.tmax = kRayTMax;
    Sampler sampler(5);
    sampler.start_pixel_sample(0, 0, 0);
    glm::vec3 radiance;
    pt.radiance(SampleBatch{std::span<const Ray>(&ray, 1), std::span<Sampler>(&sampler, 1)},
                SampleOutput{std::span<glm::vec3>(&radiance, 1)}, scene, accel);
    EXPECT_EQ(radiance, glm::vec3(0.0f)) << "kind " << kind;
    EXPECT_GT(radiance_at(scene, 1.2f, 0.9f).x, 0.0f) << "kind " << kind;
  }
}

// On a glossy surface (a rough conductor, shaded through its BSDF rather than the Lambert branch)
// the new kinds agree with the point light they stand for: a spot light seen inside its inner cone
// is a point light of power 4 pi I, and a directional light is the limit of a point light far away
// along -direction with power 4 pi E d^2 (at d = 1e4 the directions differ by under 1e-3 rad
// across the points used, which changes the radiance by far less than the tolerance).
TEST(DeltaLights, OnAGlossySurfaceTheyMatchTheEquivalentPointLight) {
  Scene base = plane_scene();
  base.materials[0] = Material{
      .albedo = glm::vec3(0.9f, 0.6f, 0.3f), .type = MaterialType::kConductor, .roughness = 0.5f};
  const glm::vec2 points[] = {{0.1f, 0.2f}, {-0.4f, 0.3f}, {0.3f, -0.1f}};
  Scene spot = base, point = base;
  spot.spot_lights.push_back(down_spot(SpotFalloff::kGltf));
  point.lights.push_back({spot.spot_lights[0].position, kIntensity * static_cast<float>(4 * kPi)});
  for (const glm::vec2 p : points) {
    const glm::vec3 a = radiance_at(spot, p.x, p.y), b = radiance_at(point, p.x, p.y);
    ASSERT_GT(b.x, 0.0f);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(a[ch], b[ch], 1e-5f * b[ch]) << p.x << "," << p.y;
  }
  Scene sun = base, far = base;
  const glm::vec3 dir = glm::normalize(glm::vec3(0.3f, 1.0f, 0.2f));
  const glm::vec3 e(1.0f, 2.0f, 3.0f);
  const double d = 1e4;
  sun.directional_lights.push_back({.direction = dir, .irradiance = e});
  far.lights.push_back({-dir * static_cast<float>(d), e * static_cast<float>(4 * kPi * d * d)});
  for (const glm::vec2 p : points) {
    const glm::vec3 a = radiance_at(sun, p.x, p.y), b = radiance_at(far, p.x, p.y);
    ASSERT_GT(b.x, 0.0f);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(a[ch], b[ch], 2e-3f * b[ch]) << p.x << "," << p.y;
  }
}

// transformed() (a uniform scale s and a translation) moves a spot light with the scene and
// multiplies its intensity by s^2, so the radiance at corresponding points stays (I s^2 / (s r)^2);
// a directional light stays as it is. Every light's power (the directional one's E pi r^2 over the
// scene's bounds included) scales by s^2, so the light sampler chooses alike and one sample is
// comparable point for point.
TEST(DeltaLights, ASimilarityKeepsTheirLightAtCorrespondingPoints) {
  Scene scene = plane_scene();
  scene.spot_lights.push_back(down_spot(SpotFalloff::kGltf));
  scene.directional_lights.push_back(
      {.direction = glm::normalize(glm::vec3(0.2f, 1.0f, 0.1f)), .irradiance = glm::vec3(0.5f)});
  const Similarity xf{.scale = 2.0f, .translation = {1.0f, -3.0f, 0.5f}};
  const Scene moved = transformed(scene, xf);
  ASSERT_EQ(moved.spot_lights.size(), 1u);
  EXPECT_EQ(moved.spot_lights[0].position, xf.apply(scene.spot_lights[0].position));
  EXPECT_EQ(moved.spot_lights[0].direction, scene.spot_lights[0].direction);
  EXPECT_EQ(moved.spot_lights[0].intensity, kIntensity * 4.0f);
  ASSERT_EQ(moved.directional_lights.size(), 1u);
  EXPECT_EQ(moved.directional_lights[0].irradiance, glm::vec3(0.5f));
  for (const glm::vec2 p : {glm::vec2(0.3f, 0.1f), glm::vec2(-0.6f, 0.9f)}) {
    const glm::vec3 q = xf.apply(glm::vec3(p.x, 0.0f, p.y));
    // radiance_at looks at the plane y = 0; the moved plane is y = -3: aim at it directly.
    const BruteForceAccel accel(moved.mesh, kDefaultKernel);
    const PathIntegrator pt(moved, PathSettings{.max_depth = 1});
    Ray ray;
    ray.origin = q + glm::vec3(0.1f, -1.0f, -0.2f);
    ray.dir = glm::normalize(q - ray.origin);
    ray.tmin = 0.0f;
    ray.tmax = kRayTMax;
    Sampler sampler(5);
    sampler.start_pixel_sample(0, 0, 0);
    glm::vec3 l;
    pt.radiance(SampleBatch{std::span<const Ray>(&ray, 1), std::span<Sampler>(&sampler, 1)},
                SampleOutput{std::span<glm::vec3>(&l, 1)}, moved, accel);
    const glm::vec3 want = radiance_at(scene, p.x, p.y);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(l[ch], want[ch], 1e-4f * want[ch]) << ch;
  }
}

// With several lights each sample takes one, chosen by power, and divides by its probability: the
// mean over samples is the sum of the lights' radiance (hand-computed as above), within four
// standard errors of the two-point estimator (its variance sum v_i^2 / p_i - (sum v_i)^2 computed
// from the sampler's own probabilities), with a fixed seed.
TEST(DeltaLights, SeveralLightsChosenByPowerAverageToTheirSum) {
  Scene scene = plane_scene();
  scene.spot_lights.push_back(down_spot(SpotFalloff::kGltf));
  scene.directional_lights.push_back({.direction = {0.6f, 0.8f, 0.0f}, .irradiance = {1, 1, 1}});
  const LightSampler lights(scene);
  ASSERT_EQ(lights.size(), 2u);
  const double theta = radians(12.0), d = kHeight * std::tan(theta);
  const double v[2] = {kAlbedo / kPi * kIntensity.y * std::cos(theta) * std::cos(theta) *
                           std::cos(theta) / (kHeight * kHeight),
                       kAlbedo / kPi * 1.0 * 0.8};
  const double p[2] = {lights.pmf(0), lights.pmf(1)};
  const double mean = v[0] + v[1];
  const double var = v[0] * v[0] / p[0] + v[1] * v[1] / p[1] - mean * mean;
  const BruteForceAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene, PathSettings{.max_depth = 1});
  const glm::vec3 target(static_cast<float>(d), 0.0f, 0.0f);
  Ray ray;
  ray.origin = target + glm::vec3(0.1f, -1.0f, -0.2f);
  ray.dir = glm::normalize(target - ray.origin);
  ray.tmin = 0.0f;
  ray.tmax = kRayTMax;
  constexpr int kN = 4000;
  Sampler sampler(17, SamplerKind::kIndependent);
  double sum = 0.0;
  for (int i = 0; i < kN; ++i) {
    sampler.start_pixel_sample(0, 0, static_cast<uint32_t>(i));
    glm::vec3 l;
    pt.radiance(SampleBatch{std::span<const Ray>(&ray, 1), std::span<Sampler>(&sampler, 1)},
                SampleOutput{std::span<glm::vec3>(&l, 1)}, scene, accel);
    sum += l.y;
  }
  EXPECT_NEAR(sum / kN, mean, 4.0 * std::sqrt(var / kN));
}

// Each light is chosen in proportion to its power: a point light of power 4 pi, a spot light of
// intensity I (power I 2 pi (1 - cos_i + (cos_i - cos_o) / 3), the integral of the glTF falloff
// t^2 over the cosine), and a directional light of irradiance E over the scene's bounding sphere
// (E pi r^2, r half the box's diagonal).
TEST(LightSampling, ChoosesSpotAndDirectionalLightsInProportionToPower) {
  Scene scene;
  scene.materials.push_back({.albedo = glm::vec3(0.5f)});
  scene.mesh.add({0, 0, 0}, {2, 0, 0}, {0, 1, 2}, 0);  // box (0,0,0)-(2,1,2): r = 1.5
  scene.lights.push_back({glm::vec3(0.0f, -1.0f, 0.0f), glm::vec3(4.0 * kPi)});
  SpotLight spot = down_spot(SpotFalloff::kGltf);
  spot.intensity = glm::vec3(5.0f);
  scene.spot_lights.push_back(spot);
  SpotLight smooth = down_spot(SpotFalloff::kSmoothstep);
  smooth.intensity = glm::vec3(5.0f);
  scene.spot_lights.push_back(smooth);
  scene.directional_lights.push_back({.direction = {0, 1, 0}, .irradiance = glm::vec3(0.5f)});
  const LightSampler lights(scene);
  ASSERT_EQ(lights.size(), 4u);
  const double ci = std::cos(radians(kInner)), co = std::cos(radians(kOuter));
  const double power[] = {4.0 * kPi, 5.0 * 2.0 * kPi * (1.0 - ci + (ci - co) / 3.0),
                          5.0 * 2.0 * kPi * (1.0 - ci + (ci - co) / 2.0), 0.5 * kPi * 1.5 * 1.5};
  const double total = power[0] + power[1] + power[2] + power[3];
  for (size_t i = 0; i < 4; ++i) EXPECT_NEAR(lights.pmf(i), power[i] / total, 1e-6) << i;
  // The directional light's sample: its direction, delta and infinite, irradiance as radiance.
  bool found = false;
  for (int k = 0; k < 1000 && !found; ++k) {
    const LightSample s = lights.sample(scene, glm::vec3(1.0f), (k + 0.5f) / 1000.0f, {0.5f, 0.5f});
    if (!s.infinite) continue;
    found = true;
    EXPECT_TRUE(s.delta);
    EXPECT_EQ(s.wi, glm::vec3(0.0f, -1.0f, 0.0f));
    EXPECT_EQ(s.radiance, glm::vec3(0.5f));
    EXPECT_NEAR(s.pdf, power[3] / total, 1e-6);
  }
  EXPECT_TRUE(found);
}

// Scenes without spot or directional lights sample exactly as before: the point light and the
// triangles keep their probabilities (the pinned images depend on it).
TEST(LightSampling, PointAndTriangleWeightsAreUnchangedWithoutTheNewKinds) {
  Scene scene;
  scene.lights.push_back({glm::vec3(0.0f, -1.0f, 0.0f), glm::vec3(10.0f, 14.0f, 18.0f)});
  scene.materials.push_back({.albedo = glm::vec3(0.0f), .emission = glm::vec3(2.0f)});
  scene.mesh.add({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 0);
  const LightSampler lights(scene);
  const double point = 14.0, tri = 2.0 * 0.5 * kPi;
  EXPECT_NEAR(lights.pmf(0), point / (point + tri), 1e-6);
}

// --- Scene files ---

constexpr char kTriangle[] =
    R"("meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]]}])";

LoadedScene parse_lights(const std::string& lights) {
  return parse_scene_json(R"({"lights": )" + lights + ", " + kTriangle + "}", "lights.json");
}

std::string lights_error(const std::string& lights) {
  try {
    parse_lights(lights);
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "lights.json");
    EXPECT_EQ(e.reason().find('\n'), std::string::npos);
    return e.reason();
  }
  ADD_FAILURE() << "no error for: " << lights;
  return "";
}

TEST(SceneFileLights, ReadsPointSpotAndDirectionalLights) {
  const LoadedScene s = parse_lights(R"([
    {"position": [0, -1, 0], "power": [1, 2, 3]},
    {"type": "point", "position": [1, 1, 1], "power": [4, 4, 4]},
    {"type": "spot", "position": [0, -2, 0], "direction": [0, 3, 4], "intensity": [5, 6, 7],
     "inner_angle": 10, "outer_angle": 30},
    {"type": "spot", "position": [0, 0, 0], "direction": [1, 0, 0], "intensity": [1, 1, 1],
     "outer_angle": 90},
    {"type": "directional", "direction": [0, 0, -2], "irradiance": [0.5, 1, 2]}])");
  ASSERT_EQ(s.scene.lights.size(), 2u);
  EXPECT_EQ(s.scene.lights[0].power, glm::vec3(1, 2, 3));
  EXPECT_EQ(s.scene.lights[1].position, glm::vec3(1, 1, 1));
  ASSERT_EQ(s.scene.spot_lights.size(), 2u);
  const SpotLight& a = s.scene.spot_lights[0];
  EXPECT_EQ(a.position, glm::vec3(0, -2, 0));
  EXPECT_NEAR(a.direction.y, 0.6f, 1e-7f);
  EXPECT_NEAR(a.direction.z, 0.8f, 1e-7f);
  EXPECT_EQ(a.intensity, glm::vec3(5, 6, 7));
  EXPECT_NEAR(a.cos_inner, std::cos(radians(10.0)), 1e-7);
  EXPECT_NEAR(a.cos_outer, std::cos(radians(30.0)), 1e-7);
  EXPECT_EQ(a.falloff, SpotFalloff::kGltf);
  EXPECT_EQ(s.scene.spot_lights[1].cos_inner, 1.0f);  // inner_angle 0 by default
  EXPECT_NEAR(s.scene.spot_lights[1].cos_outer, 0.0f, 1e-7f);
  ASSERT_EQ(s.scene.directional_lights.size(), 1u);
  EXPECT_EQ(s.scene.directional_lights[0].direction, glm::vec3(0, 0, -1));
  EXPECT_EQ(s.scene.directional_lights[0].irradiance, glm::vec3(0.5f, 1.0f, 2.0f));
}

TEST(SceneFileLights, BadFieldsAreOneLineErrorsNamingTheField) {
  EXPECT_EQ(lights_error(R"([{"type": "area"}])"),
            "/lights/0/type: must be \"point\", \"spot\" or \"directional\", got 'area'");
  EXPECT_EQ(lights_error(R"([{"type": 3}])"), "/lights/0/type: must be a string, got 3");
  EXPECT_EQ(lights_error(R"([{"type": "spot", "position": [0,0,0], "direction": [0,1,0],
                              "intensity": [1,1,1]}])"),
            "/lights/0: missing \"outer_angle\"");
  EXPECT_EQ(lights_error(R"([{"type": "spot", "position": [0,0,0], "direction": [0,0,0],
                              "intensity": [1,1,1], "outer_angle": 30}])"),
            "/lights/0/direction: must be a non-zero direction");
  EXPECT_EQ(lights_error(R"([{"type": "spot", "position": [0,0,0], "direction": [0,1,0],
                              "intensity": [1,-1,1], "outer_angle": 30}])"),
            "/lights/0/intensity/1: must not be negative");
  EXPECT_EQ(lights_error(R"([{"type": "spot", "position": [0,0,0], "direction": [0,1,0],
                              "intensity": [1,1,1], "outer_angle": 0}])"),
            "/lights/0/outer_angle: must be more than 0 and at most 180 degrees, got 0");
  EXPECT_EQ(lights_error(R"([{"type": "spot", "position": [0,0,0], "direction": [0,1,0],
                              "intensity": [1,1,1], "outer_angle": 30, "inner_angle": 30}])"),
            "/lights/0/inner_angle: must be at least 0 and less than outer_angle (30) degrees, "
            "got 30");
  EXPECT_EQ(lights_error(R"([{"type": "spot", "position": [0,0,0], "direction": [0,1,0],
                              "intensity": [1,1,1], "outer_angle": 30, "inner_angel": 5}])"),
            "/lights/0: unknown key 'inner_angel' (did you mean 'inner_angle'?)");
  EXPECT_EQ(lights_error(R"([{"type": "directional", "direction": [0,1,0]}])"),
            "/lights/0: missing \"irradiance\"");
  EXPECT_EQ(lights_error(R"([{"type": "directional", "direction": [0,1,0], "irradiance": [1,1,1],
                              "position": [0,0,0]}])"),
            "/lights/0: unknown key 'position' (did you mean 'direction'?)");
  EXPECT_EQ(lights_error(R"([{"type": "point", "position": [0,0,0]}])"),
            "/lights/0: missing \"power\"");
}

// The lab's model has point lights only: it refuses such a scene with a usage error rather than
// draw it without the lights. bdpt starts light subpaths on them (tests/render/bdpt_test.cpp).
TEST(DeltaLights, LabRefusesSpotAndDirectionalLightsAndBdptTakesThem) {
  Scene scene = plane_scene();
  scene.camera = Camera(8, 8, 0.0, 3.0f);
  EXPECT_TRUE(lab_unsupported(scene).empty());
  EXPECT_TRUE(bdpt_unsupported(scene).empty());
  scene.spot_lights.push_back(down_spot(SpotFalloff::kGltf));
  EXPECT_NE(lab_unsupported(scene).find("point lights only"), std::string::npos);
  EXPECT_TRUE(bdpt_unsupported(scene).empty());
  scene.spot_lights.clear();
  scene.directional_lights.push_back({.direction = {0, 1, 0}, .irradiance = glm::vec3(1.0f)});
  EXPECT_FALSE(lab_unsupported(scene).empty());
  EXPECT_TRUE(bdpt_unsupported(scene).empty());
  JobSettings lab;
  lab.integrator = "lab";
  try {
    const RenderJob job(lab, scene, IntegratorSpec{});
    ADD_FAILURE() << "lab accepted a directional light";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "--integrator");
    EXPECT_EQ(e.exit_code(), ExitCode::kUsage);
  }
  for (const char* integrator : {"path", "bdpt"}) {
    JobSettings settings;
    settings.integrator = integrator;
    EXPECT_NO_THROW(RenderJob(settings, scene, IntegratorSpec{})) << integrator;
  }
}

}  // namespace
}  // namespace tritrace

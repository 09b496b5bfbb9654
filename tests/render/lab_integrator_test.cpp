// The lab shading at chosen pixels of the default 500 x 500 view. Each expected colour is worked
// out here from the geometry (where the pixel's ray meets a wall, found by hand from the camera
// formula) and the lab's formulas, in double precision, not by running the renderer.
#include "tritrace/render/lab_integrator.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "lab_view.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/procedural.h"
#include "tritrace/scene/transform.h"

namespace tritrace {
namespace {

struct D3 {
  double x, y, z;
};

const D3 kLight{0.0, -0.5, -0.7};
constexpr double kPower = 14.0;
constexpr double kIndirect = 0.5;
const D3 kGreen{0.15, 0.75, 0.15}, kWhite{0.75, 0.75, 0.75}, kPurple{0.75, 0.15, 0.75},
    kYellow{0.75, 0.75, 0.15};

// The ray from the camera at (0,0,-3) through pixel (px, py) of a 500 x 500 image has direction
// (px - 250, py - 250, 500); return where it meets the plane `axis` = `value`.
D3 camera_ray_meets_plane(int px, int py, int axis, double value) {
  const D3 o{0.0, 0.0, -3.0};
  const D3 d{px - 250.0, py - 250.0, 500.0};
  const double oc[3] = {o.x, o.y, o.z}, dc[3] = {d.x, d.y, d.z};
  const double s = (value - oc[axis]) / dc[axis];
  return {o.x + s * d.x, o.y + s * d.y, o.z + s * d.z};
}

// rho * (P max(n.r^, 0) / (4 pi |r|^2) + N), unshadowed.
D3 lit_colour(D3 x, D3 n, D3 rho) {
  const D3 r{kLight.x - x.x, kLight.y - x.y, kLight.z - x.z};
  const double r2 = r.x * r.x + r.y * r.y + r.z * r.z;
  const double cos = std::max(0.0, (r.x * n.x + r.y * n.y + r.z * n.z) / std::sqrt(r2));
  const double direct = kPower * cos / (4.0 * std::numbers::pi * r2);
  return {rho.x * (direct + kIndirect), rho.y * (direct + kIndirect), rho.z * (direct + kIndirect)};
}

D3 shadowed_colour(D3 rho) {
  return {rho.x * kIndirect, rho.y * kIndirect, rho.z * kIndirect};
}

class LabPixels : public ::testing::TestWithParam<Kernel> {
 protected:
  void SetUp() override {
    scene_ = make_cornell_box();
    const BruteForceAccel accel(scene_.mesh, GetParam());
    image_ = render(scene_, accel, LabIntegrator{}, {});
  }
  void expect_pixel(int x, int y, D3 want) const {
    const glm::vec3 got = image_.at(x, y);
    EXPECT_NEAR(got.r, want.x, 2e-5) << "pixel " << x << "," << y;
    EXPECT_NEAR(got.g, want.y, 2e-5) << "pixel " << x << "," << y;
    EXPECT_NEAR(got.b, want.z, 2e-5) << "pixel " << x << "," << y;
  }
  Scene scene_;
  Image image_;
};

TEST_P(LabPixels, BackWallStraightAhead) {
  // Pixel (250, 150) meets the back wall z = 1 at (0, -0.8, 1), above the tall block (top at
  // y = -0.19); nothing lies between that point and the light. Normal (0, 0, -1).
  const D3 x = camera_ray_meets_plane(250, 150, 2, 1.0);
  ASSERT_NEAR(x.y, -0.8, 1e-12);
  expect_pixel(250, 150, lit_colour(x, {0, 0, -1}, kWhite));
}

TEST_P(LabPixels, LeftAndRightWalls) {
  // (100, 250) meets the purple wall x = -1 at (-1, 0, 1/3); (400, 200) the yellow wall x = +1 at
  // (1, -1/3, 1/3). Both see the light unobstructed.
  expect_pixel(100, 250, lit_colour(camera_ray_meets_plane(100, 250, 0, -1.0), {1, 0, 0}, kPurple));
  expect_pixel(400, 200, lit_colour(camera_ray_meets_plane(400, 200, 0, 1.0), {-1, 0, 0}, kYellow));
}

TEST_P(LabPixels, LitFloorInFront) {
  // (96, 474) meets the floor y = 1 at (-0.6875, 1, -0.768), in front of both blocks.
  const D3 x = camera_ray_meets_plane(96, 474, 1, 1.0);
  expect_pixel(96, 474, lit_colour(x, {0, -1, 0}, kGreen));
}

// The two shadow pixels were chosen with a separate double-precision tracer (not tritrace): every
// pixel within 4 of them sees the floor in the same block's shadow, so neither lies on a shadow
// edge.
TEST_P(LabPixels, FloorInTheShadowOfTheTallBlock) {
  // (138, 402) meets the floor y = 1 at (-0.737, 1, 0.289), left of and behind the tall block as
  // seen from the light; only the indirect term remains.
  const D3 x = camera_ray_meets_plane(138, 402, 1, 1.0);
  ASSERT_NEAR(x.x, -0.7368, 1e-4);
  expect_pixel(138, 402, shadowed_colour(kGreen));
  // Were it lit, the same point would be much brighter: the test can tell the two apart.
  EXPECT_GT(lit_colour(x, {0, -1, 0}, kGreen).y - shadowed_colour(kGreen).y, 0.05);
}

TEST_P(LabPixels, FloorInTheShadowOfTheShortBlock) {
  // (390, 420) meets the floor at (0.824, 1, -0.059), right of and behind the short block.
  const D3 x = camera_ray_meets_plane(390, 420, 1, 1.0);
  expect_pixel(390, 420, shadowed_colour(kGreen));
  EXPECT_GT(lit_colour(x, {0, -1, 0}, kGreen).y - shadowed_colour(kGreen).y, 0.05);
}

TEST_P(LabPixels, RayThatLeavesTheRoomIsBlack) {
  // A 700 x 500 image keeps f = 500, so pixel (0, 250) looks along (-350, 0, 500): it passes the
  // open side z = -1 at x = -1.4, outside the room, and never meets a triangle.
  CornellOptions wide;
  wide.width = 700;
  const Scene s = make_cornell_box(wide);
  const BruteForceAccel accel(s.mesh, GetParam());
  const Image img = render(s, accel, LabIntegrator{}, {});
  EXPECT_EQ(img.at(0, 250), glm::vec3(0.0f));
  EXPECT_NE(img.at(350, 250), glm::vec3(0.0f));  // the centre still sees the room
}

INSTANTIATE_TEST_SUITE_P(AllKernels, LabPixels, ::testing::ValuesIn(kAllKernels),
                         [](const auto& info) {
                           std::string name(kernel_name(info.param));
                           std::erase(name, '-');
                           return name;
                         });

// The lab scene moved as a whole (geometry, camera, light, power * scale^2) must render the same
// picture: shadow rays are offset relative to the scene's size and position, not by a constant.
struct Placement {
  const char* name;
  Similarity xf;
};
const Placement kPlacements[] = {{"ScaledDownBy1000", {1e-3f, glm::vec3(0.0f)}},
                                 {"ScaledUpBy10000", {1e4f, glm::vec3(0.0f)}},
                                 {"TranslatedBy10000", {1.0f, glm::vec3(1e4f)}}};

class MovedLabScene : public ::testing::TestWithParam<Placement> {};

TEST_P(MovedLabScene, RendersTheSameImageApartFromEdgePixels) {
  const Scene base = make_cornell_box();
  const Scene moved = transformed(base, GetParam().xf);
  const BruteForceAccel base_accel(base.mesh, Kernel::kWatertight),
      moved_accel(moved.mesh, Kernel::kWatertight);
  const std::vector<uint8_t> want = to_rgb8_lab(render(base, base_accel, LabIntegrator{}, {}));
  const std::vector<uint8_t> got = to_rgb8_lab(render(moved, moved_accel, LabIntegrator{}, {}));
  ASSERT_EQ(got.size(), want.size());
  // A scaled scene keeps float's relative precision: off the room's corner edges (exact ties, see
  // lab_view.h), at most 0.1% of pixels may differ at all. Translated by 1e4, positions are known
  // to float's resolution there, 2^-10 (a 2000th of the box): every shading term is off by up to
  // one level of 255, and geometric and shadow edges move by up to half a pixel (vertices round by
  // 2^-11, shadow rays start 4 ULPs = 2^-8 off the surface), so at most 0.2% of pixels may differ
  // by more than one level. Measured: 4 pixels at 1e-3, 0 at 1e4, 205 translated.
  const bool translated = GetParam().xf.scale == 1.0f;
  const int tolerance = translated ? 1 : 0;
  int differing = 0;
  for (int y = 0; y < 500; ++y) {
    for (int x = 0; x < 500; ++x) {
      if (testing_lab::on_room_corner_edge(x, y)) continue;
      const size_t p = 3 * (static_cast<size_t>(y) * 500 + x);
      for (int c = 0; c < 3; ++c) {
        if (std::abs(int{got[p + c]} - int{want[p + c]}) > tolerance) {
          ++differing;
          break;
        }
      }
    }
  }
  std::printf("%s: %d pixels differ off the room's corner edges\n", GetParam().name, differing);
  EXPECT_LE(differing, (translated ? 2 : 1) * 500 * 500 / 1000);
}

TEST_P(MovedLabScene, NoShadowRayHitsTheFaceItStartsOn) {
  // Acne: a shadow ray that hits its own triangle, or the other half of the same wall or block
  // face (the lab's faces are consecutive triangle pairs). Every pixel's ray is checked against
  // all triangles, and the one it hits first is looked at.
  for (const Scene& s : {make_cornell_box(), transformed(make_cornell_box(), GetParam().xf)}) {
    const BruteForceAccel accel(s.mesh, Kernel::kWatertight);
    int traced = 0, acne = 0;
    for (int y = 0; y < 500; y += 2) {
      for (int x = 0; x < 500; x += 2) {
        const Hit hit = accel.intersect(s.camera.primary_ray(x, y));
        if (!hit.found()) continue;
        const ShadowRay shadow = lab_shadow_ray(s.mesh, hit, s.lights[0].position);
        if (shadow.kind != ShadowRay::Kind::kTrace) continue;
        ++traced;
        const Hit blocker = accel.intersect(shadow.ray);
        acne += blocker.found() && blocker.prim / 2 == hit.prim / 2;
      }
    }
    EXPECT_GT(traced, 30'000);
    EXPECT_EQ(acne, 0);
  }
}

TEST_P(MovedLabScene, NoLightLeaksIntoAClosedRoomThroughItsCorners) {
  // The room closed by a front wall, the camera inside it, and the light outside, beyond the edge
  // where the floor meets the yellow wall: every shadow ray must be stopped by a wall, so every
  // pixel shows the indirect term only. A shadow ray starting behind a neighbouring wall, or
  // slipping through the seam between two walls, would light a pixel.
  Scene room = make_cornell_box();
  const glm::vec3 a(1.0f, 1.0f, -1.0f), b(-1.0f, 1.0f, -1.0f), e(1.0f, -1.0f, -1.0f),
      f(-1.0f, -1.0f, -1.0f);
  room.mesh.add(a, b, f, 6);  // white front wall at z = -1
  room.mesh.add(a, f, e, 6);
  room.lights[0].position = {-1.2f, 1.3f, 0.4f};
  // Wide (f = 80 for 200 pixels), from just inside the front wall: sees all four walls' corners.
  room.camera = Camera::look_at(200, 200, {0.0f, 0.0f, -0.95f}, {0.0f, 0.0f, 1.0f},
                                {0.0f, -1.0f, 0.0f}, 80.0f);
  const Scene s = transformed(room, GetParam().xf);
  const BruteForceAccel accel(s.mesh, Kernel::kWatertight);
  const Image img = render(s, accel, LabIntegrator{}, {});
  int lit = 0, seen = 0;
  for (int y = 0; y < img.height(); ++y) {
    for (int x = 0; x < img.width(); ++x) {
      const Hit hit = accel.intersect(s.camera.primary_ray(x, y));
      ASSERT_TRUE(hit.found()) << "closed room, pixel " << x << "," << y;
      ++seen;
      const glm::vec3 albedo = s.materials[s.mesh.material()[hit.prim]].albedo;
      lit += img.at(x, y) != albedo * s.ambient;
    }
  }
  EXPECT_EQ(seen, 200 * 200);
  EXPECT_EQ(lit, 0);
}

INSTANTIATE_TEST_SUITE_P(Placements, MovedLabScene, ::testing::ValuesIn(kPlacements),
                         [](const auto& info) { return std::string(info.param.name); });

// lab_shadow_rays (SIMD lanes where the build has them) against lab_shadow_ray, the scalar
// reference, field by field and bit for bit: batches where every hit is on one triangle (loaded
// once) and on many (gathered), with missed rays in between, of every length up to a few lanes, for
// lights in the room, far away, on a vertex and on a wall's plane, and the scene moved far off.
void expect_same_shadows(const TriangleMesh& mesh, const std::vector<Hit>& hits, glm::vec3 light,
                         const RayOffsetParams& offset) {
  std::vector<ShadowRay> got(hits.size());
  lab_shadow_rays(mesh, hits, light, offset, got);
  auto bits = [](float f) { return std::bit_cast<uint32_t>(f); };
  for (size_t i = 0; i < hits.size(); ++i) {
    const ShadowRay want =
        hits[i].found() ? lab_shadow_ray(mesh, hits[i], light, offset) : ShadowRay{};
    const ShadowRay& g = got[i];
    SCOPED_TRACE(::testing::Message()
                 << "hit " << i << " of " << hits.size() << ", prim " << hits[i].prim << ", light ("
                 << light.x << ", " << light.y << ", " << light.z << ")");
    ASSERT_EQ(g.kind, want.kind);
    ASSERT_EQ(bits(g.cos_theta), bits(want.cos_theta));
    ASSERT_EQ(bits(g.dist2), bits(want.dist2));
    const float gf[8] = {g.ray.origin.x, g.ray.origin.y, g.ray.origin.z, g.ray.dir.x,
                         g.ray.dir.y,    g.ray.dir.z,    g.ray.tmin,     g.ray.tmax};
    const float wf[8] = {want.ray.origin.x, want.ray.origin.y, want.ray.origin.z, want.ray.dir.x,
                         want.ray.dir.y,    want.ray.dir.z,    want.ray.tmin,     want.ray.tmax};
    for (int f = 0; f < 8; ++f) ASSERT_EQ(bits(gf[f]), bits(wf[f])) << "ray field " << f;
  }
}

TEST(LabShadowRays, BatchEqualsScalarBitForBit) {
  std::mt19937 rng(20261122);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const Scene scenes[] = {make_cornell_box(), make_builtin_scene("terrain:5000"),
                          transformed(make_cornell_box(), {1.0f, glm::vec3(1e4f)}),
                          transformed(make_cornell_box(), {1e-3f, glm::vec3(0.0f)})};
  int batches = 0;
  for (const Scene& scene : scenes) {
    const TriangleMesh& mesh = scene.mesh;
    const uint32_t n = static_cast<uint32_t>(mesh.size());
    std::uniform_int_distribution<uint32_t> any_prim(0, n - 1);
    // Barycentrics inside, on edges and on vertices.
    auto random_hit = [&](uint32_t prim) {
      Hit h;
      h.prim = prim;
      const int shape = static_cast<int>(unit(rng) * 4.0f);
      float u = unit(rng), v = unit(rng);
      if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
      if (shape == 1) v = 0.0f;
      if (shape == 2) u = 1.0f - v;
      if (shape == 3) u = unit(rng) < 0.5f ? 0.0f : 1.0f, v = 0.0f;
      h.u = u;
      h.v = v;
      h.t = 1.0f;
      return h;
    };
    const glm::vec3 v0 = mesh.v0()[n / 2];
    const glm::vec3 on_plane = v0 + 0.5f * mesh.e1(n / 2) + 0.25f * mesh.e2(n / 2);
    const glm::vec3 lights[] = {scene.lights.at(0).position, v0, on_plane,
                                glm::vec3(0.3f, 0.9f, 0.2f), glm::vec3(-1e4f, 2e3f, 5e3f)};
    for (const glm::vec3 light : lights) {
      for (size_t count = 1; count <= 40; ++count) {
        for (int pattern = 0; pattern < 3; ++pattern) {
          std::vector<Hit> hits(count);
          const uint32_t one = any_prim(rng);
          for (Hit& h : hits) {
            h = random_hit(pattern == 0 ? one : any_prim(rng));
            if (pattern == 2 && unit(rng) < 0.3f) h = Hit{};  // a missed ray
          }
          expect_same_shadows(mesh, hits, light, {});
          expect_same_shadows(mesh, hits, light, {16.0f, 1.0f / 4096.0f});
          ++batches;
        }
      }
    }
  }
  EXPECT_EQ(batches, 4 * 5 * 40 * 3);
}

}  // namespace
}  // namespace tritrace

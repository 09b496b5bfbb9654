// Conservative traversal at any distance: the BVH (packets and single rays) returns the brute-force
// loop's hits bit for bit for rays that start far from the scene, for scenes far from the origin
// and for rays that start on a triangle. The kernels' rounding grows with the origin's distance;
// a box test that ignored it would skip triangles the kernel accepts (wide_bvh.h,
// origin_padding).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "test_rays.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

struct Agreement {
  int mismatches = 0;
  int hits = 0;
};

// Closest hits and occlusion of `rays` through brute force and through the BVH's traversals:
// packets, single rays, and single rays interleaved (several in flight).
Agreement compare_with_brute(const TriangleMesh& mesh, const std::vector<Ray>& rays,
                             Kernel kernel = kDefaultKernel) {
  const BruteForceAccel brute(mesh, kernel);
  const BvhAccel packets(mesh, kernel, {}, BvhTraversal::kAuto);
  const BvhAccel single(mesh, kernel, {}, BvhTraversal::kSingle);
  const BvhAccel interleaved(mesh, kernel, {}, BvhTraversal::kSingleInterleaved);
  std::vector<Hit> want(rays.size()), got_p(rays.size()), got_s(rays.size()), got_i(rays.size());
  std::vector<uint8_t> occ(rays.size()), occ_p(rays.size()), occ_s(rays.size()), occ_i(rays.size());
  brute.intersect(rays, want);
  packets.intersect(rays, got_p);
  single.intersect(rays, got_s);
  interleaved.intersect(rays, got_i);
  brute.occluded(rays, occ);
  packets.occluded(rays, occ_p);
  single.occluded(rays, occ_s);
  interleaved.occluded(rays, occ_i);
  auto same = [](const Hit& a, const Hit& b) {
    return a.prim == b.prim && std::memcmp(&a.t, &b.t, sizeof(float)) == 0 &&
           std::memcmp(&a.u, &b.u, sizeof(float)) == 0 &&
           std::memcmp(&a.v, &b.v, sizeof(float)) == 0;
  };
  Agreement out;
  for (size_t i = 0; i < rays.size(); ++i) {
    out.hits += want[i].found();
    const bool ok = same(want[i], got_p[i]) && same(want[i], got_s[i]) && same(want[i], got_i[i]) &&
                    occ[i] == occ_p[i] && occ[i] == occ_s[i] && occ[i] == occ_i[i];
    if (!ok && ++out.mismatches <= 5) {
      ADD_FAILURE() << "ray " << i << " from (" << rays[i].origin.x << ", " << rays[i].origin.y
                    << ", " << rays[i].origin.z << "): brute prim " << want[i].prim << " t "
                    << want[i].t << " occ " << int(occ[i]) << "; packets prim " << got_p[i].prim
                    << " t " << got_p[i].t << " occ " << int(occ_p[i]) << "; single prim "
                    << got_s[i].prim << " t " << got_s[i].t << " occ " << int(occ_s[i])
                    << "; interleaved prim " << got_i[i].prim << " t " << got_i[i].t << " occ "
                    << int(occ_i[i]);
    }
  }
  return out;
}

// A w x h grid of camera rays through the lab camera at `distance`, in 4 x 4 pixel blocks (the
// renderer's packets), with focal length `focal` pixels.
std::vector<Ray> camera_rays(int w, int h, double yaw, float distance, float focal) {
  const Camera camera(w, h, yaw, distance, focal);
  std::vector<Ray> rays;
  for (int by = 0; by < h; by += 4) {
    for (int bx = 0; bx < w; bx += 4) {
      for (int y = by; y < by + 4 && y < h; ++y) {
        for (int x = bx; x < bx + 4 && x < w; ++x) rays.push_back(camera.primary_ray(x, y));
      }
    }
  }
  return rays;
}

class FarCamera : public ::testing::TestWithParam<float> {};

// The lab focal length (f = H): from far away the box is a few pixels or less, and every ray
// misses or grazes it; the kernel's rounding there is as large as the box.
TEST_P(FarCamera, LabFocalLengthSameHitsAsBrute) {
  const TriangleMesh mesh = make_cornell_box().mesh;
  const Agreement a = compare_with_brute(mesh, camera_rays(64, 64, 0.3, GetParam(), 64.0f));
  EXPECT_EQ(a.mismatches, 0);
}

// A long focal length that frames the box as the lab camera does from 3 units away: most rays hit.
TEST_P(FarCamera, LongFocalLengthSameHitsAsBrute) {
  const TriangleMesh mesh = make_cornell_box().mesh;
  const float focal = 64.0f * GetParam() / kLabCameraDistance;
  const std::vector<Ray> rays = camera_rays(64, 64, 0.3, GetParam(), focal);
  const Agreement a = compare_with_brute(mesh, rays);
  EXPECT_EQ(a.mismatches, 0);
  EXPECT_GT(a.hits, static_cast<int>(rays.size()) / 2);
}

TEST_P(FarCamera, TerrainLongFocalLengthSameHitsAsBrute) {
  const TriangleMesh mesh = make_terrain_scene(20000).mesh;
  const float focal = 48.0f * GetParam() / kLabCameraDistance;
  const std::vector<Ray> rays = camera_rays(48, 48, -0.4, GetParam(), focal);
  const Agreement a = compare_with_brute(mesh, rays);
  EXPECT_EQ(a.mismatches, 0);
  EXPECT_GT(a.hits, static_cast<int>(rays.size()) / 2);
}

// Whole lab images (camera rays and the shadow rays that start on the hit surfaces) through brute
// force and the BVH, from far away with a long lens.
TEST_P(FarCamera, LabImageIsIdenticalToBrute) {
  Scene scene = make_cornell_box({.width = 48, .height = 48, .yaw = -0.2});
  scene.camera = Camera(48, 48, -0.2, GetParam(), 48.0f * GetParam() / kLabCameraDistance);
  const BruteForceAccel brute(scene.mesh, kDefaultKernel);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image a = render(scene, brute, LabIntegrator{}, {});
  const Image b = render(scene, accel, LabIntegrator{}, {});
  ASSERT_EQ(a.pixels().size(), b.pixels().size());
  size_t lit = 0;
  for (const glm::vec3& p : a.pixels()) lit += p.x + p.y + p.z > 0.0f;
  EXPECT_GT(lit, a.pixels().size() / 2) << "the box should fill most of the frame";
  EXPECT_EQ(
      std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)), 0);
}

INSTANTIATE_TEST_SUITE_P(Distances, FarCamera, ::testing::Values(1e3f, 1e5f, 1e7f),
                         [](const auto& info) {
                           return "D1e" + std::to_string(static_cast<int>(
                                              std::lround(std::log10(info.param))));
                         });

// The lab box moved to (1e6, 1e6, 1e6): the scene's own coordinates are large, the rays start
// near it.
TEST(TranslatedScene, SameHitsAsBruteAtOneMillion) {
  const glm::vec3 shift(1e6f);
  const TriangleMesh box = make_cornell_box().mesh;
  TriangleMesh moved;
  for (size_t i = 0; i < box.size(); ++i) {
    moved.add(box.vertex(i, 0) + shift, box.vertex(i, 1) + shift, box.vertex(i, 2) + shift, 0);
  }
  std::vector<Ray> rays = awkward_rays(moved, 8000, 21);
  for (Ray& r : rays) r.origin = (r.origin - shift) * 0.5f + shift;  // near the moved box
  std::vector<Ray> coherent = coherent_rays(moved, 500, 22);
  rays.insert(rays.end(), coherent.begin(), coherent.end());
  const Agreement a = compare_with_brute(moved, rays);
  EXPECT_EQ(a.mismatches, 0);
  EXPECT_GT(a.hits, static_cast<int>(rays.size()) / 4);
}

// Shadow rays as the renderer makes them start on a surface; here they start exactly on
// triangles (points computed from barycentrics, so on or within rounding of the plane), with
// tmin = 0, in every direction, one at a time and in coherent groups of 16 toward one point.
TEST(RaysFromTriangles, SameHitsAsBrute) {
  for (const TriangleMesh& mesh : {make_cornell_box().mesh, make_terrain_scene(20000).mesh}) {
    std::mt19937 rng(31);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f), pos(-1.5f, 1.5f);
    std::uniform_int_distribution<size_t> tri(0, mesh.size() - 1);
    std::vector<Ray> rays;
    for (int k = 0; k < 600; ++k) {
      const glm::vec3 light(pos(rng), pos(rng), pos(rng));
      const size_t t = tri(rng);
      for (int l = 0; l < 16; ++l) {
        const float a = unit(rng), b = unit(rng) * (1.0f - a);
        const size_t s = l % 2 == 0 ? t : tri(rng);  // half from one triangle: coherent origins
        Ray r;
        r.origin = mesh.v0()[s] + a * mesh.e1(s) + b * mesh.e2(s);
        const glm::vec3 to = k % 2 == 0 ? light : glm::vec3(pos(rng), pos(rng), pos(rng));
        const glm::vec3 seg = to - r.origin;
        r.tmax = k % 3 == 0 ? kRayTMax : glm::length(seg);
        r.dir = glm::normalize(seg);
        rays.push_back(r);
      }
    }
    const Agreement ag = compare_with_brute(mesh, rays);
    EXPECT_EQ(ag.mismatches, 0);
    EXPECT_GT(ag.hits, static_cast<int>(rays.size()) / 4);
  }
}

}  // namespace
}  // namespace tritrace

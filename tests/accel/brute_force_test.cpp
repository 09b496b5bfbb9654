// BruteForceAccel: the closest hit wins, exact ties go to the earlier triangle, occlusion honours
// the ray's interval, and the batch and single-ray entry points agree.
#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/make_accel.h"

#include <gtest/gtest.h>

#include <vector>

namespace tritrace {
namespace {

// Three parallel unit right triangles facing the -z ray at z = 3, 1 and 2, in that order.
TriangleMesh stacked_mesh() {
  TriangleMesh m;
  for (float z : {3.0f, 1.0f, 2.0f}) {
    m.add({0, 0, z}, {1, 0, z}, {0, 1, z}, 0);
  }
  return m;
}

Ray ray_down_z(float x, float y) {
  Ray r;
  r.origin = {x, y, 0.0f};
  r.dir = {0.0f, 0.0f, 1.0f};
  return r;
}

class BruteForceTest : public ::testing::TestWithParam<Kernel> {};

TEST_P(BruteForceTest, ClosestOfSeveralHitsWins) {
  const TriangleMesh mesh = stacked_mesh();
  const BruteForceAccel accel(mesh, GetParam());
  const Hit hit = accel.intersect(ray_down_z(0.25f, 0.25f));
  ASSERT_TRUE(hit.found());
  EXPECT_EQ(hit.prim, 1u);
  EXPECT_FLOAT_EQ(hit.t, 1.0f);
  EXPECT_FLOAT_EQ(hit.u, 0.25f);
}

TEST_P(BruteForceTest, ExactTieGoesToTheEarlierTriangle) {
  TriangleMesh mesh;
  mesh.add({0, 0, 1}, {1, 0, 1}, {0, 1, 1}, 0);
  mesh.add({0, 0, 2}, {1, 0, 2}, {0, 1, 2}, 0);
  mesh.add({0, 0, 1}, {1, 0, 1}, {0, 1, 1}, 1);  // the same triangle as #0, later
  const BruteForceAccel accel(mesh, GetParam());
  EXPECT_EQ(accel.intersect(ray_down_z(0.2f, 0.2f)).prim, 0u);
  // A shared edge: both triangles of a quad report t = 1; the first one listed keeps the hit.
  TriangleMesh quad;
  quad.add({1, 0, 1}, {1, 1, 1}, {0, 0, 1}, 0);
  quad.add({0, 0, 1}, {0, 1, 1}, {1, 1, 1}, 0);
  EXPECT_EQ(BruteForceAccel(quad, GetParam()).intersect(ray_down_z(0.5f, 0.5f)).prim, 0u);
}

TEST_P(BruteForceTest, MissReportsNoHit) {
  const TriangleMesh mesh = stacked_mesh();
  const BruteForceAccel accel(mesh, GetParam());
  const Hit hit = accel.intersect(ray_down_z(0.75f, 0.75f));
  EXPECT_FALSE(hit.found());
  EXPECT_EQ(hit.prim, kNoHit);
}

TEST_P(BruteForceTest, EmptyMeshNeverHits) {
  const TriangleMesh mesh;
  const BruteForceAccel accel(mesh, GetParam());
  EXPECT_FALSE(accel.intersect(ray_down_z(0.1f, 0.1f)).found());
  EXPECT_FALSE(accel.occluded(ray_down_z(0.1f, 0.1f)));
}

TEST_P(BruteForceTest, OcclusionHonoursTheInterval) {
  const TriangleMesh mesh = stacked_mesh();
  const BruteForceAccel accel(mesh, GetParam());
  Ray r = ray_down_z(0.25f, 0.25f);
  EXPECT_TRUE(accel.occluded(r));
  r.tmax = 0.5f;  // stops before the nearest triangle at t = 1
  EXPECT_FALSE(accel.occluded(r));
  r.tmin = 3.5f;  // starts after the farthest at t = 3
  r.tmax = kRayTMax;
  EXPECT_FALSE(accel.occluded(r));
  r.tmin = 1.5f;  // skips the first, finds the one at t = 2
  EXPECT_TRUE(accel.occluded(r));
  EXPECT_EQ(accel.intersect(r).prim, 2u);
}

TEST_P(BruteForceTest, BatchAgreesWithSingleRays) {
  const TriangleMesh mesh = stacked_mesh();
  const BruteForceAccel accel(mesh, GetParam());
  std::vector<Ray> rays;
  for (int i = 0; i < 40; ++i) rays.push_back(ray_down_z(-0.1f + 0.03f * i, 0.3f));
  std::vector<Hit> hits(rays.size());
  std::vector<uint8_t> blocked(rays.size());
  accel.intersect(rays, hits);
  accel.occluded(rays, blocked);
  int found = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const Hit one = accel.intersect(rays[i]);
    EXPECT_EQ(hits[i].prim, one.prim);
    EXPECT_EQ(hits[i].t, one.t);
    EXPECT_EQ(blocked[i] != 0, hits[i].found());
    found += hits[i].found();
  }
  EXPECT_GT(found, 10);
  EXPECT_LT(found, 40);
}

INSTANTIATE_TEST_SUITE_P(AllKernels, BruteForceTest, ::testing::ValuesIn(kAllKernels),
                         [](const auto& info) {
                           std::string name(kernel_name(info.param));
                           std::erase(name, '-');
                           return name;
                         });

}  // namespace
}  // namespace tritrace

namespace tritrace {
namespace {

// Issue 10: watertight on every accel tritrace implements, so that they agree by default.
TEST(DefaultKernel, WatertightForEveryAccel) {
  EXPECT_EQ(default_kernel_for(AccelKind::kBrute), Kernel::kWatertight);
  EXPECT_EQ(default_kernel_for(AccelKind::kBvh), Kernel::kWatertight);
  EXPECT_EQ(default_kernel_for(AccelKind::kBvhSingle), Kernel::kWatertight);
}

}  // namespace
}  // namespace tritrace

// The closed-mesh leak test (tools/leaks): the meshes are closed, the count can see leaks (the
// non-watertight kernels leak on the same rays), the shortcut of testing only the triangles
// around the target agrees with testing them all, and the watertight kernel lets no ray through.
#include "leaks/leak_count.h"

#include <gtest/gtest.h>

#include <set>
#include <utility>

namespace tritrace::leaks {
namespace {

// 100,000 rays per mesh, 600,000 in all: a fraction of a second, and enough that each
// non-watertight kernel leaks thousands of times.
constexpr uint64_t kRaysPerMesh = 100'000;

TEST(ClosedMeshes, EveryEdgeJoinsTwoTrianglesAndEulerCharacteristicIsTwo) {
  for (const IndexedMesh& m : leak_test_meshes()) {
    SCOPED_TRACE(m.name);
    const std::vector<EdgeUse> edges = edge_uses(m);
    for (const EdgeUse& e : edges) EXPECT_EQ(e.triangles, 2) << e.a << "-" << e.b;
    // A closed genus-0 surface: V - E + F = 2.
    EXPECT_EQ(static_cast<long>(m.positions.size()) - static_cast<long>(edges.size()) +
                  static_cast<long>(m.triangles.size()),
              2);
    // Welded: no two vertices at the same position.
    std::set<std::tuple<float, float, float>> distinct;
    for (glm::vec3 p : m.positions) distinct.insert({p.x, p.y, p.z});
    EXPECT_EQ(distinct.size(), m.positions.size());
  }
}

TEST(ClosedMeshes, SphereHasPolesAndWeldedSeam) {
  // 24 bands, 48 longitudes: 2 poles + 23 rings of 48 vertices; 48 fan triangles at each pole and
  // 2 per quad in the 22 bands between rings.
  const IndexedMesh m = make_uv_sphere(24, 48, {0.0f, 0.0f, 0.0f}, 1.0f);
  EXPECT_EQ(m.positions.size(), 2u + 23u * 48u);
  EXPECT_EQ(m.triangles.size(), 2u * 48u + 2u * 22u * 48u);
}

TEST(ClosedMeshes, LabBoxesAreTheRoomAndBlocksClosed) {
  // The room's 10 triangles plus a 2-triangle front wall; each block's 10 plus its bottom.
  const std::vector<IndexedMesh> boxes = make_lab_boxes();
  ASSERT_EQ(boxes.size(), 3u);
  for (const IndexedMesh& b : boxes) {
    EXPECT_EQ(b.positions.size(), 8u) << b.name;
    EXPECT_EQ(b.triangles.size(), 12u) << b.name;
  }
  // The front wall closes the open side z = -1 of the room.
  for (size_t t = 10; t < 12; ++t) {
    for (uint32_t v : boxes[0].triangles[t]) EXPECT_EQ(boxes[0].positions[v].z, -1.0f);
  }
}

TEST(LeakCount, TestingOnlyTrianglesAroundTheTargetMatchesTestingAll) {
  for (const IndexedMesh& m : leak_test_meshes()) {
    for (Kernel k : {Kernel::kMollerTrumbore, Kernel::kWatertight}) {
      const LeakCounts ring = count_leaks(m, k, {.rays = 5'000, .seed = 3});
      const LeakCounts all = count_leaks(m, k, {.rays = 5'000, .seed = 3, .all_triangles = true});
      EXPECT_EQ(ring.leaks, all.leaks) << m.name << " " << kernel_name(k);
      EXPECT_EQ(ring.inside_leaks, all.inside_leaks) << m.name << " " << kernel_name(k);
    }
  }
}

TEST(LeakCount, NonWatertightKernelsLeakOnTheseRays) {
  // The rays are hard enough to find the known leaks of the other kernels (about 1-10% here), so
  // the watertight kernel's 0 below means something.
  for (const IndexedMesh& m : leak_test_meshes()) {
    for (Kernel k : kAllKernels) {
      if (k == Kernel::kWatertight) continue;
      const LeakCounts c = count_leaks(m, k, {.rays = 20'000, .seed = 2});
      EXPECT_EQ(c.rays, 20'000u);
      EXPECT_GT(c.leaks, 20u) << m.name << " " << kernel_name(k);
    }
  }
}

TEST(LeakCount, WatertightKernelLetsNoRayThroughClosedMeshes) {
  for (const IndexedMesh& m : leak_test_meshes()) {
    const LeakCounts c = count_leaks(m, Kernel::kWatertight, {.rays = kRaysPerMesh, .seed = 1});
    EXPECT_EQ(c.rays, kRaysPerMesh);
    EXPECT_GT(c.inside_rays, kRaysPerMesh / 3);
    EXPECT_GT(c.outside_rays, kRaysPerMesh / 3);
    EXPECT_GT(c.vertex_rays, kRaysPerMesh / 3);
    EXPECT_EQ(c.leaks, 0u) << m.name;
  }
}

}  // namespace
}  // namespace tritrace::leaks

// The procedural terrain: deterministic, about the requested size, inside the room, facing up,
// and covering at least half of the lab view (so that big scenes really exercise the big mesh).
#include "tritrace/scene/procedural.h"

#include <gtest/gtest.h>

#include <cstring>

#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/error.h"

namespace tritrace {
namespace {

TEST(TerrainNames, ParseCountsWithSuffixes) {
  EXPECT_EQ(parse_terrain_triangles("terrain:1m"), 1000000u);
  EXPECT_EQ(parse_terrain_triangles("terrain:10M"), 10000000u);
  EXPECT_EQ(parse_terrain_triangles("terrain:250k"), 250000u);
  EXPECT_EQ(parse_terrain_triangles("terrain:5000"), 5000u);
  EXPECT_FALSE(parse_terrain_triangles("terrain:"));
  EXPECT_FALSE(parse_terrain_triangles("terrain:1g"));
  EXPECT_FALSE(parse_terrain_triangles("terrain:-5"));
  EXPECT_FALSE(parse_terrain_triangles("terrain:1"));
  EXPECT_FALSE(parse_terrain_triangles("terrain:51m"));
  EXPECT_FALSE(parse_terrain_triangles("terrain:99999999999999999999"));
  EXPECT_FALSE(parse_terrain_triangles("cornell"));
}

TEST(BuiltinScenes, UnknownNameIsAUsageError) {
  try {
    make_builtin_scene("teapot");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "teapot");
    EXPECT_EQ(e.exit_code(), ExitCode::kUsage);
  }
  EXPECT_EQ(make_builtin_scene("cornell").mesh.size(), 30u);
}

TEST(Terrain, SizeIsCloseToTheRequestAndInsideTheRoom) {
  const Scene s = make_terrain_scene(100000);
  // An n x n grid of quads with n = round(sqrt(100000 / 2)) = 224: 2 * 224^2 = 100352 triangles,
  // plus the room's 10.
  EXPECT_EQ(s.mesh.size(), 100352u + 10u);
  const Bounds3 b = s.mesh.bounds();
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(b.lo[a], -1.0f);
    EXPECT_LE(b.hi[a], 1.0f);
  }
  // Terrain triangles face up (-y, world y points down), into the room.
  size_t up = 0;
  for (size_t i = 10; i < s.mesh.size(); ++i) up += s.mesh.normal()[i].y < 0.0f;
  EXPECT_EQ(up, s.mesh.size() - 10);
}

TEST(Terrain, SameGeometryBitForBitOnEveryRun) {
  const Scene a = make_terrain_scene(20000), b = make_terrain_scene(20000);
  ASSERT_EQ(a.mesh.size(), b.mesh.size());
  EXPECT_EQ(std::memcmp(a.mesh.v0().data(), b.mesh.v0().data(), a.mesh.size() * 12), 0);
  EXPECT_EQ(std::memcmp(a.mesh.v1().data(), b.mesh.v1().data(), a.mesh.size() * 12), 0);
  EXPECT_EQ(std::memcmp(a.mesh.v2().data(), b.mesh.v2().data(), a.mesh.size() * 12), 0);
  // And it is not flat: heights vary.
  const Bounds3 bounds = make_terrain_scene(20000).mesh.bounds();
  EXPECT_LT(bounds.lo.y, 0.0f);
}

TEST(Terrain, CoversAtLeastHalfOfTheLabView) {
  const Scene s = make_terrain_scene(50000, {.width = 200, .height = 200});
  const BvhAccel accel(s.mesh, kDefaultKernel);
  int terrain = 0;
  for (int y = 0; y < 200; ++y) {
    for (int x = 0; x < 200; ++x) {
      const Hit h = accel.intersect(s.camera.primary_ray(x, y));
      terrain += h.found() && h.prim >= 10;
    }
  }
  std::printf("terrain covers %.1f%% of the lab view\n", 100.0 * terrain / (200.0 * 200.0));
  EXPECT_GE(terrain, 200 * 200 / 2);
}

}  // namespace
}  // namespace tritrace

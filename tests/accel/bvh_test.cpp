// BvhAccel against the brute-force oracle (the same closest hit, bit for bit, with the same kernel,
// and the same occlusion) on many kinds of rays, and the tree's structural invariants.
#include "tritrace/accel/bvh/bvh_accel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <span>
#include <tuple>
#include <vector>

#include "query_meshes.h"
#include "test_rays.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/packet_traversal.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

using bvh::kLeafBit;
using bvh::WideBvh;

bvh::BuildConfig with_method(bvh::BuildMethod method) {
  bvh::BuildConfig config;
  config.method = method;
  return config;
}

void expect_same_as_brute(const TriangleMesh& mesh, Kernel kernel, int rays_count, uint32_t seed,
                          BvhTraversal traversal = BvhTraversal::kAuto, bool coherent = false,
                          bvh::BuildMethod method = bvh::BuildMethod::kBinnedSah) {
  const BruteForceAccel brute(mesh, kernel);
  const BvhAccel accel(mesh, kernel, with_method(method), traversal);
  const std::vector<Ray> rays =
      coherent ? coherent_rays(mesh, rays_count / 16, seed) : awkward_rays(mesh, rays_count, seed);
  std::vector<Hit> want(rays.size()), got(rays.size());
  std::vector<uint8_t> want_occ(rays.size()), got_occ(rays.size());
  brute.intersect(rays, want);
  accel.intersect(rays, got);
  brute.occluded(rays, want_occ);
  accel.occluded(rays, got_occ);
  int mismatches = 0, hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    hits += want[i].found();
    const bool same = want[i].prim == got[i].prim && want[i].t == got[i].t &&
                      want[i].u == got[i].u && want[i].v == got[i].v && want_occ[i] == got_occ[i];
    if (!same && ++mismatches <= 5) {
      ADD_FAILURE() << kernel_name(kernel) << " ray " << i << ": brute prim " << want[i].prim
                    << " t " << want[i].t << " occ " << int(want_occ[i]) << ", bvh prim "
                    << got[i].prim << " t " << got[i].t << " occ " << int(got_occ[i]);
    }
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(hits, rays_count / 5) << "too few hits for the comparison to mean much";
}

// Every kernel through the trees of both builds.
class BvhVsBrute : public ::testing::TestWithParam<std::tuple<Kernel, bvh::BuildMethod>> {
 protected:
  Kernel kernel() const { return std::get<0>(GetParam()); }
  bvh::BuildMethod method() const { return std::get<1>(GetParam()); }
  void expect_same(const TriangleMesh& mesh, int rays_count, uint32_t seed,
                   bool coherent = false) const {
    expect_same_as_brute(mesh, kernel(), rays_count, seed, BvhTraversal::kAuto, coherent, method());
  }
};

TEST_P(BvhVsBrute, CornellBoxSameHitsBitForBit) {
  expect_same(make_cornell_box().mesh, 20000, 1);
}

TEST_P(BvhVsBrute, TerrainSameHitsBitForBit) {
  expect_same(make_terrain_scene(20000).mesh, 4000, 2);
}

TEST_P(BvhVsBrute, RandomSoupSameHitsBitForBit) {
  expect_same(random_soup(3000, 3), 4000, 4);
}

TEST_P(BvhVsBrute, MixedMagnitudeSoupSameHitsBitForBit) {
  const TriangleMesh mesh = mixed_magnitude_soup(3000, 9);
  int rebuilt_differs = 0;  // the case this test is for must really occur
  for (size_t i = 0; i < mesh.size(); ++i) {
    rebuilt_differs +=
        mesh.v0()[i] + mesh.e1(i) != mesh.v1()[i] || mesh.v0()[i] + mesh.e2(i) != mesh.v2()[i];
  }
  ASSERT_GT(rebuilt_differs, 300);
  expect_same(mesh, 8000, 10);
  expect_same(mesh, 8000, 11, true);
}

TEST_P(BvhVsBrute, CoherentPacketsSameHitsBitForBit) {
  expect_same(make_cornell_box().mesh, 16000, 5, true);
  expect_same(make_terrain_scene(20000).mesh, 8000, 6, true);
  expect_same(random_soup(3000, 7), 8000, 8, true);
}

void expect_same_image_as_brute(const Scene& scene, Kernel kernel, bvh::BuildMethod method) {
  const BruteForceAccel brute(scene.mesh, kernel);
  const BvhAccel accel(scene.mesh, kernel, with_method(method));
  const Image a = render(scene, brute, LabIntegrator{}, {});
  const Image b = render(scene, accel, LabIntegrator{}, {});
  EXPECT_EQ(
      std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)), 0);
}

TEST_P(BvhVsBrute, TerrainImageIsIdentical) {
  expect_same_image_as_brute(make_terrain_scene(20000, {.width = 64, .height = 48, .yaw = -0.3}),
                             kernel(), method());
}

TEST_P(BvhVsBrute, CornellImageIsIdentical) {
  expect_same_image_as_brute(make_cornell_box({.width = 200, .height = 200, .yaw = 0.4}), kernel(),
                             method());
}

// kAuto uses packets for Möller–Trumbore; the single-ray path must agree as well.
TEST(BvhSingleRayTraversal, SameHitsBitForBit) {
  expect_same_as_brute(make_cornell_box().mesh, Kernel::kMollerTrumbore, 20000, 5,
                       BvhTraversal::kSingle);
  expect_same_as_brute(make_terrain_scene(20000).mesh, Kernel::kMollerTrumbore, 4000, 6,
                       BvhTraversal::kSingle);
  expect_same_as_brute(random_soup(3000, 7), Kernel::kMollerTrumbore, 4000, 8,
                       BvhTraversal::kSingle);
}

// The watertight kernel's single-ray path traces a batch's rays several at a time, interleaved
// (bvh_accel.cpp); every ray must still get brute force's answer, across the 256-ray chunks the
// batch is cut into and whatever the rays' dominant axes.
TEST(BvhSingleRayTraversal, WatertightInterleavedSameHitsBitForBit) {
  expect_same_as_brute(make_cornell_box().mesh, Kernel::kWatertight, 20000, 15,
                       BvhTraversal::kSingleInterleaved);
  expect_same_as_brute(make_terrain_scene(20000).mesh, Kernel::kWatertight, 4000, 16,
                       BvhTraversal::kSingleInterleaved);
  expect_same_as_brute(random_soup(3000, 17), Kernel::kWatertight, 4000, 18,
                       BvhTraversal::kSingleInterleaved);
  expect_same_as_brute(make_terrain_scene(20000).mesh, Kernel::kWatertight, 4000, 19,
                       BvhTraversal::kSingleInterleaved, /*coherent=*/true);
}

// Rays that hit nothing by definition (NaN, infinite, empty interval) in the middle of a batch
// leave their neighbours' answers alone, through intersect_incoherent and occluded_incoherent.
TEST(BvhSingleRayTraversal, UntraceableRaysInsideABatch) {
  const TriangleMesh mesh = make_terrain_scene(5000).mesh;
  const BruteForceAccel brute(mesh, Kernel::kWatertight);
  const BvhAccel accel(mesh, Kernel::kWatertight, {}, BvhTraversal::kSingleInterleaved);
  std::vector<Ray> rays = awkward_rays(mesh, 700, 21);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (size_t i = 0; i < rays.size(); i += 37) {
    switch (i % 3) {
      case 0:
        rays[i].dir.x = nan;
        break;
      case 1:
        rays[i].origin.z = inf;
        break;
      default:
        rays[i].tmin = rays[i].tmax + 1.0f;
    }
  }
  std::vector<Hit> want(rays.size()), got(rays.size(), Hit{0.5f, 0.1f, 0.1f, 3});
  std::vector<uint8_t> want_occ(rays.size()), got_occ(rays.size(), 7);
  brute.intersect(rays, want);
  brute.occluded(rays, want_occ);
  accel.intersect_incoherent(rays, got);
  accel.occluded_incoherent(rays, got_occ);
  int hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    hits += want[i].found();
    if (i % 37 == 0) {
      EXPECT_FALSE(got[i].found()) << i;
      EXPECT_EQ(got_occ[i], 0) << i;
    }
    EXPECT_EQ(want[i].prim, got[i].prim) << i;
    EXPECT_EQ(want[i].t, got[i].t) << i;
    EXPECT_EQ(want[i].u, got[i].u) << i;
    EXPECT_EQ(want[i].v, got[i].v) << i;
    EXPECT_EQ(want_occ[i], got_occ[i]) << i;
  }
  EXPECT_GT(hits, 100);
}

// A small mesh built with fine leaves (default_build_config below 16,384 triangles) keeps a
// second tree with bigger leaves for intersect_incoherent: fewer blocks holding the same
// triangles, and the closest hits still brute force's bit for bit, through single rays and
// through incoherent packets. A build priced per block of eight keeps one tree.
TEST(BvhSingleRayTraversal, SmallMeshClosestHitsOnTheirOwnTree) {
  const TriangleMesh mesh = make_terrain_scene(3000).mesh;
  ASSERT_LT(mesh.size(), bvh::kFineLeavesBelow);
  const bvh::BuildConfig config = bvh::default_build_config(mesh.size());
  const BruteForceAccel brute(mesh, Kernel::kWatertight);
  const std::vector<Ray> rays = awkward_rays(mesh, 3000, 23);
  std::vector<Hit> want(rays.size());
  brute.intersect(rays, want);
  for (const BvhTraversal traversal : {BvhTraversal::kAuto, BvhTraversal::kSingle}) {
    const BvhAccel accel(mesh, Kernel::kWatertight, config, traversal);
    const WideBvh& fine = accel.tree();
    const WideBvh& coarse = accel.closest_tree();
    ASSERT_NE(&fine, &coarse);
    EXPECT_EQ(coarse.triangles, mesh.size());
    EXPECT_LT(coarse.blocks.size(), fine.blocks.size());
    std::set<uint32_t> prims;  // every triangle in exactly one block of the second tree
    size_t lanes = 0;
    for (const bvh::TriangleBlock& b : coarse.blocks) {
      for (uint32_t p : b.prim) {
        if (p == kNoHit) continue;
        prims.insert(p);
        ++lanes;
      }
    }
    EXPECT_EQ(lanes, mesh.size());
    EXPECT_EQ(prims.size(), mesh.size());
    std::vector<Hit> got(rays.size());
    accel.intersect_incoherent(rays, got);
    int mismatches = 0, hits = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      hits += want[i].found();
      mismatches += std::memcmp(&want[i], &got[i], sizeof(Hit)) != 0;
    }
    EXPECT_EQ(mismatches, 0);
    EXPECT_GT(hits, 600);
  }
  bvh::BuildConfig blocks_of_eight = config;
  blocks_of_eight.block_size = 8;
  const BvhAccel one_tree(mesh, Kernel::kWatertight, blocks_of_eight);
  EXPECT_EQ(&one_tree.closest_tree(), &one_tree.tree());
}

// Shadow rays leaving a closed surface, as the path tracer's leave a sphere: from a point inside a
// triangle, a little along its outward normal, into the hemisphere about it, unbounded.
static std::vector<Ray> rays_leaving_surface(const TriangleMesh& mesh, int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), coord(-1.0f, 1.0f);
  std::uniform_int_distribution<size_t> tri(0, mesh.size() - 1);
  std::vector<Ray> rays;
  while (rays.size() < static_cast<size_t>(n)) {
    const size_t t = tri(rng);
    const float a = unit(rng), b = unit(rng) * (1.0f - a);
    const glm::vec3 normal = glm::normalize(glm::cross(mesh.e1(t), mesh.e2(t)));
    const glm::vec3 d(coord(rng), coord(rng), coord(rng));
    if (glm::dot(d, d) > 1.0f || glm::dot(d, normal) <= 0.0f) continue;
    Ray r;
    r.origin = mesh.v0()[t] + a * mesh.e1(t) + b * mesh.e2(t) + 1e-4f * normal;
    r.dir = glm::normalize(d);
    rays.push_back(r);
  }
  return rays;
}

// Shadow rays in a room towards a small light, as the path tracer's in scenes/glass.json: from
// points of the floor and the walls (a little inside) to random points of a 0.5 x 0.5 square
// under the ceiling, ending just before it; each 16 rays start within 0.25 of one point, as a
// tile's shadow rays start near one another.
static std::vector<Ray> rays_to_small_light(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), jitter(-0.25f, 0.25f);
  std::vector<Ray> rays;
  glm::vec3 centre(0.0f);
  int wall = 0;
  for (int i = 0; i < n; ++i) {
    if (i % 16 == 0) {
      wall = (i / 16) % 3;  // the floor, a side wall, the back wall
      centre = {-3.5f + 7.0f * unit(rng), 0.5f + 5.0f * unit(rng), -3.5f + 7.0f * unit(rng)};
    }
    glm::vec3 from = centre + glm::vec3(jitter(rng), jitter(rng), jitter(rng));
    if (wall == 0) from.y = 0.01f;
    if (wall == 1) from.x = -3.99f;
    if (wall == 2) from.z = -3.99f;
    const glm::vec3 to(-0.25f + 0.5f * unit(rng), 5.99f, -0.25f + 0.5f * unit(rng));
    Ray r;
    r.origin = from;
    r.dir = glm::normalize(to - from);
    r.tmax = 0.999f * glm::length(to - from);
    rays.push_back(r);
  }
  return rays;
}

// occluded_incoherent on a small mesh's two trees: a sample of the rays is traced every way (one
// at a time and, under kAuto, as packets, through both trees) and chooses the way of the rest
// (BvhAccel::occluded_tree(), occluded_as_packets()); every answer, before and after the choice,
// is brute force's. Rays leaving a closed sphere take fewer steps one at a time through the
// second tree's bigger leaves (as scenes/sky.json's shadow rays leave its spheres,
// docs/PERFORMANCE.md, issue 27), so there the choice is the second tree and its any hit is
// checked too; rays across a room to a small light take less work as packets (as glass.json's),
// so there under kAuto the choice is packets and their answers are checked.
TEST(BvhSingleRayTraversal, SmallMeshShadowRaysOnTheTreeASampleOfThemChose) {
  struct Case {
    const char* name;
    TriangleMesh mesh;
    std::vector<Ray> rays;
  };
  // Two spheres side by side, each shadowing part of the other.
  TriangleMesh spheres = icosphere(4, 1.0).mesh();
  const TriangleMesh other = icosphere(4, 1.0).mesh();
  for (size_t t = 0; t < other.size(); ++t) {
    const glm::vec3 shift(2.2f, 0.3f, 0.0f);
    spheres.add(other.vertex(t, 0) + shift, other.vertex(t, 1) + shift, other.vertex(t, 2) + shift,
                0);
  }
  const TriangleMesh terrain = make_terrain_scene(3000).mesh;
  // A room of 8 x 6 x 8 (floor, ceiling, three walls, two triangles each) with a sphere of radius
  // 1.5 on the floor under the light.
  TriangleMesh room;
  const TriangleMesh ball = icosphere(3, 1.5).mesh();
  for (size_t t = 0; t < ball.size(); ++t) {
    const glm::vec3 lift(0.0f, 1.5f, 0.0f);
    room.add(ball.vertex(t, 0) + lift, ball.vertex(t, 1) + lift, ball.vertex(t, 2) + lift, 0);
  }
  auto quad = [&](glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
    room.add(a, b, c, 0);
    room.add(a, c, d, 0);
  };
  quad({-4, 0, -4}, {4, 0, -4}, {4, 0, 4}, {-4, 0, 4});
  quad({-4, 6, -4}, {4, 6, -4}, {4, 6, 4}, {-4, 6, 4});
  quad({-4, 0, -4}, {-4, 6, -4}, {-4, 6, 4}, {-4, 0, 4});
  quad({4, 0, -4}, {4, 6, -4}, {4, 6, 4}, {4, 0, 4});
  quad({-4, 0, -4}, {4, 0, -4}, {4, 6, -4}, {-4, 6, -4});
  const Case cases[] = {{"spheres", spheres, rays_leaving_surface(spheres, 3000, 5)},
                        {"terrain", terrain, awkward_rays(terrain, 3000, 31)},
                        {"room", room, rays_to_small_light(3000, 7)}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    ASSERT_LT(c.mesh.size(), bvh::kFineLeavesBelow);
    const BruteForceAccel brute(c.mesh, Kernel::kWatertight);
    std::vector<uint8_t> want(c.rays.size());
    brute.occluded(c.rays, want);
    const size_t occluded = static_cast<size_t>(std::count(want.begin(), want.end(), 1));
    EXPECT_GT(occluded, 100u);
    EXPECT_LT(occluded, c.rays.size() - 100);
    for (const BvhTraversal traversal : {BvhTraversal::kAuto, BvhTraversal::kSingle}) {
      const BvhAccel accel(c.mesh, Kernel::kWatertight, bvh::default_build_config(c.mesh.size()),
                           traversal);
      ASSERT_NE(&accel.closest_tree(), &accel.tree());
      EXPECT_EQ(&accel.occluded_tree(), &accel.tree());  // until the probe has chosen
      // Passes in batches of 64 until kOccludedProbeRays rays have surely been counted (one call
      // in kOccludedProbeEvery is, the odd last batch of a pass shorter), every answer checked.
      const size_t passes =
          BvhAccel::kOccludedProbeRays * BvhAccel::kOccludedProbeEvery * 5 / 4 / c.rays.size();
      int mismatches = 0;
      std::vector<uint8_t> got(c.rays.size());
      for (size_t pass = 0; pass < passes; ++pass) {
        std::fill(got.begin(), got.end(), uint8_t{2});
        for (size_t first = 0; first < c.rays.size(); first += 64) {
          const size_t n = std::min<size_t>(64, c.rays.size() - first);
          accel.occluded_incoherent(std::span(c.rays).subspan(first, n),
                                    std::span(got).subspan(first, n));
        }
        for (size_t i = 0; i < c.rays.size(); ++i) mismatches += want[i] != got[i];
      }
      EXPECT_EQ(mismatches, 0);
      if (c.name == std::string("spheres")) {
        EXPECT_EQ(&accel.occluded_tree(), &accel.closest_tree());
        EXPECT_FALSE(accel.occluded_as_packets());
      }
      if (c.name == std::string("room")) {
        EXPECT_EQ(accel.occluded_as_packets(),
                  traversal == BvhTraversal::kAuto && bvh::kPacketSize > 0);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllKernels, BvhVsBrute,
                         ::testing::Combine(::testing::ValuesIn(kAllKernels),
                                            ::testing::Values(bvh::BuildMethod::kBinnedSah,
                                                              bvh::BuildMethod::kMorton)),
                         [](const auto& info) {
                           std::string name(kernel_name(std::get<0>(info.param)));
                           std::erase(name, '-');
                           if (std::get<1>(info.param) == bvh::BuildMethod::kMorton) {
                             name += "_morton";
                           }
                           return name;
                         });

// Walks the tree: every triangle in exactly one leaf lane, leaves within the size limit, every
// child's box inside its parent's slot box.
void check_invariants(const TriangleMesh& mesh,
                      bvh::BuildMethod method = bvh::BuildMethod::kBinnedSah) {
  const WideBvh tree = bvh::build_wide_bvh(mesh, with_method(method));
  ASSERT_EQ(tree.triangles, mesh.size());
  if (mesh.empty()) {
    EXPECT_TRUE(tree.nodes.empty());
    return;
  }
  std::vector<int> seen(mesh.size(), 0);
  struct Item {
    uint32_t ref;
    Bounds3 box;
  };
  std::vector<Item> todo{{0, Bounds3{glm::vec3(-1e30f), glm::vec3(1e30f)}}};
  size_t nodes_visited = 0;
  while (!todo.empty()) {
    const Item item = todo.back();
    todo.pop_back();
    if (item.ref & kLeafBit) {
      const bvh::TriangleBlock& b = tree.blocks[item.ref & ~kLeafBit];
      for (int l = 0; l < bvh::kWidth; ++l) {
        if (b.prim[l] == kNoHit) continue;
        ASSERT_LT(b.prim[l], mesh.size());
        ++seen[b.prim[l]];
        // The triangle lies inside its leaf's box.
        for (int c = 0; c < 3; ++c) {
          const glm::vec3 p = mesh.vertex(b.prim[l], c);
          EXPECT_TRUE(item.box.contains(Bounds3{p, p}));
        }
      }
      continue;
    }
    ASSERT_LT(item.ref, tree.nodes.size());
    ++nodes_visited;
    const bvh::WideNode& n = tree.nodes[item.ref];
    int used = 0;
    for (int i = 0; i < bvh::kWidth; ++i) {
      if (n.child[i] == bvh::kEmptyChild) continue;
      ++used;
      const Bounds3 box{{n.lo_x[i], n.lo_y[i], n.lo_z[i]}, {n.hi_x[i], n.hi_y[i], n.hi_z[i]}};
      EXPECT_TRUE(item.box.contains(box)) << "child box outside its parent";
      todo.push_back({n.child[i], box});
    }
    EXPECT_GE(used, 1);
  }
  EXPECT_EQ(nodes_visited, tree.nodes.size()) << "unreachable nodes";
  for (size_t i = 0; i < mesh.size(); ++i) EXPECT_EQ(seen[i], 1) << "triangle " << i;
}

TEST(BvhInvariants, CornellBox) {
  check_invariants(make_cornell_box().mesh);
  check_invariants(make_cornell_box().mesh, bvh::BuildMethod::kMorton);
}
TEST(BvhInvariants, Terrain) {
  check_invariants(make_terrain_scene(50000).mesh);
  check_invariants(make_terrain_scene(50000).mesh, bvh::BuildMethod::kMorton);
}
TEST(BvhInvariants, RandomSoup) {
  check_invariants(random_soup(5000, 9));
  check_invariants(random_soup(5000, 9), bvh::BuildMethod::kMorton);
}
TEST(BvhInvariants, EmptyMesh) {
  check_invariants(TriangleMesh{});
  check_invariants(TriangleMesh{}, bvh::BuildMethod::kMorton);
}

TEST(BvhInvariants, ManyIdenticalTrianglesStayShallowEnough) {
  TriangleMesh m;  // no plane separates identical centroids: the builder must still terminate
  for (int i = 0; i < 5000; ++i) m.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0);
  for (bvh::BuildMethod method : {bvh::BuildMethod::kBinnedSah, bvh::BuildMethod::kMorton}) {
    check_invariants(m, method);
    const BvhAccel accel(m, kDefaultKernel, with_method(method));
    Ray r;
    r.origin = {0.2f, 0.2f, -1.0f};
    EXPECT_EQ(accel.intersect(r).prim, 0u);  // the tie goes to the first triangle
  }
}

TEST(BvhAccel, EmptyAndSingleTriangleScenes) {
  const TriangleMesh empty;
  const BvhAccel none(empty, kDefaultKernel);
  Ray r;
  r.origin = {0.25f, 0.25f, -1.0f};
  EXPECT_FALSE(none.intersect(r).found());
  EXPECT_FALSE(none.occluded(r));

  TriangleMesh one;
  one.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0);
  const BvhAccel single(one, kDefaultKernel);
  const Hit h = single.intersect(r);
  ASSERT_TRUE(h.found());
  EXPECT_FLOAT_EQ(h.t, 1.0f);
  EXPECT_TRUE(single.occluded(r));
  r.origin = {0.75f, 0.75f, -1.0f};
  EXPECT_FALSE(single.intersect(r).found());
}

TEST(BvhAccel, NonFiniteRaysHitNothing) {
  const Scene scene = make_cornell_box();
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  Ray r;
  r.dir = {std::numeric_limits<float>::quiet_NaN(), 0.0f, 1.0f};
  EXPECT_FALSE(accel.intersect(r).found());
  EXPECT_FALSE(accel.occluded(r));
  r.dir = {0.0f, 0.0f, 1.0f};
  r.origin = {std::numeric_limits<float>::infinity(), 0.0f, 0.0f};
  EXPECT_FALSE(accel.intersect(r).found());
}

}  // namespace
}  // namespace tritrace

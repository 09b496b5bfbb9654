// The Embree backend against the brute-force oracle. Embree has its own kernel, so the two may
// differ where rounding decides: rays within a hair of a triangle's edge or in a tie. Everywhere
// else they must return the same triangle, the same t (to float precision) and the same occlusion,
// in every mode (single rays, 8- and 16-wide packets), with and without RTC_SCENE_FLAG_ROBUST, and
// through the incoherent queries (ray by ray) as through the batch ones.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "test_rays.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/procedural.h"
#if TRITRACE_HAVE_EMBREE
#include "tritrace/accel/embree_accel.h"
#endif

namespace tritrace {
namespace {

#if TRITRACE_HAVE_EMBREE
constexpr float kEdgeBand = 1e-4f;

// How close the brute-force hit is to its triangle's boundary, in barycentric units.
float edge_distance(const Hit& h) {
  return std::min({h.u, h.v, 1.0f - h.u - h.v});
}

// Whether hit h of `ray` is near an edge of its triangle for the float kernels: kEdgeBand in
// barycentric units, widened by 1 / |cos| of the angle between the ray and the triangle's normal.
// A ray that grazes a triangle meets it at barycentrics that float arithmetic gets only roughly
// (a ray 0.04 degrees off a terrain triangle's plane: 0.0019 inside the triangle in double
// precision, 0.00007 outside it in the watertight kernel), so either kernel may report it or its
// neighbour there.
bool near_edge(const TriangleMesh& mesh, const Ray& ray, const Hit& h) {
  const glm::vec3 n = glm::cross(mesh.e1(h.prim), mesh.e2(h.prim));
  const float cosine = std::abs(glm::dot(n, ray.dir)) / (glm::length(n) * glm::length(ray.dir));
  return edge_distance(h) * std::max(cosine, 1e-6f) < kEdgeBand;
}

struct EmbreeSetup {
  EmbreeMode mode;
  bool robust;
};

// The oracle's kernel. Robust mode is compared with our watertight kernel, with which it agreed on
// the two random-soup rays it failed against Möller–Trumbore: Möller–Trumbore's barycentrics (off
// by 2e-4 for a ray from 8 units away at a triangle 0.03 across) put one hit 2.6e-4 inside an edge
// that the watertight kernel puts 5.4e-5 inside and robust Embree misses, and give the other a hit
// 2.7e-4 from a vertex that both the watertight kernel and robust Embree miss: both outside the
// 1e-4 band where this test forgives a difference.
Kernel oracle_kernel(const EmbreeSetup& setup) {
  return setup.robust ? Kernel::kWatertight : Kernel::kMollerTrumbore;
}

// Whether several triangles lie within a hair of the t of `hit` along `ray`: then either may be
// reported.
bool near_tie(const TriangleMesh& mesh, Kernel kernel, const Ray& ray, const Hit& hit) {
  Ray around = ray;
  around.tmin = hit.t * (1.0f - 1e-5f);
  around.tmax = hit.t * (1.0f + 1e-5f);
  int near = 0;
  for (size_t tri = 0; tri < mesh.size(); ++tri) {
    TriangleHit th;
    near += intersect_triangle(kernel, around, mesh.v0()[tri], mesh.e1(tri), mesh.e2(tri), th);
  }
  return near > 1;
}

void expect_matches_brute(const TriangleMesh& mesh, EmbreeSetup setup, int count, uint32_t seed) {
  const Kernel kernel = oracle_kernel(setup);
  const BruteForceAccel brute(mesh, kernel);
  const EmbreeAccel embree(mesh, setup.mode, setup.robust);
  ASSERT_EQ(embree.robust(), setup.robust);
  const std::vector<Ray> rays = awkward_rays(mesh, count, seed);
  std::vector<Hit> want(rays.size()), got(rays.size());
  std::vector<uint8_t> want_occ(rays.size()), got_occ(rays.size());
  brute.intersect(rays, want);
  embree.intersect(rays, got);
  brute.occluded(rays, want_occ);
  embree.occluded(rays, got_occ);
  int judged = 0, bad = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    // Skip edge cases: a hit (either's) near an edge, or a second triangle at nearly the same t.
    if (want[i].found() && near_edge(mesh, rays[i], want[i])) continue;
    if (got[i].found() && near_edge(mesh, rays[i], got[i])) continue;
    if (want[i].found() && near_tie(mesh, kernel, rays[i], want[i])) continue;
    ++judged;
    bool same = want[i].prim == got[i].prim && want_occ[i] == got_occ[i];
    if (same && want[i].found()) {
      same = std::abs(want[i].t - got[i].t) <= 1e-4f * std::max(1.0f, want[i].t);
    }
    if (!same && ++bad <= 5) {
      ADD_FAILURE() << "ray " << i << ": brute prim " << want[i].prim << " t " << want[i].t
                    << " occ " << int(want_occ[i]) << "; embree prim " << got[i].prim << " t "
                    << got[i].t << " occ " << int(got_occ[i]);
    }
  }
  EXPECT_EQ(bad, 0);
  EXPECT_GT(judged, count * 8 / 10) << "most rays must be judged";
}

// A path tracer's rays: from random points inside `extent` towards random interior points of
// random triangles (barycentrics at least 0.1 from every edge), in random directions of all
// kinds. Every third stops halfway to its target, as a shadow ray towards a light does.
std::vector<Ray> interior_aimed_rays(const TriangleMesh& mesh, float extent, int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-extent, extent), bary(0.1f, 0.8f);
  std::uniform_int_distribution<size_t> tri(0, mesh.size() - 1);
  std::vector<Ray> rays;
  while (rays.size() < static_cast<size_t>(n)) {
    const size_t t = tri(rng);
    const float u = bary(rng), v = bary(rng);
    if (u + v > 0.9f) continue;
    const glm::vec3 target = mesh.v0()[t] + u * mesh.e1(t) + v * mesh.e2(t);
    Ray r;
    r.origin = glm::vec3(pos(rng), pos(rng), pos(rng));
    const glm::vec3 to = target - r.origin;
    const float distance = glm::length(to);
    if (distance < 1e-3f) continue;
    r.dir = to / distance;
    r.tmin = 0.0f;
    r.tmax = rays.size() % 3 == 2 ? 0.5f * distance : std::numeric_limits<float>::infinity();
    rays.push_back(r);
  }
  return rays;
}

// intersect_incoherent and occluded_incoherent (ray by ray whatever the mode) answer as the batch
// queries (packets in the packet modes) and as brute force, on rays a path tracer casts.
void expect_incoherent_matches(const TriangleMesh& mesh, float extent, EmbreeSetup setup, int count,
                               uint32_t seed) {
  const Kernel kernel = oracle_kernel(setup);
  const BruteForceAccel brute(mesh, kernel);
  const EmbreeAccel embree(mesh, setup.mode, setup.robust);
  const std::vector<Ray> rays = interior_aimed_rays(mesh, extent, count, seed);
  const size_t n = rays.size();
  std::vector<Hit> want(n), batch(n), single(n);
  std::vector<uint8_t> want_occ(n), batch_occ(n), single_occ(n);
  brute.intersect(rays, want);
  brute.occluded(rays, want_occ);
  embree.intersect(rays, batch);
  embree.occluded(rays, batch_occ);
  embree.intersect_incoherent(rays, single);
  embree.occluded_incoherent(rays, single_occ);
  int judged = 0, hits = 0, occluded = 0, bad = 0;
  for (size_t i = 0; i < n; ++i) {
    if (want[i].found() &&
        (edge_distance(want[i]) < kEdgeBand || near_tie(mesh, kernel, rays[i], want[i]))) {
      continue;
    }
    ++judged;
    hits += want[i].found();
    occluded += want_occ[i];
    const bool same_prims = single[i].prim == want[i].prim && batch[i].prim == single[i].prim;
    const bool same_occ = single_occ[i] == want_occ[i] && batch_occ[i] == single_occ[i];
    const bool same_t =
        !want[i].found() || std::abs(single[i].t - batch[i].t) <= 1e-5f * std::max(1.0f, want[i].t);
    if (!(same_prims && same_occ && same_t) && ++bad <= 5) {
      ADD_FAILURE() << "ray " << i << ": brute prim " << want[i].prim << " occ " << int(want_occ[i])
                    << "; batch prim " << batch[i].prim << " t " << batch[i].t << " occ "
                    << int(batch_occ[i]) << "; incoherent prim " << single[i].prim << " t "
                    << single[i].t << " occ " << int(single_occ[i]);
    }
  }
  EXPECT_EQ(bad, 0);
  EXPECT_GT(judged, count * 9 / 10) << "interior-aimed rays are rarely near an edge";
  // The rays do what they are for: most full-length ones hit, and the shortened ones are a mix.
  EXPECT_GT(hits, count / 2);
  EXPECT_GT(occluded, count / 2);
  EXPECT_LT(occluded, judged);
}

class EmbreeVsBrute : public ::testing::TestWithParam<EmbreeSetup> {};

TEST_P(EmbreeVsBrute, IncoherentQueriesOnCornellBox) {
  // From inside the box, as the bounces of a path are.
  expect_incoherent_matches(make_cornell_box().mesh, 0.95f, GetParam(), 4000, 21);
}
TEST_P(EmbreeVsBrute, IncoherentQueriesOnRandomSoup) {
  expect_incoherent_matches(random_soup(2000, 22), 1.5f, GetParam(), 3000, 23);
}

TEST_P(EmbreeVsBrute, CornellBox) {
  expect_matches_brute(make_cornell_box().mesh, GetParam(), 6000, 11);
}
TEST_P(EmbreeVsBrute, Terrain) {
  expect_matches_brute(make_terrain_scene(20000).mesh, GetParam(), 2000, 12);
}
TEST_P(EmbreeVsBrute, RandomSoup) {
  expect_matches_brute(random_soup(2000, 13), GetParam(), 2000, 14);
}

INSTANTIATE_TEST_SUITE_P(Modes, EmbreeVsBrute,
                         ::testing::Values(EmbreeSetup{EmbreeMode::kSingle, false},
                                           EmbreeSetup{EmbreeMode::kPacket8, false},
                                           EmbreeSetup{EmbreeMode::kPacket16, false},
                                           EmbreeSetup{EmbreeMode::kSingle, true},
                                           EmbreeSetup{EmbreeMode::kPacket8, true},
                                           EmbreeSetup{EmbreeMode::kPacket16, true}),
                         [](const auto& info) {
                           const std::string mode =
                               info.param.mode == EmbreeMode::kSingle    ? "single"
                               : info.param.mode == EmbreeMode::kPacket8 ? "packet8"
                                                                         : "packet16";
                           return info.param.robust ? "robust_" + mode : mode;
                         });

// --accel embree-robust is Embree's packet mode of --accel embree with the robust flag.
TEST(EmbreeAccel, EmbreeRobustAccelIsThePacketModeWithTheRobustFlag) {
  const TriangleMesh mesh = make_cornell_box().mesh;
  const auto robust = make_accel(AccelKind::kEmbreeRobust, mesh, Kernel::kWatertight);
  const auto plain = make_accel(AccelKind::kEmbree, mesh, Kernel::kWatertight);
  const auto* r = dynamic_cast<const EmbreeAccel*>(robust.get());
  const auto* p = dynamic_cast<const EmbreeAccel*>(plain.get());
  ASSERT_NE(r, nullptr);
  ASSERT_NE(p, nullptr);
  EXPECT_TRUE(r->robust());
  EXPECT_FALSE(p->robust());
  EXPECT_EQ(r->mode(), p->mode());
  EXPECT_NE(r->mode(), EmbreeMode::kSingle);
}

TEST(EmbreeAccel, EmptySceneHitsNothing) {
  const TriangleMesh empty;
  const EmbreeAccel embree(empty, EmbreeMode::kSingle);
  Ray r;
  EXPECT_FALSE(embree.intersect(r).found());
  EXPECT_FALSE(embree.occluded(r));
}
#else
TEST(EmbreeAccel, NotBuilt) {
  GTEST_SKIP() << "built without Embree (TRITRACE_WITH_EMBREE)";
}
#endif

}  // namespace
}  // namespace tritrace

// The two-level structure for instances against its oracles: the instanced brute force (every
// instance, the same object-space rays), bit for bit; one flattened mesh, bit for bit where the
// transforms make the arithmetic exact and within a tolerance for general ones; and the scene's
// triangle numbering, world-space triangles and Embree's refusal.
#include "tritrace/accel/instanced_accel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/matrix.hpp>
#include <random>
#include <string>
#include <vector>

#include "test_rays.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/error.h"

namespace tritrace {
namespace {

Affine make_affine(glm::vec3 degrees, glm::vec3 scale, glm::vec3 translate) {
  glm::mat4 r(1.0f);
  r = glm::rotate(r, glm::radians(degrees.z), glm::vec3(0, 0, 1));
  r = glm::rotate(r, glm::radians(degrees.y), glm::vec3(0, 1, 0));
  r = glm::rotate(r, glm::radians(degrees.x), glm::vec3(1, 0, 0));
  Affine a;
  a.linear = glm::mat3(r) * glm::mat3(glm::vec3(scale.x, 0, 0), glm::vec3(0, scale.y, 0),
                                      glm::vec3(0, 0, scale.z));
  a.translation = translate;
  return a;
}

Affine diagonal(glm::vec3 scale) {
  return make_affine(glm::vec3(0.0f), scale, glm::vec3(0.0f));
}

// A scene of two random soups placed `placements` times each with general transforms (rotations,
// non-uniform and mirroring scales, translations), plus a soup of its own.
Scene random_instanced_scene(int placements, uint32_t seed, bool exact) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> angle(-180.0f, 180.0f), scale(0.3f, 2.0f),
      offset(-6.0f, 6.0f);
  std::uniform_int_distribution<int> exponent(-2, 2), sign(0, 1);
  Scene s;
  s.mesh = random_soup(100, seed + 1);
  s.prototypes.push_back(random_soup(300, seed + 2));
  s.prototypes.push_back(mixed_magnitude_soup(50, seed + 3));
  for (int i = 0; i < 2 * placements; ++i) {
    Affine a;
    if (exact) {
      // One power of two, each axis's sign drawn, no rotation or translation (see
      // ExactTransforms below).
      const float p = std::ldexp(1.0f, exponent(rng));
      auto pick = [&] { return sign(rng) ? -p : p; };
      a = diagonal({pick(), pick(), pick()});
    } else {
      a = make_affine({angle(rng), angle(rng), angle(rng)},
                      {scale(rng) * (sign(rng) ? -1.0f : 1.0f), scale(rng), scale(rng)},
                      {offset(rng), offset(rng), offset(rng)});
    }
    add_instance(s, static_cast<uint32_t>(i % 2), a);
  }
  return s;
}

// Bit for bit, or with `zero_sign_free` the barycentrics compared as numbers (+0 == -0).
void expect_same_hits(const std::vector<Hit>& want, const std::vector<Hit>& got, const char* what,
                      bool zero_sign_free = false) {
  ASSERT_EQ(want.size(), got.size());
  size_t differ = 0;
  for (size_t i = 0; i < want.size(); ++i) {
    const bool same = zero_sign_free ? want[i].prim == got[i].prim &&
                                           std::memcmp(&want[i].t, &got[i].t, sizeof(float)) == 0 &&
                                           want[i].u == got[i].u && want[i].v == got[i].v
                                     : std::memcmp(&want[i], &got[i], sizeof(Hit)) == 0;
    if (!same && differ++ < 5) {
      ADD_FAILURE() << what << ": ray " << i << ": t " << want[i].t << " u " << want[i].u << " v "
                    << want[i].v << " prim " << want[i].prim << " vs u " << got[i].u << " v "
                    << got[i].v << " vs t " << got[i].t << " prim " << got[i].prim;
    }
  }
  EXPECT_EQ(differ, 0u) << what;
}

std::vector<Hit> trace(const Accel& accel, const std::vector<Ray>& rays, bool incoherent = false) {
  std::vector<Hit> hits(rays.size());
  if (incoherent) {
    accel.intersect_incoherent(rays, hits);
  } else {
    accel.intersect(rays, hits);
  }
  return hits;
}

std::vector<uint8_t> blocked(const Accel& accel, const std::vector<Ray>& rays) {
  std::vector<uint8_t> out(rays.size());
  accel.occluded(rays, out);
  return out;
}

TEST(InstancedScene, NumbersTrianglesAfterTheMeshInInstanceOrder) {
  Scene s;
  s.mesh = random_soup(7, 1);
  s.prototypes = {random_soup(3, 2), random_soup(5, 3)};
  add_instance(s, 1, diagonal(glm::vec3(2.0f)));
  add_instance(s, 0, diagonal(glm::vec3(1.0f)));
  add_instance(s, 1, diagonal(glm::vec3(4.0f)));
  EXPECT_EQ(s.drawn_triangles(), 7u + 5u + 3u + 5u);
  EXPECT_EQ(s.stored_triangles(), 7u + 3u + 5u);
  EXPECT_EQ(s.instances[0].first_prim, 7u);
  EXPECT_EQ(s.instances[1].first_prim, 12u);
  EXPECT_EQ(s.instances[2].first_prim, 15u);
  EXPECT_EQ(&s.instance_of(7), &s.instances[0]);
  EXPECT_EQ(&s.instance_of(11), &s.instances[0]);
  EXPECT_EQ(&s.instance_of(12), &s.instances[1]);
  EXPECT_EQ(&s.instance_of(19), &s.instances[2]);
}

TEST(InstancedScene, InverseUndoesTheTransform) {
  const Affine a = make_affine({30, -70, 110}, {2.0f, -0.5f, 1.25f}, {3, -4, 5});
  const Affine b = inverse(a);
  const glm::vec3 p(0.3f, -1.7f, 2.2f);
  const glm::vec3 back = b.apply(a.apply(p));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(back[k], p[k], 1e-5f);
}

// The world triangle of an instanced hit is what flattening stores, bit for bit, whatever the
// transform: both move the vertices with Affine::apply and derive edges and normal as
// TriangleMesh::add does. The normal is the inverse transpose of the object normal, flipped by a
// mirror (negative determinant), checked here against that formula.
TEST(InstancedScene, WorldTrianglesAreTheFlattenedOnesAndNormalsFollowTheInverseTranspose) {
  const Scene s = random_instanced_scene(6, 11, /*exact=*/false);
  const Scene flat = flattened(s);
  ASSERT_EQ(flat.mesh.size(), s.drawn_triangles());
  int mirrored = 0;
  for (uint32_t prim = 0; prim < flat.mesh.size(); ++prim) {
    const SurfaceTriangle t = s.triangle(prim);
    const SurfaceTriangle f = stored_triangle(flat.mesh, prim);
    ASSERT_EQ(std::memcmp(&t, &f, sizeof t), 0) << prim;
    if (prim < s.mesh.size()) continue;
    const Instance& inst = s.instance_of(prim);
    const glm::vec3 n_obj = s.prototypes[inst.prototype].normal()[prim - inst.first_prim];
    if (n_obj == glm::vec3(0.0f) || t.normal == glm::vec3(0.0f)) continue;
    const float det = glm::determinant(inst.to_world.linear);
    mirrored += det < 0.0f;
    const glm::vec3 want =
        glm::normalize(glm::transpose(inst.to_object.linear) * n_obj) * (det < 0.0f ? -1.0f : 1.0f);
    EXPECT_GT(glm::dot(want, t.normal), 0.999f) << prim;
  }
  EXPECT_GT(mirrored, 0) << "the scene should have mirroring instances";
}

// The two-level BVH, single rays and batches, against the instanced brute force: the same rays
// into the same object spaces, so the same hits bit for bit (t, u, v and triangle), ties included.
TEST(InstancedAccel, TwoLevelBvhMatchesInstancedBruteForceBitForBit) {
  const Scene s = random_instanced_scene(12, 21, /*exact=*/false);
  const Scene flat = flattened(s);
  std::vector<Ray> rays = awkward_rays(flat.mesh, 3000, 5);
  for (Ray& r : rays) r.origin *= 4.0f;  // the placements spread over [-6, 6]
  const std::vector<Ray> coherent = coherent_rays(flat.mesh, 100, 6);
  rays.insert(rays.end(), coherent.begin(), coherent.end());
  const auto brute = make_accel(AccelKind::kBrute, s, kDefaultKernel);
  const std::vector<Hit> want = trace(*brute, rays);
  size_t found = 0;
  for (const Hit& h : want) found += h.found() && h.prim >= s.mesh.size();
  EXPECT_GT(found, rays.size() / 4) << "rays should hit instances";
  for (AccelKind kind : {AccelKind::kBvh, AccelKind::kBvhSingle}) {
    const auto accel = make_accel(kind, s, kDefaultKernel);
    expect_same_hits(want, trace(*accel, rays), std::string(accel_name(kind)).c_str());
    expect_same_hits(want, trace(*accel, rays, true), "incoherent");
    EXPECT_EQ(blocked(*brute, rays), blocked(*accel, rays)) << accel_name(kind);
  }
}

// Every kernel, not only the default one: the top level must never drop an instance the kernel
// would hit, whatever the kernel's rounding.
TEST(InstancedAccel, TwoLevelBvhMatchesInstancedBruteForceForEveryKernel) {
  const Scene s = random_instanced_scene(4, 31, /*exact=*/false);
  std::vector<Ray> rays = awkward_rays(flattened(s).mesh, 800, 7);
  for (Kernel k : kAllKernels) {
    const auto brute = make_accel(AccelKind::kBrute, s, k);
    const auto bvh = make_accel(AccelKind::kBvh, s, k);
    expect_same_hits(trace(*brute, rays), trace(*bvh, rays), std::string(kernel_name(k)).c_str());
  }
}

// A scale by one power of two, each axis's sign free (mirrors included), moves every coordinate
// by an exact factor: the world-to-object transform of a ray (multiplying by 2^-k, adding zeros)
// and the flattening (2^k v) round nothing, and every operation of the kernel on the scaled values
// gives the scaled result (no overflow or underflow here), so an instance is hit exactly where its
// flattened copy is, at the same t. The factor must be the same on every axis: the watertight
// kernel picks its axes by the direction's largest component, and a non-uniform scale can change
// that choice and so the rounding. Translations are left out too: o - t rounds for an arbitrary
// ray origin (a shadow ray's), so they can move a hit by an ulp. General transforms are compared
// within a tolerance below. One thing the exact factor leaves: a mirror negates the kernel's edge
// functions, so a ray through a vertex, where they are zero, may get u or v as -0 instead of +0
// (the same number; the hit point is the vertex either way).
TEST(InstancedAccel, ExactTransformsHitBitForBitLikeTheFlattenedScene) {
  const Scene s = random_instanced_scene(8, 41, /*exact=*/true);
  const Scene flat = flattened(s);
  const std::vector<Ray> rays = awkward_rays(flat.mesh, 4000, 9);
  const BruteForceAccel oracle(flat.mesh, kDefaultKernel);
  const std::vector<Hit> want = trace(oracle, rays);
  for (AccelKind kind : {AccelKind::kBrute, AccelKind::kBvh}) {
    const auto accel = make_accel(kind, s, kDefaultKernel);
    expect_same_hits(want, trace(*accel, rays), std::string(accel_name(kind)).c_str(),
                     /*zero_sign_free=*/true);
    EXPECT_EQ(blocked(oracle, rays), blocked(*accel, rays));
  }
}

// General transforms: the object-space ray is the world ray rounded, and the flattened triangle
// is the prototype's moved with rounding, so the two hit points differ by a few ulps of the
// coordinates (times the transform's stretch), which along a ray meeting the plane at angle theta
// moves t by that much over sin(theta); a ray through a shared edge or vertex may take the
// neighbour. Rays aimed inside triangles (away from edges) must hit the same triangle with t
// within 2^-16 (|o| + |x|) / sin(theta): a few hundred ulps, to allow the stretch of scales 0.3 to
// 2.
TEST(InstancedAccel, GeneralTransformsHitLikeTheFlattenedSceneWithinRounding) {
  const Scene s = random_instanced_scene(10, 51, /*exact=*/false);
  const Scene flat = flattened(s);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), pos(-12.0f, 12.0f);
  std::uniform_int_distribution<uint32_t> tri(0, static_cast<uint32_t>(flat.mesh.size() - 1));
  std::vector<Ray> rays;
  for (int i = 0; i < 4000; ++i) {
    const uint32_t t = tri(rng);
    const float a = 0.1f + 0.35f * unit(rng), b = 0.1f + 0.35f * unit(rng);
    const glm::vec3 target = flat.mesh.v0()[t] + a * flat.mesh.e1(t) + b * flat.mesh.e2(t);
    Ray r;
    r.origin = {pos(rng), pos(rng), pos(rng)};
    r.dir = glm::normalize(target - r.origin);
    rays.push_back(r);
  }
  const BruteForceAccel oracle(flat.mesh, kDefaultKernel);
  const std::vector<Hit> want = trace(oracle, rays);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  const std::vector<Hit> got = trace(*accel, rays);
  size_t same_prim = 0, found = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(want[i].found(), got[i].found()) << i;
    if (!want[i].found()) continue;
    ++found;
    if (want[i].prim != got[i].prim) continue;
    ++same_prim;
    const glm::vec3 x = rays[i].origin + want[i].t * rays[i].dir;
    const float size = glm::length(rays[i].origin) + glm::length(x);
    const float sin_theta = std::abs(glm::dot(rays[i].dir, flat.mesh.normal()[want[i].prim]));
    EXPECT_NEAR(got[i].t, want[i].t, 0x1p-16f * size / sin_theta) << i;
  }
  EXPECT_EQ(found, rays.size());
  // Two random soups overlap: a ray may meet two triangles a rounding apart. Not more than 0.5%.
  EXPECT_GE(same_prim, found - found / 200);
}

TEST(InstancedAccel, EmbreeRefusesInstancedScenes) {
  const Scene s = random_instanced_scene(1, 61, false);
  try {
    (void)make_accel(AccelKind::kEmbree, s, kDefaultKernel);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "--accel");
  }
}

TEST(InstancedAccel, SceneWithoutInstancesGetsThePlainStructure) {
  Scene s;
  s.mesh = random_soup(50, 71);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  EXPECT_EQ(dynamic_cast<const InstancedAccel*>(accel.get()), nullptr);
}

}  // namespace
}  // namespace tritrace

// Convex groups (bvh/convex_groups.h) and the BVH's skipping of the group a ray leaves: which
// meshes are convex, by construction; and rays leaving triangles as the path tracer's do, whose
// closest hits and occlusion through BvhAccel with their origin triangles must be brute force's
// without them.
#include "tritrace/accel/bvh/convex_groups.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>
#include <iterator>
#include <limits>
#include <random>
#include <vector>

#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/accel/recording_accel.h"
#include "tritrace/render/surface_offset.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

using bvh::find_convex_groups;
using bvh::kNoGroup;

// An axis-aligned box from lo to hi: 12 triangles, wound so that TriangleMesh's normal
// (normalize(cross(e2, e1))) points out, or in with `inward`; `skip_face` (0-5: -x, +x, -y, +y,
// -z, +z) leaves that face out.
void add_box(TriangleMesh& m, glm::vec3 lo, glm::vec3 hi, bool inward = false, int skip_face = -1) {
  const auto corner = [&](int i) {
    return glm::vec3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
  };
  // Each face's corners counter-clockwise seen from outside (so cross(b - a, c - a) points out).
  const int faces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (int f = 0; f < 6; ++f) {
    if (f == skip_face) continue;
    const glm::vec3 a = corner(faces[f][0]), b = corner(faces[f][1]), c = corner(faces[f][2]),
                    d = corner(faces[f][3]);
    // TriangleMesh's normal is cross(e2, e1) = cross(c - a, b - a): out when added as (a, c, b).
    if (inward) {
      m.add(a, b, c, 0);
      m.add(a, c, d, 0);
    } else {
      m.add(a, c, b, 0);
      m.add(a, d, c, 0);
    }
  }
}

// An L-shaped prism (non-convex): the L in the xy plane, extruded along z, sides as quads.
void add_l_solid(TriangleMesh& m, glm::vec3 at) {
  const glm::vec2 outline[6] = {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  const auto p = [&](int i, float z) { return at + glm::vec3(outline[i % 6], z); };
  for (int i = 0; i < 6; ++i) {
    const glm::vec3 a = p(i, 0), b = p(i + 1, 0), c = p(i + 1, 1), d = p(i, 1);
    m.add(a, c, b, 0);
    m.add(a, d, c, 0);
  }
  // Caps as fans from the reflex corner 3, which sees every other corner.
  for (int i = 4; i < 8; ++i) {
    m.add(p(3, 0), p(i, 0), p(i + 1, 0), 0);
    m.add(p(3, 1), p(i + 1, 1), p(i, 1), 0);
  }
}

LoadedScene sky_scene() {
  return load_scene(std::string(TRITRACE_SOURCE_DIR) + "/scenes/sky.json");
}

// The centroid of triangle t.
glm::vec3 centroid(const TriangleMesh& m, size_t t) {
  return (m.v0()[t] + m.v1()[t] + m.v2()[t]) / 3.0f;
}

// Every face's group normal points away from `centre` (the group's outer side).
void expect_outward(const bvh::ConvexGroups& g, const TriangleMesh& m, size_t first, size_t end,
                    glm::vec3 centre) {
  for (size_t t = first; t < end; ++t) {
    const glm::vec3 n(g.faces[t].n[0], g.faces[t].n[1], g.faces[t].n[2]);
    EXPECT_NEAR(glm::length(n), 1.0f, 1e-5f) << t;
    EXPECT_GT(glm::dot(n, centroid(m, t) - centre), 0.0f) << t;
  }
}

TEST(ConvexGroups, ACubeIsOneGroupWhicheverWayItIsWound) {
  for (const bool inward : {false, true}) {
    TriangleMesh m;
    add_box(m, glm::vec3(-1.0f), glm::vec3(1.0f), inward);
    const bvh::ConvexGroups g = find_convex_groups(m);
    ASSERT_EQ(g.count(), 1u);
    EXPECT_EQ(g.flat[0], 0);
    for (const bvh::ConvexFace& f : g.faces) EXPECT_EQ(f.group, 0u);
    // A room seen from inside (inward normals) is a convex surface too: its outer side is out.
    expect_outward(g, m, 0, m.size(), glm::vec3(0.0f));
  }
}

TEST(ConvexGroups, AnOpenBoxIsOneGroup) {
  TriangleMesh m;
  add_box(m, glm::vec3(0.0f), glm::vec3(1.0f, 2.0f, 3.0f), false, 3);
  const bvh::ConvexGroups g = find_convex_groups(m);
  ASSERT_EQ(g.count(), 1u);
  for (const bvh::ConvexFace& f : g.faces) EXPECT_EQ(f.group, 0u);
  expect_outward(g, m, 0, m.size(), glm::vec3(0.5f, 1.0f, 1.5f));
}

TEST(ConvexGroups, AnLShapedSolidIsNone) {
  TriangleMesh m;
  add_l_solid(m, glm::vec3(0.0f));
  const bvh::ConvexGroups g = find_convex_groups(m);
  EXPECT_EQ(g.count(), 0u);
  for (const bvh::ConvexFace& f : g.faces) EXPECT_EQ(f.group, kNoGroup);
}

TEST(ConvexGroups, InconsistentWindingIsNone) {
  TriangleMesh m;
  add_box(m, glm::vec3(-1.0f), glm::vec3(1.0f));
  // One face turned inside out: its two triangles' normals point in.
  TriangleMesh flipped;
  for (size_t t = 0; t < m.size(); ++t) {
    if (t < 2) {
      flipped.add(m.v0()[t], m.v2()[t], m.v1()[t], 0);
    } else {
      flipped.add(m.v0()[t], m.v1()[t], m.v2()[t], 0);
    }
  }
  EXPECT_EQ(find_convex_groups(flipped).count(), 0u);
}

TEST(ConvexGroups, SeparateCubesAreSeparateGroupsAndAFlatQuadIsFlat) {
  TriangleMesh m;
  add_box(m, glm::vec3(0.0f), glm::vec3(1.0f));
  add_l_solid(m, glm::vec3(5.0f, 0.0f, 0.0f));
  const size_t l_end = m.size();
  add_box(m, glm::vec3(3.0f, 0.0f, 0.0f), glm::vec3(4.0f, 1.0f, 1.0f));
  const size_t quad = m.size();
  m.add(glm::vec3(0, 5, 0), glm::vec3(1, 5, 1), glm::vec3(1, 5, 0), 0);
  m.add(glm::vec3(0, 5, 0), glm::vec3(0, 5, 1), glm::vec3(1, 5, 1), 0);
  const bvh::ConvexGroups g = find_convex_groups(m);
  ASSERT_EQ(g.count(), 3u);
  const uint32_t first = g.faces[0].group, second = g.faces[l_end].group,
                 flat = g.faces[quad].group;
  for (size_t t = 0; t < 12; ++t) EXPECT_EQ(g.faces[t].group, first);
  for (size_t t = 12; t < l_end; ++t) EXPECT_EQ(g.faces[t].group, kNoGroup);  // the L
  for (size_t t = l_end; t < quad; ++t) EXPECT_EQ(g.faces[t].group, second);
  EXPECT_EQ(g.faces[quad + 1].group, flat);
  EXPECT_NE(first, second);
  EXPECT_NE(flat, first);
  EXPECT_NE(flat, second);
  EXPECT_EQ(g.flat[first], 0);
  EXPECT_EQ(g.flat[second], 0);
  EXPECT_EQ(g.flat[flat], 1);
  // Components above the size limit are not tested.
  EXPECT_EQ(find_convex_groups(m, 11).count(), 1u);  // the quad alone
}

TEST(ConvexGroups, TheFacetedSphereOfTheScenesIsConvex) {
  const LoadedScene loaded = sky_scene();
  const TriangleMesh& m = loaded.scene.mesh;
  ASSERT_EQ(m.size(), 2u + 3u * 1280u);
  const bvh::ConvexGroups g = find_convex_groups(m);
  // The ground (two triangles, flat) and the three spheres.
  ASSERT_EQ(g.count(), 4u);
  EXPECT_EQ(g.flat[g.faces[0].group], 1);
  for (int s = 0; s < 3; ++s) {
    const size_t first = 2 + 1280 * static_cast<size_t>(s);
    const uint32_t group = g.faces[first].group;
    ASSERT_NE(group, kNoGroup);
    EXPECT_EQ(g.flat[group], 0);
    glm::vec3 centre(0.0f);
    for (size_t t = first; t < first + 1280; ++t) {
      EXPECT_EQ(g.faces[t].group, group);
      centre += centroid(m, t);
    }
    expect_outward(g, m, first, first + 1280, centre / 1280.0f);
  }
}

TEST(ConvexGroups, RaysIntoTheirGroupOrGrazingItSkipNothing) {
  TriangleMesh m;
  add_box(m, glm::vec3(-1.0f), glm::vec3(1.0f), true);  // a room
  const bvh::ConvexGroups g = find_convex_groups(m);
  ASSERT_EQ(g.count(), 1u);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> s(-1.0f, 1.0f);
  int skipped = 0;
  for (int k = 0; k < 10000; ++k) {
    const uint32_t t = static_cast<uint32_t>(k % m.size());
    const glm::vec3 d(s(rng), s(rng), s(rng));
    const glm::vec3 into_room = m.normal()[t];  // the room's walls face in
    const uint32_t skip = bvh::skip_group(g.faces, g.flat, t, &d.x);
    if (glm::dot(d, into_room) >= 0.0f) {
      EXPECT_EQ(skip, kNoGroup) << t;
    }
    if (glm::dot(d, into_room) < -1e-2f * glm::length(d)) {
      EXPECT_EQ(skip, 0u) << t;
      ++skipped;
    }
  }
  EXPECT_GT(skipped, 3000);
  // Along the wall, and no triangle: nothing.
  const glm::vec3 along = m.v1()[0] - m.v0()[0];
  EXPECT_EQ(bvh::skip_group(g.faces, g.flat, 0, &along.x), kNoGroup);
  const glm::vec3 any(1.0f, 2.0f, 3.0f);
  EXPECT_EQ(bvh::skip_group(g.faces, g.flat, kNoHit, &any.x), kNoGroup);
}

// A scene of convex and other meshes: the sky scene's ground and spheres, plus a room around them,
// a cube, an open box and an L-shaped solid.
TriangleMesh mixed_scene() {
  const LoadedScene loaded = sky_scene();
  TriangleMesh m;
  m.append(loaded.scene.mesh, 0);
  add_box(m, glm::vec3(-6.0f, -6.0f, -6.0f), glm::vec3(6.0f, 1.5f, 6.0f), true);
  add_box(m, glm::vec3(1.8f, 0.2f, -0.5f), glm::vec3(2.6f, 0.95f, 0.3f));
  add_box(m, glm::vec3(-2.8f, 0.1f, -0.5f), glm::vec3(-2.0f, 0.95f, 0.3f), false, 2);
  add_l_solid(m, glm::vec3(-1.0f, -1.5f, 1.2f));
  return m;
}

// Rays from random points of random triangles, to either side, started as the path tracer starts
// them (leave_surface), some to a point (shadow rays), some unbounded (bounce rays).
struct LeavingRays {
  std::vector<Ray> rays;
  std::vector<uint32_t> origins;
};

LeavingRays leaving_rays(const TriangleMesh& m, int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f), s(-1.0f, 1.0f);
  std::uniform_int_distribution<uint32_t> pick(0, static_cast<uint32_t>(m.size() - 1));
  LeavingRays out;
  while (out.rays.size() < static_cast<size_t>(n)) {
    const uint32_t t = pick(rng);
    const SurfaceTriangle tri = stored_triangle(m, t);
    if (!(glm::length(tri.normal) > 0.5f)) continue;
    float b1 = u(rng), b2 = u(rng);
    if (b1 + b2 > 1.0f) {
      b1 = 1.0f - b1;
      b2 = 1.0f - b2;
    }
    const glm::vec3 x = tri.v0 + b1 * tri.e1 + b2 * tri.e2;
    glm::vec3 d(s(rng), s(rng), s(rng));
    if (!(glm::length(d) > 0.05f)) continue;
    d = glm::normalize(d);
    // A quarter of the rays nearly graze their triangle.
    if (out.rays.size() % 4 == 0)
      d = glm::normalize(d - 0.999f * glm::dot(d, tri.normal) * tri.normal);
    const glm::vec3 side = glm::dot(d, tri.normal) >= 0.0f ? tri.normal : -tri.normal;
    Ray r;
    r.origin = leave_surface(tri, x, side, RayOffsetParams{});
    r.dir = d;
    r.tmin = 0.0f;
    r.tmax = out.rays.size() % 2 ? 1.5f : kRayTMax;
    out.rays.push_back(r);
    out.origins.push_back(t);
  }
  return out;
}

void expect_brute_force_answers(const TriangleMesh& m, BvhTraversal traversal) {
  const BvhAccel bvh(m, kDefaultKernel, bvh::default_build_config(m.size()), traversal);
  const BruteForceAccel brute(m, kDefaultKernel);
  ASSERT_GT(bvh.convex_groups().count(), 5u);
  const LeavingRays in = leaving_rays(m, 20000, 11);
  std::vector<Hit> got(in.rays.size()), want(in.rays.size());
  std::vector<uint8_t> blocked(in.rays.size()), want_blocked(in.rays.size());
  // In batches of 64, as the path tracer's.
  for (size_t first = 0; first < in.rays.size(); first += 64) {
    const size_t k = std::min<size_t>(64, in.rays.size() - first);
    const std::span<const Ray> rays(in.rays.data() + first, k);
    const std::span<const uint32_t> origins(in.origins.data() + first, k);
    bvh.intersect_incoherent_from(rays, origins, std::span<Hit>(got.data() + first, k));
    bvh.occluded_incoherent_from(rays, origins, std::span<uint8_t>(blocked.data() + first, k));
  }
  brute.intersect(in.rays, want);
  brute.occluded(in.rays, want_blocked);
  size_t skipping = 0, skipping_hits = 0;
  const bvh::ConvexGroups& g = bvh.convex_groups();
  for (size_t i = 0; i < in.rays.size(); ++i) {
    EXPECT_EQ(got[i].prim, want[i].prim) << i;
    EXPECT_EQ(got[i].t, want[i].t) << i;
    EXPECT_EQ(blocked[i] != 0, want_blocked[i] != 0) << i;
    const uint32_t skip = bvh::skip_group(g.faces, g.flat, in.origins[i], &in.rays[i].dir.x);
    if (skip != kNoGroup) {
      ++skipping;
      skipping_hits += want[i].found();
      // Brute force agrees that nothing of the group is hit.
      if (want[i].found()) {
        EXPECT_NE(g.faces[want[i].prim].group, skip) << i;
      }
    }
  }
  // The skipping is exercised, also by rays that hit something else.
  EXPECT_GT(skipping, in.rays.size() / 4);
  EXPECT_GT(skipping_hits, skipping / 10);
}

TEST(ConvexGroups, RaysLeavingTrianglesGetBruteForceAnswersWithTheirOrigins) {
  const TriangleMesh m = mixed_scene();
  expect_brute_force_answers(m, BvhTraversal::kSingle);
  expect_brute_force_answers(m, BvhTraversal::kAuto);
}

// BvhAccel screens each batch's rays against the root eight at a time (root_survivors in
// bvh_accel.cpp) and traverses only those that meet a root box. On the open sky scene most rays
// leave past every root box: they, rays that meet one, rays that cannot be traced (NaN, infinite or
// zero directions, empty intervals), rays parallel to an axis and batches of every length up to
// and past the screen's chunks must get brute force's answers, with and without origins.
TEST(ConvexGroups, BatchesOfRaysPastTheRootGetBruteForceAnswers) {
  const TriangleMesh m = sky_scene().scene.mesh;
  const BvhAccel bvh(m, kDefaultKernel, bvh::default_build_config(m.size()));
  const BruteForceAccel brute(m, kDefaultKernel);
  LeavingRays in = leaving_rays(m, 3000, 17);
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> s(-1.0f, 1.0f), height(-3.0f, 0.9f);
  for (int k = 0; k < 3000; ++k) {
    // From above the ground (y < 1 is above: the scene's up is -y), anywhere around the spheres.
    Ray r;
    r.origin = glm::vec3(4.0f * s(rng), height(rng), 4.0f * s(rng));
    r.dir = glm::vec3(s(rng), s(rng), s(rng));
    if (k % 5 == 0) r.dir[k % 3] = 0.0f;  // parallel to an axis's slabs
    if (k % 7 == 0) r.dir = glm::vec3(0.0f, k % 2 ? 1.0f : -1.0f, 0.0f);
    r.tmax = k % 3 == 0 ? 2.0f : kRayTMax;
    in.rays.push_back(r);
    in.origins.push_back(kNoHit);
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const glm::vec3 bad_dirs[4] = {glm::vec3(0.0f), glm::vec3(nan, 0.0f, 1.0f),
                                 glm::vec3(0.0f, inf, 0.0f), glm::vec3(0.3f, -1.0f, 0.2f)};
  for (int k = 0; k < 40; ++k) {
    Ray r;
    r.origin = k % 5 == 4 ? glm::vec3(nan, 0.0f, 0.0f) : glm::vec3(0.0f, 0.5f, -3.0f);
    r.dir = bad_dirs[k % 4];
    if (k % 4 == 3) r.tmin = 2.0f, r.tmax = 1.0f;  // an empty interval
    in.rays.insert(in.rays.begin() + 37 * k, r);
    in.origins.insert(in.origins.begin() + 37 * k, kNoHit);
  }
  std::vector<Hit> want(in.rays.size());
  std::vector<uint8_t> want_blocked(in.rays.size());
  brute.intersect(in.rays, want);
  brute.occluded(in.rays, want_blocked);
  size_t misses = 0;
  for (const Hit& h : want) misses += !h.found();
  EXPECT_GT(misses, in.rays.size() / 3);  // many rays leave past everything
  EXPECT_LT(misses, in.rays.size() * 9 / 10);
  for (const bool with_origins : {true, false}) {
    std::vector<Hit> got(in.rays.size());
    std::vector<uint8_t> blocked(in.rays.size(), 7);
    const size_t lengths[] = {1, 3, 7, 8, 9, 15, 16, 17, 63, 64, 65, 130, 200};
    size_t first = 0;
    for (size_t b = 0; first < in.rays.size(); ++b) {
      const size_t k = std::min(lengths[b % std::size(lengths)], in.rays.size() - first);
      const std::span<const Ray> rays(in.rays.data() + first, k);
      const std::span<const uint32_t> origins =
          with_origins ? std::span<const uint32_t>(in.origins.data() + first, k)
                       : std::span<const uint32_t>();
      bvh.intersect_incoherent_from(rays, origins, std::span<Hit>(got.data() + first, k));
      bvh.occluded_incoherent_from(rays, origins, std::span<uint8_t>(blocked.data() + first, k));
      first += k;
    }
    for (size_t i = 0; i < in.rays.size(); ++i) {
      EXPECT_EQ(got[i].prim, want[i].prim) << i << " " << with_origins;
      EXPECT_EQ(got[i].t, want[i].t) << i;
      EXPECT_EQ(got[i].u, want[i].u) << i;
      EXPECT_EQ(got[i].v, want[i].v) << i;
      EXPECT_EQ(blocked[i] != 0, want_blocked[i] != 0) << i << " " << with_origins;
      EXPECT_LE(blocked[i], 1) << i;
    }
  }
}

TEST(ConvexGroups, RecordingAccelKeepsAndReplaysTheOrigins) {
  const TriangleMesh m = mixed_scene();
  const BvhAccel bvh(m, kDefaultKernel, bvh::default_build_config(m.size()));
  const LeavingRays in = leaving_rays(m, 300, 5);
  RecordingAccel recording(bvh);
  std::vector<Hit> hits(in.rays.size());
  std::vector<uint8_t> blocked(in.rays.size());
  recording.intersect_incoherent_from(in.rays, in.origins, hits);
  recording.occluded_incoherent(in.rays, blocked);  // without origins: kNoHit recorded
  const RecordedRays r = recording.take();
  EXPECT_EQ(r.closest.origins, in.origins);
  EXPECT_EQ(r.any.origins, std::vector<uint32_t>(in.rays.size(), kNoHit));
  std::vector<Hit> again(in.rays.size());
  replay_closest(bvh, r.closest, again, 1);
  for (size_t i = 0; i < hits.size(); ++i) {
    EXPECT_EQ(std::memcmp(&again[i], &hits[i], sizeof(Hit)), 0) << i;
  }
}

}  // namespace
}  // namespace tritrace

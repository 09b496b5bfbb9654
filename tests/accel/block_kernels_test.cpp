// The BVH's SIMD leaf kernels against the scalar kernels they must equal bit for bit: each lane of
// block_watertight and block_moller_trumbore, and the packet leaves through the BVH, on rays that
// go through triangle interiors, edges and vertices exactly (where the watertight kernel takes its
// exact fallback) and on random rays.
#include "tritrace/accel/bvh/block_kernels.h"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "test_rays.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/bvh_accel.h"

#if defined(__AVX2__)

namespace tritrace {
namespace {

using bvh::TriangleBlock;

// A size x size grid of unit squares in the plane z = 0, each split into two triangles along a
// diagonal (alternating), with integer vertices: rays through grid points and lines meet edges and
// vertices exactly.
TriangleMesh grid(int size) {
  TriangleMesh m;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const glm::vec3 a(x, y, 0), b(x + 1, y, 0), c(x + 1, y + 1, 0), d(x, y + 1, 0);
      if ((x + y) % 2 == 0) {
        m.add(a, b, c, 0);
        m.add(a, c, d, 0);
      } else {
        m.add(a, b, d, 0);
        m.add(b, c, d, 0);
      }
    }
  }
  return m;
}

// Rays at points of the grid: straight down the z axis through grid points, edge midpoints and
// interiors (exact zeros in the edge functions), and slanted ones along each axis as dominant
// direction.
std::vector<Ray> grid_rays(int size, uint32_t seed) {
  std::mt19937 rng(seed);
  // Inside the grid, not on its outer border: a slanted ray's rounded origin may pass a border
  // point on the outside.
  std::uniform_int_distribution<int> cell(1, 2 * size - 1);
  std::uniform_real_distribution<float> tilt(-0.5f, 0.5f);
  std::vector<Ray> rays;
  for (int i = 0; i < 4000; ++i) {
    const glm::vec3 target(0.5f * static_cast<float>(cell(rng)),
                           0.5f * static_cast<float>(cell(rng)), 0.0f);
    Ray r;
    switch (i % 4) {
      case 0:
        r.dir = {0.0f, 0.0f, 1.0f};
        break;
      case 1:
        r.dir = {tilt(rng), tilt(rng), 1.0f};
        break;
      case 2:  // dominant x: grazing the grid
        r.dir = {1.0f, tilt(rng), 0.25f * tilt(rng)};
        break;
      default:  // dominant y, from the other side
        r.dir = {tilt(rng), -1.0f, -0.25f * tilt(rng)};
    }
    r.origin = target - 2.0f * r.dir;
    rays.push_back(r);
  }
  return rays;
}

bool same_hit(const Hit& a, const Hit& b) {
  return a.prim == b.prim && std::memcmp(&a.t, &b.t, sizeof(float)) == 0 &&
         std::memcmp(&a.u, &b.u, sizeof(float)) == 0 && std::memcmp(&a.v, &b.v, sizeof(float)) == 0;
}

// Every block of the mesh's BVH against every ray: the SIMD kernel's best hit and any-hit answers
// (block_watertight with nullptr, block_watertight_occluded) equal a scalar loop over the block's
// triangles.
template <Kernel K>
void expect_blocks_match_scalar(const TriangleMesh& mesh, const std::vector<Ray>& rays,
                                int* hits_seen) {
  const bvh::WideBvh tree = bvh::build_wide_bvh(mesh);
  const TriangleArrays tris = mesh.arrays();
  int mismatches = 0;
  for (const Ray& ray : rays) {
    const PreparedRay<K> prepared(ray);
    for (const TriangleBlock& b : tree.blocks) {
      Hit want;
      for (int l = 0; l < bvh::kWidth; ++l) {
        if (b.prim[l] == kNoHit) continue;
        TriangleHit h;
        if (prepared.intersect(tris, b.prim[l], h)) bvh::offer(want, h.t, h.u, h.v, b.prim[l]);
      }
      Hit got;
      bool any;
      if constexpr (K == Kernel::kWatertight) {
        bvh::block_watertight(b, prepared.watertight(), &got);
        any = bvh::block_watertight(b, prepared.watertight(), nullptr);
        // The any-hit form of the interleaved shadow-ray traversal, for the ray's dominant axis.
        const WatertightRay& wt = prepared.watertight();
        const bool occluded = wt.kz == 0   ? bvh::block_watertight_occluded<0>(b, wt)
                              : wt.kz == 1 ? bvh::block_watertight_occluded<1>(b, wt)
                                           : bvh::block_watertight_occluded<2>(b, wt);
        if (occluded != want.found() && ++mismatches <= 5) {
          ADD_FAILURE() << "block_watertight_occluded: " << occluded << ", scalar prim "
                        << want.prim;
        }
      } else {
        bvh::block_moller_trumbore(b, ray, &got);
        any = bvh::block_moller_trumbore(b, ray, nullptr);
      }
      *hits_seen += want.found();
      if ((!same_hit(want, got) || any != want.found()) && ++mismatches <= 5) {
        ADD_FAILURE() << kernel_name(K) << ": scalar prim " << want.prim << " t " << want.t
                      << ", block prim " << got.prim << " t " << got.t << " any " << any;
      }
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST(BlockKernels, WatertightEqualsScalarThroughEdgesAndVertices) {
  int hits = 0;
  expect_blocks_match_scalar<Kernel::kWatertight>(grid(6), grid_rays(6, 1), &hits);
  EXPECT_GT(hits, 1000);
}

TEST(BlockKernels, WatertightEqualsScalarOnRandomRays) {
  int hits = 0;
  const TriangleMesh soup = random_soup(400, 2);
  expect_blocks_match_scalar<Kernel::kWatertight>(soup, awkward_rays(soup, 1500, 3), &hits);
  const TriangleMesh mixed = mixed_magnitude_soup(400, 4);
  expect_blocks_match_scalar<Kernel::kWatertight>(mixed, awkward_rays(mixed, 1500, 5), &hits);
  EXPECT_GT(hits, 500);
}

TEST(BlockKernels, MollerTrumboreEqualsScalar) {
  int hits = 0;
  expect_blocks_match_scalar<Kernel::kMollerTrumbore>(grid(6), grid_rays(6, 6), &hits);
  const TriangleMesh mixed = mixed_magnitude_soup(400, 7);
  expect_blocks_match_scalar<Kernel::kMollerTrumbore>(mixed, awkward_rays(mixed, 1500, 8), &hits);
  EXPECT_GT(hits, 1000);
}

// Through the BVH: packets of 16 coherent rays (all down the z axis: one dominant axis for the
// packet) and mixed packets (consecutive rays of grid_rays, whose dominant axes differ), at the
// grid's points and lines. The grid has no holes, so every ray aimed inside it must hit, and the
// BVH must return exactly brute force's hits.
TEST(BlockKernels, PacketsThroughSharedEdgesHitAndEqualBruteForce) {
  const TriangleMesh mesh = grid(8);
  std::vector<Ray> rays = grid_rays(8, 9);
  for (int y = 1; y < 16; ++y) {
    for (int x = 1; x < 16; ++x) {
      Ray r;
      r.origin = {0.5f * static_cast<float>(x), 0.5f * static_cast<float>(y), -1.0f};
      rays.push_back(r);
    }
  }
  const BruteForceAccel brute(mesh, Kernel::kWatertight);
  const BvhAccel bvh(mesh, Kernel::kWatertight);
  std::vector<Hit> want(rays.size()), got(rays.size());
  std::vector<uint8_t> occ_want(rays.size()), occ_got(rays.size());
  brute.intersect(rays, want);
  bvh.intersect(rays, got);
  brute.occluded(rays, occ_want);
  bvh.occluded(rays, occ_got);
  int leaks = 0, mismatches = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    leaks += !want[i].found();
    mismatches += !same_hit(want[i], got[i]) || occ_want[i] != occ_got[i];
  }
  EXPECT_EQ(leaks, 0) << "rays aimed inside a closed grid must hit it";
  EXPECT_EQ(mismatches, 0);
}

}  // namespace
}  // namespace tritrace

#endif  // __AVX2__

// Best-first closest-point traversal of the wide BVH. Box distances are computed eight children at
// a time (AVX2 where the build has it) and compared with the best squared distance so far made a
// little larger, so that float rounding in a box distance never prunes a subtree holding a nearer
// triangle; at a leaf the same test on each triangle's own box skips most exact evaluations.
#include "tritrace/accel/bvh/closest_point.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "tritrace/accel/bvh/ray_box.h"
#include "tritrace/accel/bvh/traversal_stack.h"
#include "tritrace/geometry/point_triangle_distance.h"
#include "tritrace/parallel.h"

namespace tritrace::bvh {
namespace {

// A float box distance carries a relative error of a few units in the last place (one rounding
// per subtraction, square and sum); the pruning bound is the best squared distance times this.
constexpr float kBoundScale = 1.0f + 0x1p-19f;

struct Best {
  double distance2 = std::numeric_limits<double>::infinity();
  TrianglePoint point;
  uint32_t prim = kNoHit;
  float bound = std::numeric_limits<float>::infinity();  // prune boxes whose distance^2 exceeds it

  void offer(const TrianglePoint& p, uint32_t prim_index) {
    if (p.distance2 < distance2 || (p.distance2 == distance2 && prim_index < prim)) {
      distance2 = p.distance2;
      point = p;
      prim = prim_index;
      bound = static_cast<float>(distance2) * kBoundScale;
    }
  }
};

// Squared distances from q to eight boxes given as lo/hi arrays per axis (an inverted, empty box
// gives +inf), and the mask of those not beyond `bound`.
inline uint32_t box_distances(const float* lo_x, const float* hi_x, const float* lo_y,
                              const float* hi_y, const float* lo_z, const float* hi_z,
                              const glm::vec3& q, float bound, float* d2) {
#if defined(__AVX2__)
  const __m256 zero = _mm256_setzero_ps();
  const float* lo[3] = {lo_x, lo_y, lo_z};
  const float* hi[3] = {hi_x, hi_y, hi_z};
  __m256 sum = zero;
  for (int a = 0; a < 3; ++a) {
    const __m256 p = _mm256_set1_ps(q[a]);
    const __m256 below = _mm256_sub_ps(_mm256_loadu_ps(lo[a]), p);
    const __m256 above = _mm256_sub_ps(p, _mm256_loadu_ps(hi[a]));
    const __m256 d = _mm256_max_ps(_mm256_max_ps(below, above), zero);
    sum = _mm256_add_ps(sum, _mm256_mul_ps(d, d));
  }
  _mm256_storeu_ps(d2, sum);
  return static_cast<uint32_t>(
      _mm256_movemask_ps(_mm256_cmp_ps(sum, _mm256_set1_ps(bound), _CMP_LE_OQ)));
#else
  const float* lo[3] = {lo_x, lo_y, lo_z};
  const float* hi[3] = {hi_x, hi_y, hi_z};
  uint32_t mask = 0;
  for (int i = 0; i < kWidth; ++i) {
    float sum = 0.0f;
    for (int a = 0; a < 3; ++a) {
      const float d = std::max(std::max(lo[a][i] - q[a], q[a] - hi[a][i]), 0.0f);
      sum += d * d;
    }
    d2[i] = sum;
    if (sum <= bound) mask |= 1u << i;
  }
  return mask;
#endif
}

// The lanes of a block to evaluate exactly: triangles whose own boxes are within the bound (NaN
// padding lanes never are), and every lane whose three corners are one point. Those may be
// zero-area triangles that GeometrySet collapsed onto their first corner so that rays miss them
// (geometry_set.h): their real corners, read from the mesh, may be nearer than that point.
inline uint32_t block_candidates(const TriangleBlock& b, const glm::vec3& q, float bound,
                                 uint32_t& collapsed) {
  alignas(32) float lo[3][kWidth], hi[3][kWidth], d2[kWidth];
  collapsed = 0;
  for (int i = 0; i < kWidth; ++i) {
    bool point = true;
    for (int a = 0; a < 3; ++a) {
      const float x0 = b.vertex[0][a][i], x1 = b.vertex[1][a][i], x2 = b.vertex[2][a][i];
      lo[a][i] = std::min(std::min(x0, x1), x2);
      hi[a][i] = std::max(std::max(x0, x1), x2);
      point = point && x1 == x0 && x2 == x0;
    }
    collapsed |= point ? 1u << i : 0u;
  }
  return box_distances(lo[0], hi[0], lo[1], hi[1], lo[2], hi[2], q, bound, d2) | collapsed;
}

inline void visit_block(const TriangleBlock& b, const TriangleMesh& mesh, const glm::vec3& q,
                        Best& best) {
  uint32_t collapsed;
  uint32_t mask = block_candidates(b, q, best.bound, collapsed);
  const glm::dvec3 p(q);
  while (mask) {
    const int i = std::countr_zero(mask);
    mask &= mask - 1;
    const uint32_t prim = b.prim[i];
    if (prim == kNoHit) continue;
    if (collapsed >> i & 1u) {
      best.offer(
          closest_point_on_triangle(p, glm::dvec3(mesh.v0()[prim]), glm::dvec3(mesh.v1()[prim]),
                                    glm::dvec3(mesh.v2()[prim])),
          prim);
      continue;
    }
    const glm::dvec3 v0(b.vertex[0][0][i], b.vertex[0][1][i], b.vertex[0][2][i]);
    const glm::dvec3 v1(b.vertex[1][0][i], b.vertex[1][1][i], b.vertex[1][2][i]);
    const glm::dvec3 v2(b.vertex[2][0][i], b.vertex[2][1][i], b.vertex[2][2][i]);
    best.offer(closest_point_on_triangle(p, v0, v1, v2), prim);
  }
}

// The slots of a node that hold a child (an empty slot's box is at distance +inf, which the
// initial bound of +inf would not prune).
inline uint32_t occupied_slots(const WideNode& node) {
#if defined(__AVX2__)
  const __m256i child = _mm256_load_si256(reinterpret_cast<const __m256i*>(node.child));
  const __m256i empty = _mm256_cmpeq_epi32(child, _mm256_set1_epi32(-1));
  return ~static_cast<uint32_t>(_mm256_movemask_ps(_mm256_castsi256_ps(empty))) & 0xFFu;
#else
  uint32_t mask = 0;
  for (int i = 0; i < kWidth; ++i) mask |= node.child[i] != kEmptyChild ? 1u << i : 0u;
  return mask;
#endif
}

ClosestPoint result(const Best& best) {
  ClosestPoint out;
  if (best.prim == kNoHit) return out;
  out.point = glm::vec3(best.point.point);
  out.distance = static_cast<float>(std::sqrt(best.distance2));
  out.prim = best.prim;
  out.u = static_cast<float>(best.point.u);
  out.v = static_cast<float>(best.point.v);
  return out;
}

bool finite(const glm::vec3& q) {
  return std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
}

}  // namespace

ClosestPoint closest_point(const WideBvh& tree, const TriangleMesh& mesh, const glm::vec3& query) {
  if (tree.nodes.empty() || !finite(query)) return {};
  Best best;
  StackEntry stack[kStackSize];
  int sp = 0;
  uint32_t ref = 0;
  alignas(32) float d2[kWidth];
  for (;;) {
    if (ref & kLeafBit) {
      visit_block(tree.blocks[ref & ~kLeafBit], mesh, query, best);
    } else {
      const WideNode& node = tree.nodes[ref];
      uint32_t mask = box_distances(node.lo_x, node.hi_x, node.lo_y, node.hi_y, node.lo_z,
                                    node.hi_z, query, best.bound, d2) &
                      occupied_slots(node);
      if (mask) {
        if (std::has_single_bit(mask)) {
          ref = node.child[std::countr_zero(mask)];
          continue;
        }
        // Nearest child next, the others on the stack with the farthest deepest.
        assert(sp + std::popcount(mask) <= kStackSize);
        StackEntry* top = stack + sp;
        const int n = push_nearest_last(node, mask, d2, top);
        // The stacked children are fetched while the nearest is searched (as in the ray
        // traversal): on a big mesh most visits wait on memory.
        for (int i = 0; i < n - 1; ++i) prefetch(tree, top[i].ref);
        sp += n - 1;
        ref = top[n - 1].ref;
        continue;
      }
    }
    do {
      if (sp == 0) return result(best);
      --sp;
    } while (stack[sp].key > best.bound);
    ref = stack[sp].ref;
  }
}

void closest_points(const WideBvh& tree, const TriangleMesh& mesh,
                    std::span<const glm::vec3> queries, std::span<ClosestPoint> out) {
  assert(queries.size() == out.size());
  parallel::for_range(tbb::blocked_range<size_t>(0, queries.size(), 256), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) out[i] = closest_point(tree, mesh, queries[i]);
  });
}

ClosestPoint closest_point_brute_force(const TriangleMesh& mesh, const glm::vec3& query) {
  if (!finite(query)) return {};
  Best best;
  const glm::dvec3 p(query);
  for (size_t t = 0; t < mesh.size(); ++t) {
    best.offer(closest_point_on_triangle(p, glm::dvec3(mesh.v0()[t]), glm::dvec3(mesh.v1()[t]),
                                         glm::dvec3(mesh.v2()[t])),
               static_cast<uint32_t>(t));
  }
  return result(best);
}

}  // namespace tritrace::bvh

// The hierarchical winding number: expansions of every BVH subtree, made bottom up (children come
// after their parent in WideBvh::nodes), and the traversal that sums far subtrees by their
// expansion and near triangles exactly.
#include "tritrace/accel/bvh/winding_number.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>

#include "tritrace/geometry/hit.h"
#include "tritrace/parallel.h"

namespace tritrace::bvh {
namespace {

constexpr double kInv4Pi = 0.25 / std::numbers::pi;

// One subtree's moments in double while building: summed area (scalar), summed area vector, the
// area-weighted sum of triangle centroids, and the sum of area_vector (x) centroid, all about the
// origin; shifted to the centre when stored.
struct Moments {
  double area = 0.0;
  glm::dvec3 normal{0.0};
  glm::dvec3 weighted_centroid{0.0};
  std::array<double, 9> normal_centroid{};  // (i, j): sum of normal_i * centroid_j

  void add(const Moments& o) {
    area += o.area;
    normal += o.normal;
    weighted_centroid += o.weighted_centroid;
    for (int k = 0; k < 9; ++k) normal_centroid[k] += o.normal_centroid[k];
  }
  void add_triangle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const glm::dvec3 n = 0.5 * glm::cross(b - a, c - a);
    const double A = glm::length(n);
    if (!std::isfinite(A)) return;
    const glm::dvec3 centroid = (a + b + c) / 3.0;
    area += A;
    normal += n;
    weighted_centroid += A * centroid;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) normal_centroid[3 * i + j] += n[i] * centroid[j];
    }
  }
};

// Stores `m` as slot `s` of `out`, centred on its area-weighted centre (the box centre when it has
// no area), with the radius of the child's box about that centre.
void store(const Moments& m, const WideNode& node, int s, float far_ratio, bool first_order_only,
           WindingSlots& out) {
  const glm::dvec3 lo(node.lo_x[s], node.lo_y[s], node.lo_z[s]);
  const glm::dvec3 hi(node.hi_x[s], node.hi_y[s], node.hi_z[s]);
  // The centre as stored, in float, so that the radius and the moments are about that point.
  const glm::dvec3 c(glm::vec3(m.area > 0.0 ? m.weighted_centroid / m.area : 0.5 * (lo + hi)));
  // The farthest box corner from c bounds the distance of every triangle point in the subtree.
  const glm::dvec3 reach = glm::max(glm::abs(hi - c), glm::abs(c - lo));
  const double far = far_ratio * glm::length(reach);
  out.cx[s] = static_cast<float>(c.x);
  out.cy[s] = static_cast<float>(c.y);
  out.cz[s] = static_cast<float>(c.z);
  out.nx[s] = static_cast<float>(m.normal.x);
  out.ny[s] = static_cast<float>(m.normal.y);
  out.nz[s] = static_cast<float>(m.normal.z);
  // sum n_i (centroid - c)_j = sum n_i centroid_j - N_i c_j.
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      out.m[3 * i + j][s] =
          first_order_only ? 0.0f
                           : static_cast<float>(m.normal_centroid[3 * i + j] - m.normal[i] * c[j]);
    }
  }
  // Rounded up so that a subtree is expanded only where the bound surely holds.
  out.far2[s] = std::isfinite(far) ? std::nextafter(static_cast<float>(far * far),
                                                    std::numeric_limits<float>::infinity())
                                   : std::numeric_limits<float>::infinity();
}

Moments block_moments(const TriangleBlock& b) {
  Moments m;
  for (int i = 0; i < kWidth; ++i) {
    if (b.prim[i] == kNoHit) continue;
    glm::dvec3 v[3];
    for (int c = 0; c < 3; ++c)
      v[c] = glm::dvec3(b.vertex[c][0][i], b.vertex[c][1][i], b.vertex[c][2][i]);
    m.add_triangle(v[0], v[1], v[2]);
  }
  return m;
}

void clear(WindingSlots& w, int s) {
  w.cx[s] = w.cy[s] = w.cz[s] = 0.0f;
  w.nx[s] = w.ny[s] = w.nz[s] = 0.0f;
  for (auto& row : w.m) row[s] = 0.0f;
  w.far2[s] = std::numeric_limits<float>::infinity();
}

// The second-order expansion of one slot at query q (Barill et al. 2018, sec. 3, with the
// kernel's gradient and Hessian written out): with r = c - q, the dipole N . r / (4 pi |r|^3) and
// the first-moment term (tr(M) / |r|^3 - 3 r^T M r / |r|^5) / (4 pi).
inline double expansion(const WindingSlots& w, int s, const glm::dvec3& q) {
  const glm::dvec3 r = glm::dvec3(w.cx[s], w.cy[s], w.cz[s]) - q;
  const double r2 = glm::dot(r, r);
  const double inv_r = 1.0 / std::sqrt(r2);
  const double inv_r3 = inv_r * inv_r * inv_r;
  const double inv_r5 = inv_r3 * inv_r * inv_r;
  const glm::dvec3 n(w.nx[s], w.ny[s], w.nz[s]);
  double trace = 0.0, rmr = 0.0;
  for (int i = 0; i < 3; ++i) {
    trace += w.m[4 * i][s];
    for (int j = 0; j < 3; ++j) rmr += r[i] * w.m[3 * i + j][s] * r[j];
  }
  return kInv4Pi * (glm::dot(n, r) * inv_r3 + trace * inv_r3 - 3.0 * rmr * inv_r5);
}

}  // namespace

double triangle_winding(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                        const glm::dvec3& c) {
  const glm::dvec3 x = a - p, y = b - p, z = c - p;
  const double lx = glm::length(x), ly = glm::length(y), lz = glm::length(z);
  const double det = glm::dot(x, glm::cross(y, z));
  const double den = lx * ly * lz + glm::dot(x, y) * lz + glm::dot(y, z) * lx + glm::dot(z, x) * ly;
  // tan(omega / 2) = det / den; a point in the triangle's plane (det = 0) sees no solid angle.
  if (det == 0.0) return 0.0;
  return 2.0 * std::atan2(det, den) * kInv4Pi;
}

WindingNumber::WindingNumber(const WideBvh& tree, const TriangleMesh& mesh, float far_ratio,
                             bool first_order_only) {
  // The blocks hold the exact vertices (GeometrySet's zero-area triangles collapsed to a point,
  // which subtend no solid angle either way).
  (void)mesh;
  slots_.resize(tree.nodes.size());
  // The moments of each node's whole subtree, for its parent's slot.
  std::vector<Moments> subtree(tree.nodes.size());
  for (size_t n = tree.nodes.size(); n-- > 0;) {
    const WideNode& node = tree.nodes[n];
    WindingSlots& w = slots_[n];
    Moments total;
    for (int s = 0; s < kWidth; ++s) {
      const uint32_t child = node.child[s];
      if (child == kEmptyChild) {
        clear(w, s);
        continue;
      }
      const Moments m =
          child & kLeafBit ? block_moments(tree.blocks[child & ~kLeafBit]) : subtree[child];
      store(m, node, s, far_ratio, first_order_only, w);
      total.add(m);
    }
    subtree[n] = total;
  }
}

double WindingNumber::at(const WideBvh& tree, const glm::vec3& query) const {
  if (tree.nodes.empty()) return 0.0;
  const glm::dvec3 q(query);
  double sum = 0.0;
  uint32_t stack[kStackSize];
  int sp = 0;
  stack[sp++] = 0;
  while (sp > 0) {
    const uint32_t n = stack[--sp];
    const WideNode& node = tree.nodes[n];
    const WindingSlots& w = slots_[n];
    for (int s = 0; s < kWidth; ++s) {
      const uint32_t child = node.child[s];
      if (child == kEmptyChild) continue;
      // In double: float's rounding must not call a point inside the radius far.
      const glm::dvec3 r = glm::dvec3(w.cx[s], w.cy[s], w.cz[s]) - q;
      if (glm::dot(r, r) > double(w.far2[s])) {
        sum += expansion(w, s, q);
      } else if (child & kLeafBit) {
        const TriangleBlock& b = tree.blocks[child & ~kLeafBit];
        for (int i = 0; i < kWidth; ++i) {
          if (b.prim[i] == kNoHit) continue;
          glm::dvec3 v[3];
          for (int c = 0; c < 3; ++c) {
            v[c] = glm::dvec3(b.vertex[c][0][i], b.vertex[c][1][i], b.vertex[c][2][i]);
          }
          sum += triangle_winding(q, v[0], v[1], v[2]);
        }
      } else {
        assert(sp < kStackSize);
        stack[sp++] = child;
      }
    }
  }
  return sum;
}

void WindingNumber::inside(const WideBvh& tree, std::span<const glm::vec3> queries,
                           std::span<uint8_t> out) const {
  assert(queries.size() == out.size());
  parallel::for_range(tbb::blocked_range<size_t>(0, queries.size(), 256), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      out[i] = std::abs(at(tree, queries[i])) > 0.5 ? 1 : 0;
    }
  });
}

}  // namespace tritrace::bvh

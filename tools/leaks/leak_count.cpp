// Aiming rays at a closed mesh's edges and vertices, and counting those that slip through.
#include "leaks/leak_count.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <glm/glm.hpp>
#include <random>
#include <stdexcept>

#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace::leaks {
namespace {

// Each chunk of rays draws from its own generator, seeded by (seed, chunk), so the rays do not
// depend on how chunks are spread over threads.
constexpr uint64_t kChunk = 4096;

struct Prepared {
  TriangleMesh mesh;                        // the triangles, in the kernels' layout
  std::vector<glm::vec3> outward;           // per triangle, unit, pointing away from centre
  std::vector<std::vector<uint32_t>> ring;  // per vertex, the triangles using it
  std::vector<EdgeUse> edges;
  glm::vec3 centre{0.0f};
  float radius = 0.0f;
};

Prepared prepare(const IndexedMesh& m) {
  Prepared p;
  p.edges = edge_uses(m);
  for (const EdgeUse& e : p.edges) {
    if (e.triangles != 2) throw std::invalid_argument(m.name + ": not a closed mesh");
  }
  glm::dvec3 sum(0.0);
  for (glm::vec3 v : m.positions) sum += glm::dvec3(v);
  p.centre = glm::vec3(sum / static_cast<double>(m.positions.size()));
  for (glm::vec3 v : m.positions) p.radius = std::max(p.radius, glm::length(v - p.centre));
  p.ring.resize(m.positions.size());
  for (uint32_t t = 0; t < m.triangles.size(); ++t) {
    const auto& [a, b, c] = m.triangles[t];
    p.mesh.add(m.positions[a], m.positions[b], m.positions[c], 0);
    for (uint32_t v : m.triangles[t]) p.ring[v].push_back(t);
    glm::vec3 n = glm::normalize(
        glm::cross(m.positions[b] - m.positions[a], m.positions[c] - m.positions[a]));
    const glm::vec3 mid = (m.positions[a] + m.positions[b] + m.positions[c]) / 3.0f;
    if (glm::dot(n, mid - p.centre) < 0.0f) n = -n;
    p.outward.push_back(n);
  }
  return p;
}

glm::vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<float> normal;
  while (true) {
    const glm::vec3 v(normal(rng), normal(rng), normal(rng));
    const float len = glm::length(v);
    if (len > 1e-3f) return v / len;
  }
}

struct Aim {
  Ray ray;
  float t_target = 0.0f;
  bool inside = false;
  bool vertex = false;
  uint32_t a = 0, b = 0;  // the target's vertices (a == b for a vertex)
};

Aim make_ray(const IndexedMesh& m, const Prepared& p, std::mt19937_64& rng) {
  Aim aim;
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  glm::vec3 target;
  aim.vertex = rng() & 1;
  if (aim.vertex) {
    aim.a = aim.b = static_cast<uint32_t>(rng() % m.positions.size());
    target = m.positions[aim.a];
  } else {
    const EdgeUse& e = p.edges[rng() % p.edges.size()];
    aim.a = e.a;
    aim.b = e.b;
    const glm::vec3 pa = m.positions[e.a], pb = m.positions[e.b];
    target = pa + unit(rng) * (pb - pa);
  }
  aim.inside = rng() & 1;
  glm::vec3 origin;
  if (aim.inside) {
    const glm::vec3 q = m.positions[rng() % m.positions.size()];
    origin = p.centre + (0.9f * unit(rng)) * (q - p.centre);
  } else {
    // Faces at the target: those around a vertex, or the two sharing the edge.
    glm::vec3 mean(0.0f);
    std::vector<glm::vec3> normals;
    for (uint32_t t : p.ring[aim.a]) {
      const auto& tri = m.triangles[t];
      if (std::find(tri.begin(), tri.end(), aim.b) != tri.end()) normals.push_back(p.outward[t]);
    }
    for (glm::vec3 n : normals) mean += n;
    mean = glm::normalize(mean);
    glm::vec3 w = mean;
    for (int attempt = 0; attempt < 64; ++attempt) {
      const glm::vec3 c = glm::normalize(mean + 0.8f * random_unit(rng));
      bool ok = true;
      for (glm::vec3 n : normals) ok = ok && glm::dot(c, n) >= 0.1f;
      if (ok) {
        w = c;
        break;
      }
    }
    origin = target + (2.0f * p.radius) * w;
  }
  aim.ray.origin = origin;
  aim.ray.dir = glm::normalize(target - origin);
  aim.t_target = glm::length(target - origin);
  return aim;
}

template <Kernel K>
bool leaks(const Prepared& p, const Aim& aim, const LeakOptions& options,
           std::vector<uint32_t>& candidates) {
  candidates.clear();
  if (options.all_triangles) {
    for (uint32_t t = 0; t < p.mesh.size(); ++t) candidates.push_back(t);
  } else {
    // Both ends' rings: a target rounded off an edge near its end may lie in any of them.
    candidates = p.ring[aim.a];
    if (aim.b != aim.a)
      candidates.insert(candidates.end(), p.ring[aim.b].begin(), p.ring[aim.b].end());
  }
  const PreparedRay<K> ray(aim.ray);
  const TriangleArrays tris = p.mesh.arrays();
  float closest = kRayTMax;
  bool any = false;
  for (uint32_t t : candidates) {
    TriangleHit h;
    if (ray.intersect(tris, t, h)) {
      any = true;
      closest = std::min(closest, h.t);
    }
  }
  if (aim.inside) return !any;
  return !any || closest > aim.t_target * (1.0f + 1e-5f);
}

}  // namespace

LeakCounts& LeakCounts::operator+=(const LeakCounts& o) {
  rays += o.rays;
  leaks += o.leaks;
  inside_rays += o.inside_rays;
  inside_leaks += o.inside_leaks;
  outside_rays += o.outside_rays;
  outside_leaks += o.outside_leaks;
  vertex_rays += o.vertex_rays;
  vertex_leaks += o.vertex_leaks;
  return *this;
}

LeakCounts count_leaks(const IndexedMesh& mesh, Kernel kernel, const LeakOptions& options) {
  const Prepared p = prepare(mesh);
  const uint64_t chunks = (options.rays + kChunk - 1) / kChunk;
  return tbb::parallel_reduce(
      tbb::blocked_range<uint64_t>(0, chunks), LeakCounts{},
      [&](const tbb::blocked_range<uint64_t>& range, LeakCounts counts) {
        std::vector<uint32_t> candidates;
        for (uint64_t chunk = range.begin(); chunk != range.end(); ++chunk) {
          std::seed_seq seq{options.seed, chunk};
          std::mt19937_64 rng(seq);
          const uint64_t end = std::min(options.rays, (chunk + 1) * kChunk);
          for (uint64_t i = chunk * kChunk; i < end; ++i) {
            const Aim aim = make_ray(mesh, p, rng);
            const bool leaked = with_kernel(
                kernel, [&]<Kernel K>() { return leaks<K>(p, aim, options, candidates); });
            counts.rays++;
            counts.leaks += leaked;
            (aim.inside ? counts.inside_rays : counts.outside_rays)++;
            (aim.inside ? counts.inside_leaks : counts.outside_leaks) += leaked;
            counts.vertex_rays += aim.vertex;
            counts.vertex_leaks += aim.vertex && leaked;
          }
        }
        return counts;
      },
      [](LeakCounts a, const LeakCounts& b) { return a += b; });
}

}  // namespace tritrace::leaks

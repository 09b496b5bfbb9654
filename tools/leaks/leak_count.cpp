// Aiming rays at a closed mesh's edges and vertices, and counting those that slip through the
// kernel alone or an accel built over the mesh.
#include "leaks/leak_count.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <glm/glm.hpp>
#include <memory>
#include <random>
#include <stdexcept>

#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace::leaks {
namespace {

// Rays are made, and handed to an accel, a chunk at a time; a multiple of kBundleSize.
constexpr uint64_t kChunk = 4096;
static_assert(kChunk % kBundleSize == 0);

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

// The outward normals of the faces at the target: those around a vertex, or the two sharing the
// edge a-b.
std::vector<glm::vec3> faces_at(const IndexedMesh& m, const Prepared& p, uint32_t a, uint32_t b) {
  std::vector<glm::vec3> normals;
  for (uint32_t t : p.ring[a]) {
    const auto& tri = m.triangles[t];
    if (std::find(tri.begin(), tri.end(), b) != tri.end()) normals.push_back(p.outward[t]);
  }
  return normals;
}

bool crosses(glm::vec3 w, const std::vector<glm::vec3>& normals) {
  for (glm::vec3 n : normals) {
    if (glm::dot(w, n) < 0.1f) return false;
  }
  return true;
}

// A direction from the target out to the origin: `mean` (of the normals) turned at random by up
// to about `spread` radians' worth, at least 5.7 degrees off every face; `mean` if 64 tries fail.
glm::vec3 outward_direction(glm::vec3 mean, float spread, const std::vector<glm::vec3>& normals,
                            std::mt19937_64& rng) {
  for (int attempt = 0; attempt < 64; ++attempt) {
    const glm::vec3 c = glm::normalize(mean + spread * random_unit(rng));
    if (crosses(c, normals)) return c;
  }
  return mean;
}

void aim_at(Aim& aim, glm::vec3 origin, glm::vec3 target) {
  aim.ray.origin = origin;
  aim.ray.dir = glm::normalize(target - origin);
  aim.t_target = glm::length(target - origin);
}

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
    const std::vector<glm::vec3> normals = faces_at(m, p, aim.a, aim.b);
    glm::vec3 mean(0.0f);
    for (glm::vec3 n : normals) mean += n;
    mean = glm::normalize(mean);
    origin = target + (2.0f * p.radius) * outward_direction(mean, 0.8f, normals, rng);
  }
  aim_at(aim, origin, target);
  return aim;
}

float distance_to_segment(glm::vec3 q, glm::vec3 a, glm::vec3 b) {
  const glm::vec3 ab = b - a;
  const float len2 = glm::dot(ab, ab);
  const float s = len2 > 0.0f ? std::clamp(glm::dot(q - a, ab) / len2, 0.0f, 1.0f) : 0.0f;
  return glm::length(q - (a + s * ab));
}

// kBundleSize coherent rays appended to `out`: one side, one target vertex or points spread evenly
// along a stretch of one edge, and origins close together. The stretch is at most a quarter of
// the edge and 0.2 of its distance d from the origin, and inside origins move by at most 0.1 d, so
// a bundle spans a few degrees to about 20 wherever it starts (inside, d may be small).
void make_bundle(const IndexedMesh& m, const Prepared& p, std::mt19937_64& rng,
                 std::vector<Aim>& out) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  Aim base;
  base.vertex = rng() & 1;
  if (base.vertex) {
    base.a = base.b = static_cast<uint32_t>(rng() % m.positions.size());
  } else {
    const EdgeUse& e = p.edges[rng() % p.edges.size()];
    base.a = e.a;
    base.b = e.b;
  }
  const glm::vec3 pa = m.positions[base.a], pb = m.positions[base.b];
  base.inside = rng() & 1;
  float f = 0.0f, d = 2.0f * p.radius;
  glm::vec3 base_origin(0.0f), base_dir(0.0f);
  std::vector<glm::vec3> normals;
  if (base.inside) {
    f = 0.9f * unit(rng);
    base_origin = p.centre + f * (m.positions[rng() % m.positions.size()] - p.centre);
    d = distance_to_segment(base_origin, pa, pb);
  } else {
    normals = faces_at(m, p, base.a, base.b);
    glm::vec3 mean(0.0f);
    for (glm::vec3 n : normals) mean += n;
    base_dir = outward_direction(glm::normalize(mean), 0.8f, normals, rng);
  }
  const float length = glm::length(pb - pa);
  const float span = base.vertex ? 0.0f : std::min(0.25f, 0.2f * d / length);
  const float s0 = base.vertex ? 0.0f : (1.0f - span) * unit(rng);
  for (int k = 0; k < kBundleSize; ++k) {
    Aim aim = base;
    const float s = s0 + span * ((static_cast<float>(k) + unit(rng)) / kBundleSize);
    const glm::vec3 target = base.vertex ? pa : pa + s * (pb - pa);
    glm::vec3 origin;
    if (base.inside) {
      // A convex combination of two inside points (each one of the centre and a vertex), so
      // inside.
      const glm::vec3 other = p.centre + f * (m.positions[rng() % m.positions.size()] - p.centre);
      const float apart = glm::length(other - base_origin);
      const float mix = apart > 0.0f ? std::min(0.05f, 0.1f * d / apart) : 0.0f;
      origin = base_origin + mix * (other - base_origin);
    } else {
      origin = target + (2.0f * p.radius) * outward_direction(base_dir, 0.05f, normals, rng);
    }
    aim_at(aim, origin, target);
    out.push_back(aim);
  }
}

// Each chunk of rays draws from its own generators (one for scattered rays, one for bundles),
// seeded by (seed, chunk), so that the rays do not depend on how chunks are spread over threads.
std::vector<Aim> make_aims(const IndexedMesh& m, const Prepared& p, bool bundles, uint64_t seed,
                           uint64_t chunk, uint64_t count) {
  std::vector<Aim> aims;
  aims.reserve(count + kBundleSize);
  if (bundles) {
    std::seed_seq seq{seed, chunk, uint64_t{1}};
    std::mt19937_64 rng(seq);
    while (aims.size() < count) make_bundle(m, p, rng, aims);
    aims.resize(count);
  } else {
    std::seed_seq seq{seed, chunk};
    std::mt19937_64 rng(seq);
    while (aims.size() < count) aims.push_back(make_ray(m, p, rng));
  }
  return aims;
}

template <Kernel K>
bool leaks(const Prepared& p, const Aim& aim, bool all_triangles,
           std::vector<uint32_t>& candidates) {
  candidates.clear();
  if (all_triangles) {
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

// The same rule for an accel's closest hit over the whole mesh. Through an instance the kernel
// sees the ray moved to world space and back, a few ulps of the world coordinates off the aimed
// ray, which at the shallowest angle the aim allows (dot 0.1 with a face) moves the entry point
// by up to about 1e-5 of t; the margin there is 1e-3, still far below the way through the mesh
// that a ray slipping in at the target travels to the far side.
bool leaks(const Aim& aim, const Hit& hit, float margin) {
  if (!hit.found()) return true;
  return !aim.inside && hit.t > aim.t_target * (1.0f + margin);
}

void tally(LeakCounts& counts, const Aim& aim, bool leaked) {
  counts.rays++;
  counts.leaks += leaked;
  (aim.inside ? counts.inside_rays : counts.outside_rays)++;
  (aim.inside ? counts.inside_leaks : counts.outside_leaks) += leaked;
  counts.vertex_rays += aim.vertex;
  counts.vertex_leaks += aim.vertex && leaked;
}

// Scratch space of one worker, reused from chunk to chunk.
struct Scratch {
  std::vector<uint32_t> candidates;
  std::vector<Ray> rays;
  std::vector<Hit> hits;
};

void run_chunk(const Prepared& p, const LeakRun& run, const Accel* accel, bool all_triangles,
               std::span<const Aim> aims, Scratch& scratch, LeakCounts& counts) {
  if (!accel) {
    with_kernel(run.kernel, [&]<Kernel K>() {
      for (const Aim& aim : aims) {
        tally(counts, aim, leaks<K>(p, aim, all_triangles, scratch.candidates));
      }
    });
    return;
  }
  scratch.rays.clear();
  for (const Aim& aim : aims) {
    Ray r = aim.ray;
    if (run.path.instance) {
      r.origin = run.path.instance->apply(r.origin);
      r.dir = run.path.instance->apply_vector(r.dir);
    }
    scratch.rays.push_back(r);
  }
  scratch.hits.assign(aims.size(), Hit{});
  const std::span<const Ray> rays(scratch.rays);
  const std::span<Hit> hits(scratch.hits);
  if (run.path.bundles) {
    for (size_t first = 0; first < rays.size(); first += kBundleSize) {
      const size_t n = std::min<size_t>(kBundleSize, rays.size() - first);
      accel->intersect(rays.subspan(first, n), hits.subspan(first, n));
    }
  } else {
    accel->intersect(rays, hits);
  }
  const float margin = run.path.instance ? 1e-3f : 1e-5f;
  for (size_t i = 0; i < aims.size(); ++i) {
    // Through an instance, an outside ray aimed at an edge point near a corner crosses only a
    // sliver of the mesh, and the rounding of the move can put it beside the corner: it then
    // misses the whole mesh. A ray slipping through the surface would hit the far side instead
    // (a leak by the margin rule), so these are counted apart.
    if (run.path.instance && !aims[i].inside && !hits[i].found()) {
      tally(counts, aims[i], false);
      ++counts.grazing_misses;
      continue;
    }
    tally(counts, aims[i], leaks(aims[i], hits[i], margin));
  }
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
  grazing_misses += o.grazing_misses;
  return *this;
}

std::string leak_path_name(const LeakPath& path) {
  std::string name = path.accel ? std::string(accel_name(*path.accel)) : "kernel";
  if (path.bundles) name += " bundles";
  return path.instance ? name + " instanced" : name;
}

std::vector<LeakPath> report_paths() {
  return {{},
          {AccelKind::kBrute},
          {AccelKind::kBvhSingle},
          {AccelKind::kBvh},
          {AccelKind::kBvh, /*bundles=*/true}};
}

std::vector<LeakCounts> count_leaks(const IndexedMesh& mesh, std::span<const LeakRun> runs,
                                    const LeakOptions& options) {
  const Prepared p = prepare(mesh);
  std::vector<uint64_t> rays(runs.size());
  std::vector<std::unique_ptr<Accel>> accels(runs.size());
  std::vector<std::unique_ptr<Scene>> scenes(runs.size());  // for instanced runs
  uint64_t scattered = 0, bundled = 0;
  for (size_t r = 0; r < runs.size(); ++r) {
    rays[r] = runs[r].rays ? runs[r].rays : options.rays;
    uint64_t& total = runs[r].path.bundles ? bundled : scattered;
    total = std::max(total, rays[r]);
    if (runs[r].path.accel && runs[r].path.instance) {
      scenes[r] = std::make_unique<Scene>();
      scenes[r]->prototypes.push_back(p.mesh);
      add_instance(*scenes[r], 0, *runs[r].path.instance);
      accels[r] = make_accel(*runs[r].path.accel, *scenes[r], runs[r].kernel);
    } else if (runs[r].path.accel) {
      accels[r] = make_accel(*runs[r].path.accel, p.mesh, runs[r].kernel);
    }
  }
  // How many of the chunk's rays are among the first `total`.
  auto in_chunk = [](uint64_t chunk, uint64_t total) {
    const uint64_t begin = chunk * kChunk;
    return begin >= total ? uint64_t{0} : std::min(kChunk, total - begin);
  };
  const uint64_t chunks = (std::max(scattered, bundled) + kChunk - 1) / kChunk;
  return tbb::parallel_reduce(
      tbb::blocked_range<uint64_t>(0, chunks), std::vector<LeakCounts>(runs.size()),
      [&](const tbb::blocked_range<uint64_t>& range, std::vector<LeakCounts> counts) {
        Scratch scratch;
        for (uint64_t chunk = range.begin(); chunk != range.end(); ++chunk) {
          const std::vector<Aim> scattered_aims =
              make_aims(mesh, p, false, options.seed, chunk, in_chunk(chunk, scattered));
          const std::vector<Aim> bundled_aims =
              make_aims(mesh, p, true, options.seed, chunk, in_chunk(chunk, bundled));
          for (size_t r = 0; r < runs.size(); ++r) {
            const std::span<const Aim> aims =
                std::span(runs[r].path.bundles ? bundled_aims : scattered_aims)
                    .first(in_chunk(chunk, rays[r]));
            run_chunk(p, runs[r], accels[r].get(), options.all_triangles, aims, scratch, counts[r]);
          }
        }
        return counts;
      },
      [](std::vector<LeakCounts> a, const std::vector<LeakCounts>& b) {
        for (size_t r = 0; r < a.size(); ++r) a[r] += b[r];
        return a;
      });
}

LeakCounts count_leaks(const IndexedMesh& mesh, const LeakPath& path, Kernel kernel,
                       const LeakOptions& options) {
  const LeakRun run{path, kernel, options.rays};
  return count_leaks(mesh, std::span(&run, 1), options).front();
}

LeakCounts count_leaks(const IndexedMesh& mesh, Kernel kernel, const LeakOptions& options) {
  return count_leaks(mesh, LeakPath{}, kernel, options);
}

std::vector<Ray> aimed_rays(const IndexedMesh& mesh, bool bundles, uint64_t count, uint64_t seed) {
  const Prepared p = prepare(mesh);
  std::vector<Ray> rays;
  for (uint64_t chunk = 0; chunk * kChunk < count; ++chunk) {
    const uint64_t n = std::min(kChunk, count - chunk * kChunk);
    for (const Aim& aim : make_aims(mesh, p, bundles, seed, chunk, n)) rays.push_back(aim.ray);
  }
  return rays;
}

}  // namespace tritrace::leaks

// The lab shading, batched: all primary hits of a tile first, then one shadow batch per light.
#include "tritrace/render/lab_integrator.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cstddef>
#include <glm/glm.hpp>
#include <glm/gtc/constants.hpp>

#include "tritrace/math/simd_lanes.h"

namespace tritrace {
namespace {

// The batch's hits and shadow rays, kept per thread: Hit and Ray initialise their members, and
// doing that for 256 of each on every tile cost more than a tenth of a Cornell box frame.
struct Scratch {
  std::array<Hit, kMaxBatch> hits;
  std::array<ShadowRay, kMaxBatch> shadows;
  std::array<Ray, kMaxBatch> shadow_rays;
};

Scratch& thread_scratch() {
  thread_local Scratch scratch;
  return scratch;
}

}  // namespace

ShadowRay lab_shadow_ray(const TriangleMesh& mesh, const Hit& hit, glm::vec3 light,
                         const RayOffsetParams& offset) {
  return lab_shadow_ray(stored_triangle(mesh, hit.prim), hit, light, offset);
}

ShadowRay lab_shadow_ray(const SurfaceTriangle& tri, const Hit& hit, glm::vec3 light,
                         const RayOffsetParams& offset) {
  ShadowRay s;
  const glm::vec3 e1 = tri.e1, e2 = tri.e2;
  // From the barycentrics rather than origin + t * dir: the error is then relative to the
  // triangle's own coordinates, not to the distance the primary ray travelled.
  const glm::vec3 x = tri.v0 + hit.u * e1 + hit.v * e2;
  const glm::vec3 r = light - x;
  s.dist2 = glm::dot(r, r);
  const float dist = std::sqrt(s.dist2);
  const glm::vec3 dir = r / dist;
  const glm::vec3 normal = tri.normal;
  s.cos_theta = glm::dot(dir, normal);
  // Facing away (or the hit sits on the light): no direct light, no shadow ray needed.
  if (!(s.cos_theta > 0.0f) || !(dist > 0.0f)) return s;
  // cos_theta > 0: the light is on the side the normal points to. A hit on an edge where two walls
  // meet lies on the other wall's plane too, and moving it along its own normal keeps it there (at
  // a right angle): the shadow ray would start on that wall and, with rounding, slip through it.
  // So the point first moves the same way towards its triangle's centroid, off every edge's
  // neighbour, then off its own surface.
  const float extent = triangle_extent(e1, e2);
  const glm::vec3 inward = tri.v0 + (e1 + e2) / 3.0f - x;
  const float inward_length = std::sqrt(glm::dot(inward, inward));
  const glm::vec3 inside =
      inward_length > 0.0f ? offset_ray_origin(x, inward / inward_length, extent, offset) : x;
  const glm::vec3 start = offset_ray_origin(inside, normal, extent, offset);
  const glm::vec3 end = offset_ray_origin(light, -dir, extent, offset);
  const glm::vec3 segment = end - start;
  const float length = std::sqrt(glm::dot(segment, segment));
  if (!(length > 0.0f) || !(glm::dot(segment, r) > 0.0f)) {
    s.kind = ShadowRay::Kind::kLit;
    return s;
  }
  s.kind = ShadowRay::Kind::kTrace;
  s.ray.origin = start;
  s.ray.dir = segment / length;
  s.ray.tmin = 0.0f;
  s.ray.tmax = length;
  return s;
}

#if TRITRACE_SIMD_LANES > 0
namespace {

using simd::VF;
using simd::VI;
using simd::VM;

// Three lanes-wide coordinates: kLanes points or vectors.
struct V3 {
  VF x, y, z;
};
V3 operator+(V3 a, V3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
V3 operator-(V3 a, V3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V3 operator-(V3 a) {
  return {-a.x, -a.y, -a.z};
}
V3 operator*(VF s, V3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
V3 operator/(V3 a, VF s) {
  return {a.x / s, a.y / s, a.z / s};
}
// glm::dot's order: (x + y) + z.
VF dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
V3 splat3(glm::vec3 p) {
  return {simd::splat(p.x), simd::splat(p.y), simd::splat(p.z)};
}
V3 select(VM m, V3 a, V3 b) {
  return {simd::select(m, a.x, b.x), simd::select(m, a.y, b.y), simd::select(m, a.z, b.z)};
}
// Lane l reads points[prim[l]], with first[l] = 3 * prim[l] (the float index of its x).
V3 gather3(const HugePageVector<glm::vec3>& points, VI first) {
  static_assert(sizeof(glm::vec3) == 3 * sizeof(float));
  const float* base = &points[0].x;
  return {simd::gather(base, first), simd::gather(base + 1, first), simd::gather(base + 2, first)};
}

// offset_ray_origin, lane by lane (see math/offset_ray.h for the reasoning).
VF shift(VF pc, VF nc, VF extent, const RayOffsetParams& k) {
  const VI ulps = simd::truncate_to_int(simd::splat(k.int_scale) * nc);
  const VI bits = simd::bits_of(pc);
  const VF by_ulps =
      simd::float_from_bits(simd::select(pc < simd::splat(0.0f), bits - ulps, bits + ulps));
  const VF by_extent = pc + simd::splat(k.float_scale) * extent * nc;
  // vmax(a, b) is a > b ? a : b, so vmax(by_ulps, by_extent) is std::max(by_extent, by_ulps),
  // NaN and signed zeros included; the same for vmin and std::min.
  return simd::select(nc > simd::splat(0.0f), simd::vmax(by_ulps, by_extent),
                      simd::vmin(by_ulps, by_extent));
}
V3 offset_origin(V3 p, V3 n, VF extent, const RayOffsetParams& k) {
  return {shift(p.x, n.x, extent, k), shift(p.y, n.y, extent, k), shift(p.z, n.z, extent, k)};
}

// Up to kLanes hits (count of them) into out[0, count).
void shadow_lanes(const TriangleMesh& mesh, const Hit* hits, int count, glm::vec3 light_position,
                  const RayOffsetParams& offset, ShadowRay* out) {
  constexpr int W = simd::kLanes;
  // Neighbouring pixels mostly hit the same triangle: then its data is loaded once and broadcast,
  // which costs far less than four gathers of three coordinates each.
  int first_found = -1;
  bool same = true;
  for (int l = 0; l < count; ++l) {
    if (!hits[l].found()) continue;
    if (first_found < 0) first_found = l;
    same &= hits[l].prim == hits[first_found].prim;
  }
  if (first_found < 0) {  // every ray missed
    std::fill_n(out, count, ShadowRay{});
    return;
  }
  // The hits' fields gathered (a Hit is 4 floats: t, u, v, prim) straight from where the traversal
  // wrote them; lanes past the batch read nothing and hold zeros.
  static_assert(sizeof(Hit) == 4 * sizeof(float) && offsetof(Hit, u) == sizeof(float) &&
                offsetof(Hit, v) == 2 * sizeof(float) && offsetof(Hit, prim) == 3 * sizeof(float));
  const float* hit_floats = reinterpret_cast<const float*>(hits);
  const VI field = simd::iota_i() + simd::iota_i() + simd::iota_i() + simd::iota_i();
  const VM in_batch = simd::first_lanes(count);
  const VF u = simd::gather(hit_floats + 1, field, in_batch),
           v = simd::gather(hit_floats + 2, field, in_batch);
  V3 v0, e1, e2, normal;
  if (same) {
    const size_t p = hits[first_found].prim;
    v0 = splat3(mesh.v0()[p]);
    e1 = splat3(mesh.e1(p));
    e2 = splat3(mesh.e2(p));
    normal = splat3(mesh.normal()[p]);
  } else {
    // A missed ray's lane reads triangle 0; its results are never used.
    const VI prim = simd::bits_of(simd::gather(hit_floats + 3, field, in_batch));
    const VI valid = simd::select(prim == simd::splat_i(-1), simd::splat_i(0), prim);
    const VI first = valid + valid + valid;
    v0 = gather3(mesh.v0(), first);
    e1 = gather3(mesh.v1(), first) - v0;  // the stored edges' operations, lane by lane
    e2 = gather3(mesh.v2(), first) - v0;
    normal = gather3(mesh.normal(), first);
  }
  static_assert(kNoHit == static_cast<uint32_t>(-1));
  const V3 light = splat3(light_position);
  const VF zero = simd::splat(0.0f);

  const V3 x = v0 + u * e1 + v * e2;
  const V3 r = light - x;
  const VF dist2 = dot(r, r);
  const VF dist = simd::sqrt(dist2);
  const V3 dir = r / dist;
  const VF cos_theta = dot(dir, normal);
  const VM behind = simd::not_greater(cos_theta, zero) | simd::not_greater(dist, zero);

  const V3 a = {simd::vmax(simd::abs(e1.x), simd::abs(e2.x)),
                simd::vmax(simd::abs(e1.y), simd::abs(e2.y)),
                simd::vmax(simd::abs(e1.z), simd::abs(e2.z))};
  const VF extent = simd::vmax(simd::vmax(a.x, a.y), a.z);
  const V3 inward = v0 + (e1 + e2) / simd::splat(3.0f) - x;
  const VF inward_length = simd::sqrt(dot(inward, inward));
  const V3 inside =
      select(inward_length > zero, offset_origin(x, inward / inward_length, extent, offset), x);
  const V3 start = offset_origin(inside, normal, extent, offset);
  const V3 end = offset_origin(light, -dir, extent, offset);
  const V3 segment = end - start;
  const VF length = simd::sqrt(dot(segment, segment));
  const VM lit = simd::not_greater(length, zero) | simd::not_greater(dot(segment, r), zero);
  const V3 ray_dir = segment / length;

  alignas(64) float lanes[9][W];
  const VF fields[9] = {dist2,     cos_theta, start.x,   start.y, start.z,
                        ray_dir.x, ray_dir.y, ray_dir.z, length};
  for (int f = 0; f < 9; ++f) simd::store(lanes[f], fields[f]);
  const uint32_t behind_bits = simd::bits(behind), lit_bits = simd::bits(lit);
  for (int l = 0; l < count; ++l) {
    ShadowRay& s = out[l];
    s = ShadowRay{};
    if (!hits[l].found()) continue;
    s.dist2 = lanes[0][l];
    s.cos_theta = lanes[1][l];
    if (behind_bits >> l & 1) continue;
    if (lit_bits >> l & 1) {
      s.kind = ShadowRay::Kind::kLit;
      continue;
    }
    s.kind = ShadowRay::Kind::kTrace;
    s.ray.origin = {lanes[2][l], lanes[3][l], lanes[4][l]};
    s.ray.dir = {lanes[5][l], lanes[6][l], lanes[7][l]};
    s.ray.tmin = 0.0f;
    s.ray.tmax = lanes[8][l];
  }
}

}  // namespace
#endif

void lab_shadow_rays(const TriangleMesh& mesh, std::span<const Hit> hits, glm::vec3 light,
                     const RayOffsetParams& offset, std::span<ShadowRay> out) {
  assert(out.size() == hits.size());
  size_t i = 0;
#if TRITRACE_SIMD_LANES > 0
  // The gathers index floats with 32-bit integers: 3 * prim must fit.
  if (mesh.size() <= static_cast<size_t>(INT32_MAX / 3)) {
    for (; i < hits.size(); i += simd::kLanes) {
      const int count = static_cast<int>(std::min<size_t>(simd::kLanes, hits.size() - i));
      shadow_lanes(mesh, hits.data() + i, count, light, offset, out.data() + i);
    }
  }
#endif
  for (; i < hits.size(); ++i) {
    out[i] = hits[i].found() ? lab_shadow_ray(mesh, hits[i], light, offset) : ShadowRay{};
  }
}

std::string lab_unsupported(const Scene& scene) {
  if (scene.spot_lights.empty() && scene.directional_lights.empty()) return {};
  return "the lab integrator shades point lights only (the lab's model); this scene has spot or "
         "directional lights: render it with --integrator path";
}

uint64_t LabIntegrator::radiance(const SampleBatch& batch, const SampleOutput& out,
                                 const Scene& scene, const Accel& accel) const {
  const std::span<const Ray> rays = batch.rays;
  const std::span<glm::vec3> radiance = out.radiance;
  assert(rays.size() <= kMaxBatch && radiance.size() == rays.size());
  const size_t n = rays.size();
  Scratch& scratch = thread_scratch();
  std::array<Hit, kMaxBatch>& hits = scratch.hits;
  accel.intersect(rays, std::span(hits).first(n));

  std::array<glm::vec3, kMaxBatch> direct;
  std::fill_n(direct.begin(), n, glm::vec3(0.0f));
  std::array<Ray, kMaxBatch>& shadow_rays = scratch.shadow_rays;
  std::array<float, kMaxBatch> shadow_weight;  // max(n.r, 0) / (4 pi |r|^2)
  std::array<uint32_t, kMaxBatch> shadow_owner;
  std::array<uint8_t, kMaxBatch> blocked;
  uint64_t traced = n;

  std::span<ShadowRay> shadows = std::span(scratch.shadows).first(n);
  for (const PointLight& light : scene.lights) {
    if (scene.has_instances()) {
      // An instanced hit's triangle is made in world space per hit (Scene::triangle), which the
      // SIMD lanes' gathers from the mesh's arrays cannot do; the scalar function gives the same
      // bits (lab_shadow_rays).
      for (size_t i = 0; i < n; ++i) {
        shadows[i] = hits[i].found() ? lab_shadow_ray(scene.triangle(hits[i].prim), hits[i],
                                                      light.position, offset_)
                                     : ShadowRay{};
      }
    } else {
      lab_shadow_rays(scene.mesh, std::span<const Hit>(hits.data(), n), light.position, offset_,
                      shadows);
    }
    size_t m = 0;
    for (size_t i = 0; i < n; ++i) {
      const ShadowRay& shadow = shadows[i];
      if (shadow.kind == ShadowRay::Kind::kBehind) continue;
      const float weight = shadow.cos_theta / (4.0f * glm::pi<float>() * shadow.dist2);
      if (shadow.kind == ShadowRay::Kind::kLit) {
        direct[i] += light.power * weight;
        continue;
      }
      shadow_rays[m] = shadow.ray;
      shadow_weight[m] = weight;
      shadow_owner[m] = static_cast<uint32_t>(i);
      ++m;
    }
    accel.occluded(std::span<const Ray>(shadow_rays.data(), m), std::span(blocked).first(m));
    traced += m;
    for (size_t j = 0; j < m; ++j) {
      if (!blocked[j]) direct[shadow_owner[j]] += light.power * shadow_weight[j];
    }
  }

  for (size_t i = 0; i < n; ++i) {
    if (!hits[i].found()) {
      radiance[i] = glm::vec3(0.0f);
      continue;
    }
    const glm::vec3& albedo = scene.materials[scene.material_of(hits[i].prim)].albedo;
    radiance[i] = albedo * (direct[i] + scene.ambient);
  }
  write_first_hit_aovs(scene, rays, std::span<const Hit>(hits.data(), n), out);
  return traced;
}

}  // namespace tritrace

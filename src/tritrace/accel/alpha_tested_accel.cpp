// Alpha-tested traversal as a decorator: the structures and kernels stay untouched, and a hit on a
// cut-out is skipped by tracing the ray again over the rest of its interval.
#include "tritrace/accel/alpha_tested_accel.h"

#include "tritrace/math/random.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace tritrace {
namespace {

// Rays traced again at a time: arrays on the stack, so that tracing allocates nothing.
constexpr size_t kChunk = 64;

float next_above(float t) {
  return std::nextafter(t, std::numeric_limits<float>::infinity());
}

}  // namespace

float blend_threshold(const Ray& ray, uint32_t prim) {
  constexpr uint64_t kGolden = 0x9e3779b97f4a7c15ull;
  uint64_t h = mix64(uint64_t{prim} + kGolden);
  for (const float f :
       {ray.origin.x, ray.origin.y, ray.origin.z, ray.dir.x, ray.dir.y, ray.dir.z}) {
    h = mix64(h ^ (uint64_t{std::bit_cast<uint32_t>(f)} + kGolden));
  }
  return static_cast<float>(h >> 40) * 0x1p-24f;  // 24 bits: exactly representable, below 1
}

AlphaTestedAccel::AlphaTestedAccel(const Scene& scene, std::unique_ptr<Accel> inner)
    : scene_(scene), inner_(std::move(inner)), tested_(scene.materials.size()) {
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    tested_[m] = alpha_tested(scene, scene.materials[m]) ? 1 : 0;
  }
}

bool AlphaTestedAccel::transparent(const Ray& ray, const Hit& hit) const {
  if (!hit.found()) return false;
  const uint32_t id = scene_.material_of(hit.prim);
  if (id >= tested_.size() || !tested_[id]) return false;
  const Material& m = scene_.materials[id];
  const float alpha = material_alpha(scene_, m, hit.prim, hit.u, hit.v);
  if (m.alpha_mode == AlphaMode::kMask) return alpha < m.alpha_cutoff;
  return alpha <= blend_threshold(ray, hit.prim);
}

void AlphaTestedAccel::skip_transparent(std::span<const Ray> rays, std::span<Hit> hits) const {
  // Most batches have no transparent hit: they leave before the arrays below are set up.
  size_t next = 0;
  while (next < rays.size() && !transparent(rays[next], hits[next])) ++next;
  if (next == rays.size()) return;
  Ray again[kChunk];
  Hit found[kChunk];
  uint32_t which[kChunk];
  while (next < rays.size()) {
    // Gather up to kChunk rays whose hit is transparent, then trace them until none is.
    size_t n = 0;
    for (; next < rays.size() && n < kChunk; ++next) {
      if (transparent(rays[next], hits[next])) which[n++] = static_cast<uint32_t>(next);
    }
    while (n > 0) {
      for (size_t k = 0; k < n; ++k) {
        again[k] = rays[which[k]];
        again[k].tmin = next_above(hits[which[k]].t);
      }
      inner_->intersect_incoherent(std::span<const Ray>(again, n), std::span<Hit>(found, n));
      size_t kept = 0;
      for (size_t k = 0; k < n; ++k) {
        const uint32_t i = which[k];
        // A ray whose interval closed (tmin above tmax) cannot be traced again: it missed.
        hits[i] = again[k].tmin <= again[k].tmax ? found[k] : Hit{};
        if (transparent(rays[i], hits[i])) which[kept++] = i;
      }
      n = kept;
    }
  }
}

void AlphaTestedAccel::resolve_occluded(std::span<const Ray> rays,
                                        std::span<uint8_t> occluded) const {
  // The rays that something blocks: whether that is only transparent surfaces decides the closest
  // hit, skipped past while transparent.
  size_t next = 0;
  while (next < rays.size() && !occluded[next]) ++next;
  if (next == rays.size()) return;
  Ray blocked[kChunk];
  Hit hits[kChunk];
  uint32_t which[kChunk];
  while (next < rays.size()) {
    size_t n = 0;
    for (; next < rays.size() && n < kChunk; ++next) {
      if (occluded[next]) {
        blocked[n] = rays[next];
        which[n++] = static_cast<uint32_t>(next);
      }
    }
    if (n == 0) continue;
    inner_->intersect_incoherent(std::span<const Ray>(blocked, n), std::span<Hit>(hits, n));
    skip_transparent(std::span<const Ray>(blocked, n), std::span<Hit>(hits, n));
    for (size_t k = 0; k < n; ++k) occluded[which[k]] = hits[k].found() ? 1 : 0;
  }
}

void AlphaTestedAccel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  inner_->intersect(rays, hits);
  skip_transparent(rays, hits);
}

void AlphaTestedAccel::intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const {
  inner_->intersect_incoherent(rays, hits);
  skip_transparent(rays, hits);
}

void AlphaTestedAccel::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  inner_->occluded(rays, occluded);
  resolve_occluded(rays, occluded);
}

void AlphaTestedAccel::occluded_incoherent(std::span<const Ray> rays,
                                           std::span<uint8_t> occluded) const {
  inner_->occluded_incoherent(rays, occluded);
  resolve_occluded(rays, occluded);
}

}  // namespace tritrace

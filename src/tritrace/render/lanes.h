// Eight floats per operation (GCC's vector extensions, one lane per path or subpath): the scalar
// operations that the path tracer's and bdpt's diffuse vertices share. The build does not contract
// multiply-adds (-ffp-contract=off) and every operation here is the scalar code's, in its order,
// so each lane is bit for bit what the scalar code computes; only branches become masks. Only
// where the build has AVX2 (TRITRACE_LANES).
#pragma once

#if defined(__AVX2__)
#define TRITRACE_LANES 1
#include <immintrin.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "tritrace/math/offset_ray.h"
#include "tritrace/math/sampling.h"
#include "tritrace/math/simd_lanes.h"

namespace tritrace::lanes {

inline constexpr size_t kWidth = 8;
using F = float __attribute__((vector_size(32)));
using I = int32_t __attribute__((vector_size(32)));
using U = uint32_t __attribute__((vector_size(32)));

struct V3 {
  F x, y, z;
};

inline F splat(float v) {
  return F{} + v;
}
inline F sqrt(F v) {
  return reinterpret_cast<F>(_mm256_sqrt_ps(reinterpret_cast<__m256>(v)));
}
inline F select(I mask, F a, F b) {
  return mask ? a : b;
}
inline V3 select(I mask, const V3& a, const V3& b) {
  return {mask ? a.x : b.x, mask ? a.y : b.y, mask ? a.z : b.z};
}
inline V3 operator+(const V3& a, const V3& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline V3 operator-(const V3& a, const V3& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline V3 operator-(const V3& a) {
  return {-a.x, -a.y, -a.z};
}
inline V3 operator*(const V3& a, const V3& b) {
  return {a.x * b.x, a.y * b.y, a.z * b.z};
}
inline V3 operator*(const V3& a, F s) {
  return {a.x * s, a.y * s, a.z * s};
}
inline V3 operator*(F s, const V3& a) {
  return {s * a.x, s * a.y, s * a.z};
}
// glm::dot's order: (x + y) + z.
inline F dot(const V3& a, const V3& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
// std::max({x, y, z}) (std::max_element: a later value wins only when strictly greater).
inline F max_component(const V3& c) {
  F m = c.x;
  m = m < c.y ? c.y : m;
  return m < c.z ? c.z : m;
}
// std::max(a, b) and std::min(a, b): b only when strictly beyond a.
inline F max(F a, F b) {
  return a < b ? b : a;
}
inline F min(F a, F b) {
  return b < a ? b : a;
}
inline F abs(F v) {
  return reinterpret_cast<F>(reinterpret_cast<U>(v) & 0x7fffffffu);
}

// offset_ray_origin_scalar, per lane.
inline V3 offset_ray_origin(const V3& p, const V3& n, F extent, const RayOffsetParams& k) {
  const auto shift = [&](F pc, F nc) {
    const I ulps = __builtin_convertvector(k.int_scale * nc, I);
    const U bits = reinterpret_cast<U>(pc);
    const F by_ulps = reinterpret_cast<F>(bits + reinterpret_cast<U>(pc < 0.0f ? -ulps : ulps));
    const F by_extent = pc + k.float_scale * extent * nc;
    return nc > 0.0f ? max(by_extent, by_ulps) : min(by_extent, by_ulps);
  };
  return {shift(p.x, n.x), shift(p.y, n.y), shift(p.z, n.z)};
}

// triangle_extent.
inline F triangle_extent(const V3& e1, const V3& e2) {
  const V3 a{max(abs(e1.x), abs(e2.x)), max(abs(e1.y), abs(e2.y)), max(abs(e1.z), abs(e2.z))};
  return max_component(a);
}

// leave_surface (surface_offset.h) for a triangle with vertex v0 and edges e1, e2.
inline V3 leave_surface(const V3& v0, const V3& e1, const V3& e2, F extent, const V3& x,
                        const V3& n, const RayOffsetParams& offset) {
  const V3 sum = e1 + e2;
  const V3 inward = v0 + V3{sum.x / 3.0f, sum.y / 3.0f, sum.z / 3.0f} - x;
  const F inward_length = sqrt(dot(inward, inward));
  const I inside_exists = inward_length > 0.0f;
  const auto keep = [](F d, F nc) { return d * nc < 0.0f ? F{} : d; };
  const V3 step = select(inside_exists, inward * (1.0f / inward_length), V3{});
  const V3 inside =
      select(inside_exists,
             offset_ray_origin(x, V3{keep(step.x, n.x), keep(step.y, n.y), keep(step.z, n.z)},
                               extent, offset),
             x);
  return offset_ray_origin(inside, n, extent, offset);
}

inline F load(const float* p) {
  F v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline V3 load3(const float (&p)[3][kWidth]) {
  return {load(p[0]), load(p[1]), load(p[2])};
}
inline I load_mask(const int32_t* p) {
  I v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

inline void store(float* p, F v) {
  std::memcpy(p, &v, sizeof v);
}
inline void store3(float (&p)[3][kWidth], const V3& v) {
  store(p[0], v.x);
  store(p[1], v.y);
  store(p[2], v.z);
}
inline void store_mask(int32_t* p, I v) {
  std::memcpy(p, &v, sizeof v);
}

// The eight floats at byte `offset` of each of eight objects, transposed: out[c] holds in lane l
// float c of objects[l]'s eight. The AVX 8 x 8 transpose, 8 loads and 24 shuffles, where
// gathering the same 64 numbers lane by lane takes 64 loads and 56 inserts. Moves only: each lane
// has the bits stored there (floats the caller does not use may be any bytes of the object).
inline void transpose8(const void* const* objects, size_t offset, F out[kWidth]) {
  const float* rows[8];
  for (size_t i = 0; i < 8; ++i) {
    rows[i] = reinterpret_cast<const float*>(static_cast<const char*>(objects[i]) + offset);
  }
  __m256 columns[8];
  simd::transpose_8x8(rows, columns);
  for (size_t c = 0; c < 8; ++c) out[c] = reinterpret_cast<F>(columns[c]);
}
inline V3 v3(const F* columns) {
  return {columns[0], columns[1], columns[2]};
}

// sample_cosine_hemisphere (math/sampling.h) in lanes, from its two uniforms mapped to [-1, 1)
// (a = 2 u.x - 1, b = 2 u.y - 1): the concentric disk point (x, y), lifted to z, and the density
// z / pi. sincosf runs lane by lane so every lane has the scalar code's bits.
struct CosineSample {
  F x, y, z, pdf;
};
inline CosineSample cosine_hemisphere(F a, F b) {
  const I centre = (a == 0.0f) & (b == 0.0f);
  const I wide = abs(a) > abs(b);
  const F radius = wide ? a : b;
  const F phi = wide ? 0.25f * kPi * (b / a) : 0.5f * kPi - 0.25f * kPi * (a / b);
  F cos_phi, sin_phi;
  for (size_t l = 0; l < kWidth; ++l) {
    float s_l, c_l;
    ::sincosf(phi[l], &s_l, &c_l);
    sin_phi[l] = s_l;
    cos_phi[l] = c_l;
  }
  CosineSample out;
  out.x = centre ? F{} : radius * cos_phi;
  out.y = centre ? F{} : radius * sin_phi;
  out.z = sqrt(max(F{}, 1.0f - out.x * out.x - out.y * out.y));
  out.pdf = out.z > 0.0f ? out.z * kInvPi : F{};
  return out;
}

}  // namespace tritrace::lanes
#endif

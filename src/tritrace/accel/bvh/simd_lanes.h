// A thin wrapper over the widest float SIMD this build targets (AVX-512: 16 lanes, AVX2: 8), so the
// packet traversal is written once. min/max keep the intrinsics' NaN rule (a NaN in the first
// operand returns the second), which the box tests rely on. kLanes is 0 without AVX2.
#pragma once

#include <cstdint>

#if defined(__AVX512F__) || defined(__AVX2__)
#include <immintrin.h>
#endif

namespace tritrace::bvh::simd {

#if defined(__AVX512F__)
inline constexpr int kLanes = 16;
struct VF {
  __m512 v;
};
struct VI {
  __m512i v;
};
struct VM {
  __mmask16 m;
};
inline VF splat(float x) {
  return {_mm512_set1_ps(x)};
}
inline VF load(const float* p) {
  return {_mm512_loadu_ps(p)};
}
inline void store(float* p, VF a) {
  _mm512_storeu_ps(p, a.v);
}
inline VF operator+(VF a, VF b) {
  return {_mm512_add_ps(a.v, b.v)};
}
inline VF operator-(VF a, VF b) {
  return {_mm512_sub_ps(a.v, b.v)};
}
inline VF operator*(VF a, VF b) {
  return {_mm512_mul_ps(a.v, b.v)};
}
inline VF operator/(VF a, VF b) {
  return {_mm512_div_ps(a.v, b.v)};
}
inline VF vmin(VF a, VF b) {
  return {_mm512_min_ps(a.v, b.v)};
}
inline VF vmax(VF a, VF b) {
  return {_mm512_max_ps(a.v, b.v)};
}
inline VM operator<=(VF a, VF b) {
  return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_LE_OQ)};
}
inline VM operator>=(VF a, VF b) {
  return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_GE_OQ)};
}
inline VM operator<(VF a, VF b) {
  return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_LT_OQ)};
}
inline VM operator==(VF a, VF b) {
  return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_EQ_OQ)};
}
inline VM not_equal(VF a, VF b) {
  return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_NEQ_UQ)};
}
inline VM signbit(VF a) {
  return {_mm512_movepi32_mask(_mm512_castps_si512(a.v))};
}
inline VM operator&(VM a, VM b) {
  return {static_cast<__mmask16>(a.m & b.m)};
}
inline VM operator|(VM a, VM b) {
  return {static_cast<__mmask16>(a.m | b.m)};
}
inline VM andnot(VM a, VM b) {
  return {static_cast<__mmask16>(~a.m & b.m)};
}  // !a & b
inline uint32_t bits(VM a) {
  return a.m;
}
inline VF select(VM m, VF if_true, VF if_false) {
  return {_mm512_mask_blend_ps(m.m, if_false.v, if_true.v)};
}
inline VI splat_i(int32_t x) {
  return {_mm512_set1_epi32(x)};
}
inline VM operator>(VI a, VI b) {
  return {_mm512_cmpgt_epi32_mask(a.v, b.v)};
}
inline VI select(VM m, VI if_true, VI if_false) {
  return {_mm512_mask_blend_epi32(m.m, if_false.v, if_true.v)};
}
inline void store(int32_t* p, VI a) {
  _mm512_storeu_si512(p, a.v);
}
// Written out rather than _mm512_reduce_min_ps, which trips GCC 12's -Wmaybe-uninitialized.
// Lane l reads base[8 * l] for l < count (eight floats apart: one Ray), else holds `fallback`.
inline VF load_every_8th(const float* base, int count, float fallback) {
  const __m512i index =
      _mm512_setr_epi32(0, 8, 16, 24, 32, 40, 48, 56, 64, 72, 80, 88, 96, 104, 112, 120);
  const __mmask16 lanes = count >= 16 ? 0xFFFF : static_cast<__mmask16>((1u << count) - 1);
  return {_mm512_mask_i32gather_ps(_mm512_set1_ps(fallback), lanes, index, base, 4)};
}
inline VM first_lanes(int count) {
  return {count >= 16 ? static_cast<__mmask16>(0xFFFF) : static_cast<__mmask16>((1u << count) - 1)};
}
inline float hmin(VF a) {
  __m512 m = _mm512_min_ps(a.v, _mm512_shuffle_f32x4(a.v, a.v, 0x4E));  // swap 256-bit halves
  m = _mm512_min_ps(m, _mm512_shuffle_f32x4(m, m, 0xB1));               // swap 128-bit quarters
  __m128 q = _mm512_castps512_ps128(m);
  q = _mm_min_ps(q, _mm_movehl_ps(q, q));
  q = _mm_min_ss(q, _mm_shuffle_ps(q, q, 1));
  return _mm_cvtss_f32(q);
}
inline float hmax(VF a) {
  __m512 m = _mm512_max_ps(a.v, _mm512_shuffle_f32x4(a.v, a.v, 0x4E));
  m = _mm512_max_ps(m, _mm512_shuffle_f32x4(m, m, 0xB1));
  __m128 q = _mm512_castps512_ps128(m);
  q = _mm_max_ps(q, _mm_movehl_ps(q, q));
  q = _mm_max_ss(q, _mm_shuffle_ps(q, q, 1));
  return _mm_cvtss_f32(q);
}
#elif defined(__AVX2__)
inline constexpr int kLanes = 8;
struct VF {
  __m256 v;
};
struct VI {
  __m256i v;
};
struct VM {
  __m256 m;
};
inline VF splat(float x) {
  return {_mm256_set1_ps(x)};
}
inline VF load(const float* p) {
  return {_mm256_loadu_ps(p)};
}
inline void store(float* p, VF a) {
  _mm256_storeu_ps(p, a.v);
}
inline VF operator+(VF a, VF b) {
  return {_mm256_add_ps(a.v, b.v)};
}
inline VF operator-(VF a, VF b) {
  return {_mm256_sub_ps(a.v, b.v)};
}
inline VF operator*(VF a, VF b) {
  return {_mm256_mul_ps(a.v, b.v)};
}
inline VF operator/(VF a, VF b) {
  return {_mm256_div_ps(a.v, b.v)};
}
inline VF vmin(VF a, VF b) {
  return {_mm256_min_ps(a.v, b.v)};
}
inline VF vmax(VF a, VF b) {
  return {_mm256_max_ps(a.v, b.v)};
}
inline VM operator<=(VF a, VF b) {
  return {_mm256_cmp_ps(a.v, b.v, _CMP_LE_OQ)};
}
inline VM operator>=(VF a, VF b) {
  return {_mm256_cmp_ps(a.v, b.v, _CMP_GE_OQ)};
}
inline VM operator<(VF a, VF b) {
  return {_mm256_cmp_ps(a.v, b.v, _CMP_LT_OQ)};
}
inline VM operator==(VF a, VF b) {
  return {_mm256_cmp_ps(a.v, b.v, _CMP_EQ_OQ)};
}
inline VM not_equal(VF a, VF b) {
  return {_mm256_cmp_ps(a.v, b.v, _CMP_NEQ_UQ)};
}
inline VM signbit(VF a) {
  return {_mm256_castsi256_ps(_mm256_srai_epi32(_mm256_castps_si256(a.v), 31))};
}
inline VM operator&(VM a, VM b) {
  return {_mm256_and_ps(a.m, b.m)};
}
inline VM operator|(VM a, VM b) {
  return {_mm256_or_ps(a.m, b.m)};
}
inline VM andnot(VM a, VM b) {
  return {_mm256_andnot_ps(a.m, b.m)};
}  // !a & b
inline uint32_t bits(VM a) {
  return static_cast<uint32_t>(_mm256_movemask_ps(a.m));
}
inline VF select(VM m, VF if_true, VF if_false) {
  return {_mm256_blendv_ps(if_false.v, if_true.v, m.m)};
}
inline VI splat_i(int32_t x) {
  return {_mm256_set1_epi32(x)};
}
inline VM operator>(VI a, VI b) {
  return {_mm256_castsi256_ps(_mm256_cmpgt_epi32(a.v, b.v))};
}
inline VI select(VM m, VI if_true, VI if_false) {
  return {_mm256_castps_si256(
      _mm256_blendv_ps(_mm256_castsi256_ps(if_false.v), _mm256_castsi256_ps(if_true.v), m.m))};
}
inline void store(int32_t* p, VI a) {
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), a.v);
}
// Lane l reads base[8 * l] for l < count (eight floats apart: one Ray), else holds `fallback`.
inline VM first_lanes(int count) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  return {_mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(count), lane))};
}
inline VF load_every_8th(const float* base, int count, float fallback) {
  const __m256i index = _mm256_setr_epi32(0, 8, 16, 24, 32, 40, 48, 56);
  return {_mm256_mask_i32gather_ps(_mm256_set1_ps(fallback), base, index, first_lanes(count).m, 4)};
}
inline float hmin(VF a) {
  __m128 m = _mm_min_ps(_mm256_castps256_ps128(a.v), _mm256_extractf128_ps(a.v, 1));
  m = _mm_min_ps(m, _mm_movehl_ps(m, m));
  m = _mm_min_ss(m, _mm_shuffle_ps(m, m, 1));
  return _mm_cvtss_f32(m);
}
inline float hmax(VF a) {
  __m128 m = _mm_max_ps(_mm256_castps256_ps128(a.v), _mm256_extractf128_ps(a.v, 1));
  m = _mm_max_ps(m, _mm_movehl_ps(m, m));
  m = _mm_max_ss(m, _mm_shuffle_ps(m, m, 1));
  return _mm_cvtss_f32(m);
}
#else
inline constexpr int kLanes = 0;
#endif

}  // namespace tritrace::bvh::simd

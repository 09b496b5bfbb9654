// A thin wrapper over the widest float SIMD this build targets (AVX-512: 16 lanes, AVX2: 8), so the
// packet traversal and the batched shading are written once. Every arithmetic operation is the
// IEEE single-precision operation of the scalar code (no FMA, no approximations), so a lane
// computes exactly what the scalar path computes. min/max keep the intrinsics' NaN rule (a NaN in
// the first operand returns the second), which the box tests rely on. kLanes is 0 without AVX2.
#pragma once

#include <cstdint>

#if defined(__AVX512F__) || defined(__AVX2__)
#include <immintrin.h>
#endif

namespace tritrace::simd {

#if defined(__AVX2__)
// The AVX 8 x 8 transpose (8 loads, 24 shuffles; far cheaper than 8 gathers of the same data):
// out[c] holds column c of the rows, lane l from rows[l][c]. Moves only: the bits are the rows'.
inline void transpose_8x8(const float* const rows[8], __m256 out[8]) {
  __m256 r[8], t[8], u[8];
  for (int i = 0; i < 8; ++i) r[i] = _mm256_loadu_ps(rows[i]);
  for (int i = 0; i < 8; i += 2) {
    t[i] = _mm256_unpacklo_ps(r[i], r[i + 1]);
    t[i + 1] = _mm256_unpackhi_ps(r[i], r[i + 1]);
  }
  for (int i = 0; i < 8; i += 4) {
    u[i] = _mm256_shuffle_ps(t[i], t[i + 2], 0x44);
    u[i + 1] = _mm256_shuffle_ps(t[i], t[i + 2], 0xEE);
    u[i + 2] = _mm256_shuffle_ps(t[i + 1], t[i + 3], 0x44);
    u[i + 3] = _mm256_shuffle_ps(t[i + 1], t[i + 3], 0xEE);
  }
  for (int c = 0; c < 4; ++c) {
    out[c] = _mm256_permute2f128_ps(u[c], u[c + 4], 0x20);
    out[c + 4] = _mm256_permute2f128_ps(u[c], u[c + 4], 0x31);
  }
}
#endif

#if defined(__AVX512F__)
// GCC 12 reports its own _mm512_undefined_ps() (inside sqrt/min/max/cvtt) as used uninitialized
// once inlined into larger functions; the zero-masked forms with every lane on are the same
// instructions without it.
#define TRITRACE_SIMD_LANES 16
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
  return {_mm512_maskz_min_ps(0xFFFF, a.v, b.v)};
}
inline VF vmax(VF a, VF b) {
  return {_mm512_maskz_max_ps(0xFFFF, a.v, b.v)};
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
inline VF to_float(VI a) {
  return {_mm512_maskz_cvtepi32_ps(0xFFFF, a.v)};
}
// Lane l holds l % 4 (quad_column) or l / 4 (quad_row): the pixels of rows 4 wide.
inline VI quad_column() {
  return {_mm512_setr_epi32(0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3)};
}
inline VI quad_row() {
  return {_mm512_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3)};
}
// Lane l reads base[index[l]] (index in floats) where `lanes` has bit l set, else 0.
inline VF gather(const float* base, VI index, VM lanes) {
  return {_mm512_mask_i32gather_ps(_mm512_setzero_ps(), lanes.m, index.v, base, 4)};
}
// Only lane l.
inline VM single_lane(int l) {
  return {static_cast<__mmask16>(1u << l)};
}
inline VI iota_i() {
  return {_mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)};
}
inline VM operator==(VI a, VI b) {
  return {_mm512_cmpeq_epi32_mask(a.v, b.v)};
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
// rows[l] points to 8 floats for each lane l: out[c] holds column c of the rows, lane l from
// rows[l][c] (an 8 x W transpose with 256-bit loads and in-register shuffles, far cheaper than 8
// gathers of the same data).
inline void transpose_rows_of_8(const float* const rows[16], VF out[8]) {
  __m512 r[8];
  for (int i = 0; i < 8; ++i) {  // rays i and i + 8 in the low and high 256 bits
    r[i] = _mm512_mask_expandloadu_ps(_mm512_maskz_loadu_ps(0x00FF, rows[i]), 0xFF00, rows[i + 8]);
  }
  // The AVX 8 x 8 transpose, in both 256-bit halves at once.
  __m512 t[8], u[8];
  for (int i = 0; i < 8; i += 2) {
    t[i] = _mm512_maskz_unpacklo_ps(0xFFFF, r[i], r[i + 1]);
    t[i + 1] = _mm512_maskz_unpackhi_ps(0xFFFF, r[i], r[i + 1]);
  }
  for (int i = 0; i < 8; i += 4) {
    u[i] = _mm512_maskz_shuffle_ps(0xFFFF, t[i], t[i + 2], 0x44);
    u[i + 1] = _mm512_maskz_shuffle_ps(0xFFFF, t[i], t[i + 2], 0xEE);
    u[i + 2] = _mm512_maskz_shuffle_ps(0xFFFF, t[i + 1], t[i + 3], 0x44);
    u[i + 3] = _mm512_maskz_shuffle_ps(0xFFFF, t[i + 1], t[i + 3], 0xEE);
  }
  // Columns c and c + 4: 128-bit quarters 0 (rays 0-3) of u[c] and u[c + 4] then quarter 2
  // (rays 8-11) of each; quarters 1 and 3 for column c + 4.
  const __m512i low = _mm512_setr_epi32(0, 1, 2, 3, 16, 17, 18, 19, 8, 9, 10, 11, 24, 25, 26, 27);
  const __m512i high =
      _mm512_setr_epi32(4, 5, 6, 7, 20, 21, 22, 23, 12, 13, 14, 15, 28, 29, 30, 31);
  for (int c = 0; c < 4; ++c) {
    out[c] = {_mm512_permutex2var_ps(u[c], low, u[c + 4])};
    out[c + 4] = {_mm512_permutex2var_ps(u[c], high, u[c + 4])};
  }
}
inline VM first_lanes(int count) {
  return {count >= 16 ? static_cast<__mmask16>(0xFFFF) : static_cast<__mmask16>((1u << count) - 1)};
}
// Written out rather than _mm512_reduce_min_ps, which trips GCC 12's -Wmaybe-uninitialized.
inline float hmin(VF a) {
  __m512 m = _mm512_maskz_min_ps(
      0xFFFF, a.v, _mm512_maskz_shuffle_f32x4(0xFFFF, a.v, a.v, 0x4E));  // swap 256-bit halves
  m = _mm512_maskz_min_ps(0xFFFF, m,
                          _mm512_maskz_shuffle_f32x4(0xFFFF, m, m, 0xB1));  // swap 128-bit quarters
  __m128 q = _mm512_castps512_ps128(m);
  q = _mm_min_ps(q, _mm_movehl_ps(q, q));
  q = _mm_min_ss(q, _mm_shuffle_ps(q, q, 1));
  return _mm_cvtss_f32(q);
}
inline float hmax(VF a) {
  __m512 m = _mm512_maskz_max_ps(0xFFFF, a.v, _mm512_maskz_shuffle_f32x4(0xFFFF, a.v, a.v, 0x4E));
  m = _mm512_maskz_max_ps(0xFFFF, m, _mm512_maskz_shuffle_f32x4(0xFFFF, m, m, 0xB1));
  __m128 q = _mm512_castps512_ps128(m);
  q = _mm_max_ps(q, _mm_movehl_ps(q, q));
  q = _mm_max_ss(q, _mm_shuffle_ps(q, q, 1));
  return _mm_cvtss_f32(q);
}
inline VF sqrt(VF a) {
  return {_mm512_maskz_sqrt_ps(0xFFFF, a.v)};
}
inline VF abs(VF a) {
  return {_mm512_abs_ps(a.v)};
}
// |a| with the sign bit of b.
inline VF copysign(VF a, VF b) {
  const __m512i sign = _mm512_set1_epi32(INT32_MIN);
  return {_mm512_castsi512_ps(_mm512_or_si512(_mm512_andnot_si512(sign, _mm512_castps_si512(a.v)),
                                              _mm512_and_si512(sign, _mm512_castps_si512(b.v))))};
}
// -a, sign bit flipped (so -(+0) is -0, unlike 0 - a).
inline VF operator-(VF a) {
  return {_mm512_castsi512_ps(
      _mm512_xor_si512(_mm512_castps_si512(a.v), _mm512_set1_epi32(INT32_MIN)))};
}
inline VM operator>(VF a, VF b) {
  return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_GT_OQ)};
}
// !(a > b): also true where either is NaN.
inline VM not_greater(VF a, VF b) {
  return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_NGT_UQ)};
}
inline VI operator+(VI a, VI b) {
  return {_mm512_add_epi32(a.v, b.v)};
}
inline VI operator-(VI a, VI b) {
  return {_mm512_sub_epi32(a.v, b.v)};
}
// The float's bit pattern as an integer and back (std::bit_cast per lane).
inline VI bits_of(VF a) {
  return {_mm512_castps_si512(a.v)};
}
inline VF float_from_bits(VI a) {
  return {_mm512_castsi512_ps(a.v)};
}
// static_cast<int32_t>(float) per lane: truncation towards zero.
inline VI truncate_to_int(VF a) {
  return {_mm512_maskz_cvttps_epi32(0xFFFF, a.v)};
}
// Lane l reads base[index[l]] (index in floats). The masked form with every lane on: GCC 12's
// unmasked one trips -Wuninitialized.
inline VF gather(const float* base, VI index) {
  return {_mm512_mask_i32gather_ps(_mm512_setzero_ps(), 0xFFFF, index.v, base, 4)};
}
#elif defined(__AVX2__)
#define TRITRACE_SIMD_LANES 8
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
inline VF to_float(VI a) {
  return {_mm256_cvtepi32_ps(a.v)};
}
// Lane l holds l % 4 (quad_column) or l / 4 (quad_row): the pixels of rows 4 wide.
inline VI quad_column() {
  return {_mm256_setr_epi32(0, 1, 2, 3, 0, 1, 2, 3)};
}
inline VI quad_row() {
  return {_mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1)};
}
// Lane l reads base[index[l]] (index in floats) where `lanes` has bit l set, else 0.
inline VF gather(const float* base, VI index, VM lanes) {
  return {_mm256_mask_i32gather_ps(_mm256_setzero_ps(), base, index.v, lanes.m, 4)};
}
inline VI iota_i() {
  return {_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)};
}
// Only lane l.
inline VM single_lane(int l) {
  return {_mm256_castsi256_ps(_mm256_cmpeq_epi32(iota_i().v, _mm256_set1_epi32(l)))};
}
inline VM operator==(VI a, VI b) {
  return {_mm256_castsi256_ps(_mm256_cmpeq_epi32(a.v, b.v))};
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
inline VM first_lanes(int count) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  return {_mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(count), lane))};
}
// rows[l] points to 8 floats for each lane l: out[c] holds column c of the rows, lane l from
// rows[l][c] (transpose_8x8).
inline void transpose_rows_of_8(const float* const rows[8], VF out[8]) {
  __m256 columns[8];
  transpose_8x8(rows, columns);
  for (int c = 0; c < 8; ++c) out[c] = {columns[c]};
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
inline VF sqrt(VF a) {
  return {_mm256_sqrt_ps(a.v)};
}
inline VF abs(VF a) {
  return {_mm256_andnot_ps(_mm256_set1_ps(-0.0f), a.v)};
}
// |a| with the sign bit of b.
inline VF copysign(VF a, VF b) {
  const __m256 sign = _mm256_set1_ps(-0.0f);
  return {_mm256_or_ps(_mm256_andnot_ps(sign, a.v), _mm256_and_ps(sign, b.v))};
}
// -a, sign bit flipped (so -(+0) is -0, unlike 0 - a).
inline VF operator-(VF a) {
  return {_mm256_xor_ps(a.v, _mm256_set1_ps(-0.0f))};
}
inline VM operator>(VF a, VF b) {
  return {_mm256_cmp_ps(a.v, b.v, _CMP_GT_OQ)};
}
// !(a > b): also true where either is NaN.
inline VM not_greater(VF a, VF b) {
  return {_mm256_cmp_ps(a.v, b.v, _CMP_NGT_UQ)};
}
inline VI operator+(VI a, VI b) {
  return {_mm256_add_epi32(a.v, b.v)};
}
inline VI operator-(VI a, VI b) {
  return {_mm256_sub_epi32(a.v, b.v)};
}
// The float's bit pattern as an integer and back (std::bit_cast per lane).
inline VI bits_of(VF a) {
  return {_mm256_castps_si256(a.v)};
}
inline VF float_from_bits(VI a) {
  return {_mm256_castsi256_ps(a.v)};
}
// static_cast<int32_t>(float) per lane: truncation towards zero.
inline VI truncate_to_int(VF a) {
  return {_mm256_cvttps_epi32(a.v)};
}
// Lane l reads base[index[l]] (index in floats).
inline VF gather(const float* base, VI index) {
  return {_mm256_i32gather_ps(base, index.v, 4)};
}
#else
#define TRITRACE_SIMD_LANES 0
inline constexpr int kLanes = 0;
#endif

}  // namespace tritrace::simd

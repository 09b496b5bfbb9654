// The first two dimensions of the Sobol sequence and Owen scrambling by hashing: the pieces of the
// stratified sampler (render/sampler.h). Header-only: a few dozen integer operations per number,
// which must inline into the path tracer's loops.
#pragma once

#include <cstdint>
#include <initializer_list>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace tritrace {

// The 32 bits of x in reverse order (bit 0 becomes bit 31): a byte swap, then the bits of each
// byte reversed by swapping nibbles, pairs and neighbours.
constexpr uint32_t reverse_bits(uint32_t x) {
  x = (x << 24) | ((x & 0xff00u) << 8) | ((x >> 8) & 0xff00u) | (x >> 24);
  x = ((x & 0x0f0f0f0fu) << 4) | ((x >> 4) & 0x0f0f0f0fu);
  x = ((x & 0x33333333u) << 2) | ((x >> 2) & 0x33333333u);
  x = ((x & 0x55555555u) << 1) | ((x >> 1) & 0x55555555u);
  return x;
}

// Dimension 0 of the Sobol sequence is van der Corput's radical inverse in base 2: the index's bits
// mirrored behind the binary point. As a 32-bit fraction (the value times 2^32).
constexpr uint32_t sobol_dimension0(uint32_t index) {
  return reverse_bits(index);
}

// Dimension 1, whose generator matrix is Pascal's triangle mod 2 (primitive polynomial x + 1,
// direction numbers m_k = 1): digit j + 1 of the fraction (j = 0 the 1/2 place) is the parity of
// the index bits k with binomial(k, j) odd, which by Lucas' theorem are the k whose bits contain
// j's bits. That superset parity is computed for all 32 digits at once by five butterfly steps
// (the binary zeta transform), in the mirrored order: bit j of the result is digit j + 1.
// U is uint32_t, or a GCC vector of uint32_t lanes (each lane then the scalar result).
template <class U>
constexpr U sobol_dimension1_mirrored(U index) {
  U z = index;
  z ^= (z >> 1) & 0x55555555u;
  z ^= (z >> 2) & 0x33333333u;
  z ^= (z >> 4) & 0x0f0f0f0fu;
  z ^= (z >> 8) & 0x00ff00ffu;
  z ^= (z >> 16) & 0x0000ffffu;
  return z;
}
constexpr uint32_t sobol_dimension1(uint32_t index) {
  return reverse_bits(sobol_dimension1_mirrored(index));
}

// Laine and Karras's hash-based stand-in for an Owen scramble ("Stratified Sampling for Stochastic
// Transparency", 2011), with the constants of Burley's improved version ("Practical Hash-based Owen
// Scrambling", JCGT 2020). It acts on the mirrored fraction (bit 0 = the 1/2 digit): adding the
// seed and each x ^= x * even changes bit j only as a function of bits 0..j, so every digit is
// flipped by a hash of the digits before it, which is what Owen scrambling does; each step is a
// bijection.
// U as for sobol_dimension1_mirrored.
template <class U>
constexpr U laine_karras_permutation(U mirrored, U seed) {
  U x = mirrored + seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

// A nested uniform (Owen) scramble of a 32-bit fraction, by `seed`: a point set that is a (0, m,
// 2)-net stays one, and a scrambled point is uniform over [0, 1) for a random seed.
constexpr uint32_t owen_scramble(uint32_t fraction, uint32_t seed) {
  return reverse_bits(laine_karras_permutation(reverse_bits(fraction), seed));
}

#if defined(__AVX2__)
// Eight lanes of the functions above, each lane bit for bit the scalar result (integer operations
// only), for samplers that draw several groups at once.
inline __m256i reverse_bits_x8(__m256i x) {
  // The bytes of each lane reversed by one shuffle, then each byte's bits by looking its two
  // nibbles up in a table of 4-bit reversals: the low nibble's reversal becomes the high one.
  const __m256i bytes = _mm256_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12, 3, 2,
                                         1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12);
  const __m256i rev_to_high =
      _mm256_setr_epi8(0x00, 0x80, 0x40, 0xc0, 0x20, 0xa0, 0x60, 0xe0, 0x10, 0x90, 0x50, 0xd0, 0x30,
                       0xb0, 0x70, 0xf0, 0x00, 0x80, 0x40, 0xc0, 0x20, 0xa0, 0x60, 0xe0, 0x10, 0x90,
                       0x50, 0xd0, 0x30, 0xb0, 0x70, 0xf0);
  const __m256i rev_to_low = _mm256_setr_epi8(0, 8, 4, 12, 2, 10, 6, 14, 1, 9, 5, 13, 3, 11, 7, 15,
                                              0, 8, 4, 12, 2, 10, 6, 14, 1, 9, 5, 13, 3, 11, 7, 15);
  const __m256i nibble = _mm256_set1_epi8(0x0f);
  x = _mm256_shuffle_epi8(x, bytes);
  const __m256i low = _mm256_and_si256(x, nibble);
  const __m256i high = _mm256_and_si256(_mm256_srli_epi16(x, 4), nibble);
  return _mm256_or_si256(_mm256_shuffle_epi8(rev_to_high, low),
                         _mm256_shuffle_epi8(rev_to_low, high));
}

inline __m256i laine_karras_permutation_x8(__m256i x, __m256i seed) {
  x = _mm256_add_epi32(x, seed);
  for (const int c : {0x6c50b47c, static_cast<int>(0xb82f1e52u), static_cast<int>(0xc7afe638u),
                      static_cast<int>(0x8d22f6e6u)}) {
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32(c)));
  }
  return x;
}

inline __m256i sobol_dimension1_mirrored_x8(__m256i z) {
  const auto step = [&z](int shift, int mask) {
    z = _mm256_xor_si256(z, _mm256_and_si256(_mm256_srli_epi32(z, shift), _mm256_set1_epi32(mask)));
  };
  step(1, 0x55555555);
  step(2, 0x33333333);
  step(4, 0x0f0f0f0f);
  step(8, 0x00ff00ff);
  step(16, 0x0000ffff);
  return z;
}
#endif

}  // namespace tritrace

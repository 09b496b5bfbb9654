// Sampler: the random numbers of one pixel sample, a function of (seed, pixel, sample index,
// dimension) only, so images do not depend on threads, tiles or on which samples a process renders.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <glm/vec2.hpp>

#include "tritrace/math/random.h"
#include "tritrace/math/sobol.h"

namespace tritrace {

// Each (seed, pixel, sample index) is a key; sample i is reproduced exactly without drawing samples
// 0..i-1, which lets sample ranges be rendered apart and merged. pbrt-v4's
// StartPixelSample(pPixel, sampleIndex) is start_pixel_sample here.
class Sampler {
 public:
  explicit Sampler(uint64_t seed = 0, SamplerKind kind = SamplerKind::kSobol)
      : seed_(seed), seed_hash_(hash_words(seed)), kind_(kind) {
    start_pixel_sample(0, 0, 0);
  }

  // Starts sample `sample_index` of pixel (x, y) at dimension 0. The same arguments replay the same
  // numbers whatever was drawn before.
  void start_pixel_sample(int x, int y, uint32_t sample_index);

  // The next dimension, in [0, 1) (a multiple of 2^-24, at most 1 - 2^-24).
  float get_1d() {
    if (kind_ == SamplerKind::kIndependent) {
      ++dimension_;
      return rng_.next_float();
    }
    const uint64_t h = group_hash();
    dimension_ += 1;
    return unit_float(reverse_bits(laine_karras_permutation(shuffled_index(h), high_half(h))));
  }
  // The next two dimensions, stratified together (one group) by the Sobol sampler.
  glm::vec2 get_2d() {
    if (kind_ == SamplerKind::kIndependent) {
      const float u = get_1d();
      return {u, get_1d()};
    }
    const uint64_t h = group_hash();
    dimension_ += 2;
    const uint32_t index = shuffled_index(h);
    // Owen scrambling a fraction is reverse(permutation(reverse(fraction))); dimension 0 is the
    // reversed index, dimension 1 is computed mirrored, so neither needs the inner reverse.
    const uint32_t x = reverse_bits(laine_karras_permutation(index, high_half(h)));
    const uint32_t y =
        reverse_bits(laine_karras_permutation(sobol_dimension1_mirrored(index), third_seed(h)));
    return {unit_float(x), unit_float(y)};
  }
  // N consecutive 2-D groups (1 <= N <= 4): exactly the numbers of N calls of get_2d, computed in
  // SIMD lanes by the Sobol sampler where the build has AVX2 (one shuffle for all groups' indices,
  // one for all their values), which is how the path tracer draws the three groups of a vertex.
  // Always inlined: the path tracer calls it at every vertex, and a call returns the array through
  // memory (measured: 2% more instructions in the diffuse path tracer when GCC keeps it a call).
  template <size_t N>
  [[gnu::always_inline]] inline std::array<glm::vec2, N> get_2d_groups() {
    static_assert(N >= 1 && N <= 4);
    std::array<glm::vec2, N> out;
#if defined(__AVX2__)
    if (kind_ == SamplerKind::kSobol) {
      // Lanes 0..3: group g's index seed, then its dimension 0 seed; lanes 4..7: dimension 1's.
      alignas(32) uint32_t index_seed[8] = {}, value_seed[8] = {};
      for (size_t g = 0; g < N; ++g) {
        const uint64_t h = hash_combine(pixel_hash_, dimension_ + 2 * g);
        index_seed[g] = static_cast<uint32_t>(h);
        value_seed[g] = high_half(h);
        value_seed[4 + g] = third_seed(h);
      }
      dimension_ += static_cast<uint32_t>(2 * N);
      const __m256i index = reverse_bits_x8(laine_karras_permutation_x8(
          _mm256_set1_epi32(static_cast<int>(mirrored_index_)),
          _mm256_load_si256(reinterpret_cast<const __m256i*>(index_seed))));
      // [indices of groups 0..3 | the same through dimension 1's matrix]
      const __m256i points =
          _mm256_permute2x128_si256(index, sobol_dimension1_mirrored_x8(index), 0x20);
      const __m256i bits = reverse_bits_x8(laine_karras_permutation_x8(
          points, _mm256_load_si256(reinterpret_cast<const __m256i*>(value_seed))));
      alignas(32) float lanes[8];
      _mm256_store_ps(lanes, _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(bits, 8)),
                                           _mm256_set1_ps(0x1p-24f)));
      for (size_t g = 0; g < N; ++g) out[g] = {lanes[g], lanes[4 + g]};
      return out;
    }
#endif
    for (glm::vec2& u : out) u = get_2d();
    return out;
  }

  // The next N 2-D groups (1 <= N <= 4) of each of count samplers, exactly what get_2d_groups<N>
  // draws for each: dimension d (0 or 1) of group g of samplers[j] goes to out[(2 g + d) stride +
  // j]. Where the build has AVX2 and every sampler is a Sobol one, eight samplers share each SIMD
  // operation, one lane each: a vertex's draw is a long chain of dependent multiplications, which
  // one sampler's grouped draw (get_2d_groups) leaves mostly waiting, and it takes half the
  // multiplications of the grouped draw's partly filled lanes. out must have room for count
  // rounded up to a multiple of 8 in each row (stride >= that): the last lanes are written too.
  template <size_t N>
  static void get_2d_groups_batch(Sampler* const* samplers, size_t count, float* out,
                                  size_t stride) {
    static_assert(N >= 1 && N <= 4);
#if defined(__AVX2__)
    bool sobol = true;
    for (size_t j = 0; j < count; ++j) sobol = sobol && samplers[j]->kind_ == SamplerKind::kSobol;
#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512DQ__) && defined(__GFNI__)
    if (sobol) {
      get_2d_groups_batch16<N>(samplers, count, out, stride);
      return;
    }
#endif
    if (sobol) {
      for (size_t j0 = 0; j0 < count; j0 += 8) {
        const size_t lanes = count - j0 < 8 ? count - j0 : 8;
        // Per lane: the mirrored sample index, and per group its index seed, its dimension 0 seed
        // and its dimension 1 seed (as in get_2d_groups).
        alignas(32) uint32_t index[8], seeds[N][3][8];
        if (lanes < 8) {
          std::fill_n(index, 8, 0u);
          std::fill_n(&seeds[0][0][0], N * 3 * 8, 0u);
        }
        for (size_t l = 0; l < lanes; ++l) {
          Sampler& sampler = *samplers[j0 + l];
          index[l] = sampler.mirrored_index_;
          for (size_t g = 0; g < N; ++g) {
            const uint64_t h = hash_combine(sampler.pixel_hash_, sampler.dimension_ + 2 * g);
            seeds[g][0][l] = static_cast<uint32_t>(h);
            seeds[g][1][l] = high_half(h);
            seeds[g][2][l] = third_seed(h);
          }
          sampler.dimension_ += static_cast<uint32_t>(2 * N);
        }
        const auto load = [](const uint32_t* p) {
          return _mm256_load_si256(reinterpret_cast<const __m256i*>(p));
        };
        const auto store_unit = [](float* to, __m256i bits) {
          _mm256_storeu_ps(to, _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(bits, 8)),
                                             _mm256_set1_ps(0x1p-24f)));
        };
        const __m256i mirrored = load(index);
        for (size_t g = 0; g < N; ++g) {
          const __m256i shuffled =
              reverse_bits_x8(laine_karras_permutation_x8(mirrored, load(seeds[g][0])));
          store_unit(out + 2 * g * stride + j0,
                     reverse_bits_x8(laine_karras_permutation_x8(shuffled, load(seeds[g][1]))));
          store_unit(out + (2 * g + 1) * stride + j0,
                     reverse_bits_x8(laine_karras_permutation_x8(
                         sobol_dimension1_mirrored_x8(shuffled), load(seeds[g][2]))));
        }
      }
      return;
    }
#endif
    for (size_t j = 0; j < count; ++j) {
      const std::array<glm::vec2, N> u = samplers[j]->get_2d_groups<N>();
      for (size_t g = 0; g < N; ++g) {
        out[2 * g * stride + j] = u[g].x;
        out[(2 * g + 1) * stride + j] = u[g].y;
      }
    }
  }

  // The position inside the pixel: by convention the first two dimensions of a sample (the
  // renderer calls it right after start_pixel_sample), one 2-D group.
  glm::vec2 get_pixel_2d() {
    return get_2d();
  }
  // The point on a thin lens: by convention the next two dimensions (2 and 3), one 2-D group, drawn
  // right after get_pixel_2d and only when the camera has a lens, so that pinhole renders keep the
  // layout (and the images) they had; the integrator's dimensions follow.
  glm::vec2 get_lens_2d() {
    return get_2d();
  }

  uint64_t seed() const {
    return seed_;
  }
  SamplerKind kind() const {
    return kind_;
  }
  // How many dimensions the current sample has used.
  uint32_t dimension() const {
    return dimension_;
  }
  // The current sample's index in its pixel, and the key of (seed, pixel) that scrambles its
  // numbers: for integrators that decide something per sample from the pixel's sample sequence
  // (bdpt's share of samples with a light subpath, BdptSettings::light_paths).
  uint32_t sample_index() const {
    return reverse_bits(mirrored_index_);
  }
  uint64_t pixel_key() const {
    return pixel_hash_;
  }

 private:
#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512DQ__) && defined(__GFNI__)
  // get_2d_groups_batch for Sobol samplers, sixteen to an AVX-512 operation: the keys' 64-bit
  // hashes (vpmullq) and the permutations (vpmulld) in lanes, the bit reversals by a byte shuffle
  // and a GF(2) affine transform of each byte (GFNI). Integer operations only, each lane the
  // scalar result. Writes only the count samplers' cells.
  template <size_t N>
  static void get_2d_groups_batch16(Sampler* const* samplers, size_t count, float* out,
                                    size_t stride) {
    using U64x16 = uint64_t __attribute__((vector_size(128)));
    using U32x16 = uint32_t __attribute__((vector_size(64)));
    const auto reverse = [](U32x16 x) {
      const __m512i bytes =
          _mm512_shuffle_epi8(reinterpret_cast<__m512i>(x),
                              _mm512_set4_epi32(0x0c0d0e0f, 0x08090a0b, 0x04050607, 0x00010203));
      // Each byte's bits reversed: the matrix's row for output bit i selects input bit 7 - i.
      return reinterpret_cast<U32x16>(
          _mm512_gf2p8affine_epi64_epi8(bytes, _mm512_set1_epi64(0x8040201008040201ll), 0));
    };
    const auto store_unit = [](float* to, __mmask16 mask, U32x16 bits) {
      using F32x16 = float __attribute__((vector_size(64)));
      const F32x16 unit = __builtin_convertvector(bits >> 8, F32x16) * 0x1p-24f;
      _mm512_mask_storeu_ps(to, mask, reinterpret_cast<__m512>(unit));
    };
    for (size_t j0 = 0; j0 < count; j0 += 16) {
      const size_t lanes = count - j0 < 16 ? count - j0 : 16;
      const auto mask = static_cast<__mmask16>((1u << lanes) - 1u);
      alignas(64) uint32_t index[16] = {};
      alignas(64) uint64_t key[16] = {}, dimension[16] = {};
      for (size_t l = 0; l < lanes; ++l) {
        Sampler& sampler = *samplers[j0 + l];
        index[l] = sampler.mirrored_index_;
        key[l] = sampler.pixel_hash_;
        dimension[l] = sampler.dimension_;
        sampler.dimension_ += static_cast<uint32_t>(2 * N);
      }
      U64x16 base, dims;
      U32x16 mirrored;
      std::memcpy(&base, key, sizeof base);
      std::memcpy(&dims, dimension, sizeof dims);
      std::memcpy(&mirrored, index, sizeof mirrored);
      base = base + 0x9e3779b97f4a7c15ull + dims;
      for (size_t g = 0; g < N; ++g) {
        // hash_combine(pixel_hash_, dimension_ + 2 g), high_half and third_seed, as get_2d.
        U64x16 h = base + static_cast<uint64_t>(2 * g);
        h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ull;
        h = (h ^ (h >> 27)) * 0x94d049bb133111ebull;
        h = h ^ (h >> 31);
        const U32x16 index_seed = __builtin_convertvector(h, U32x16);
        const U32x16 value_seed = __builtin_convertvector(h >> 32, U32x16);
        const U32x16 third = __builtin_convertvector((h * 0x9e3779b97f4a7c15ull) >> 32, U32x16);
        const U32x16 shuffled = reverse(laine_karras_permutation(mirrored, index_seed));
        store_unit(out + 2 * g * stride + j0, mask,
                   reverse(laine_karras_permutation(shuffled, value_seed)));
        store_unit(out + (2 * g + 1) * stride + j0, mask,
                   reverse(laine_karras_permutation(sobol_dimension1_mirrored(shuffled), third)));
      }
    }
  }
#endif

  // The key of the group starting at the current dimension: its low half scrambles the sample
  // order, its high half (and, for a 2-D group, third_seed) the values.
  uint64_t group_hash() const {
    return hash_combine(pixel_hash_, dimension_);
  }
  static uint32_t high_half(uint64_t h) {
    return static_cast<uint32_t>(h >> 32);
  }
  // A third 32-bit seed from the group's key, for dimension 1: the top half of the key times
  // 2^64 / golden ratio (Fibonacci hashing), which mixes every bit of the key into it. A full
  // mix64 here measured 3% of a path-traced frame; no test sees a difference between the two.
  static uint32_t third_seed(uint64_t h) {
    return static_cast<uint32_t>((h * 0x9e3779b97f4a7c15ull) >> 32);
  }
  // The sample index Owen-scrambled as a fraction (its top bit the leading digit): the first 2^m
  // indices of a pixel become, in a scrambled order, one aligned block of 2^m Sobol indices, whose
  // points are a net as the first 2^m are.
  uint32_t shuffled_index(uint64_t h) const {
    return reverse_bits(laine_karras_permutation(mirrored_index_, static_cast<uint32_t>(h)));
  }

  Pcg32 rng_;  // kIndependent's stream
  uint64_t seed_;
  uint64_t seed_hash_;           // hash_words(seed_), the first link of every key
  uint64_t pixel_hash_;          // the key of (seed, pixel)
  uint32_t mirrored_index_ = 0;  // reverse_bits(sample index): owen_scramble's first step, once
  uint32_t dimension_ = 0;
  SamplerKind kind_;
};

}  // namespace tritrace

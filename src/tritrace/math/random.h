// Random numbers for Monte Carlo rendering: the PCG32 generator and a 64-bit mixing hash that
// derives independent streams from keys such as (seed, pixel, sample index). Header-only: each call
// is a few integer operations and must inline into sampling loops.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace tritrace {

// The largest float below one, 1 - 2^-24.
inline constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

// SplitMix64's output function (Steele, Lea and Flood, "Fast Splittable Pseudorandom Number
// Generators", OOPSLA 2014), with the constants of David Stafford's "Mix13" variant of
// MurmurHash3's 64-bit finalizer. A bijection on 64 bits with full avalanche: every input bit flips
// each output bit with probability about 1/2, so nearby keys (pixel x and x + 1) give unrelated
// values.
constexpr uint64_t mix64(uint64_t x) {
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// Hashes a sequence of 64-bit words: a running value, mixed after each word, absorbs the next by
// addition. The golden-ratio increment (SplitMix64's state step) keeps all-zero keys away from
// mix64's fixed point at 0. Each absorbed word is mixed before the next is added, so that
// (a + 1, b) and (a, b + 1) are unrelated keys.
constexpr uint64_t hash_combine(uint64_t h, uint64_t word) {
  return mix64(h + 0x9e3779b97f4a7c15ull + word);
}
template <typename... Words>
constexpr uint64_t hash_words(Words... words) {
  uint64_t h = 0;
  ((h = hash_combine(h, static_cast<uint64_t>(words))), ...);
  return h;
}

// A float in [0, 1) from 32 random bits: the top 24 bits are exactly representable, so the result
// is a multiple of 2^-24 and at most 1 - 2^-24 (rounding a 32-bit value times 2^-32 can give 1.0).
constexpr float unit_float(uint32_t bits) {
  return static_cast<float>(bits >> 8) * 0x1p-24f;
}

// PCG32, the XSH-RR variant of O'Neill's permuted congruential generators ("PCG: A Family of Simple
// Fast Space-Efficient Statistically Good Algorithms for Random Number Generation",
// HMC-CS-2014-0905, 2014): a 64-bit LCG whose state is output through a xorshift and a random
// rotation. Period 2^64 per stream; the odd increment selects one of 2^63 streams. Seeding follows
// the paper's reference pcg32_srandom_r, so (42, 54) gives its published demo sequence (tested).
class Pcg32 {
 public:
  constexpr Pcg32() = default;
  constexpr Pcg32(uint64_t init_state, uint64_t stream) { seed(init_state, stream); }

  constexpr void seed(uint64_t init_state, uint64_t stream) {
    state_ = 0;
    inc_ = (stream << 1) | 1;
    step();
    state_ += init_state;
    step();
  }

  constexpr uint32_t next_u32() {
    const uint64_t old = state_;
    step();
    const auto xorshifted = static_cast<uint32_t>(((old >> 18) ^ old) >> 27);
    const auto rot = static_cast<uint32_t>(old >> 59);
    return (xorshifted >> rot) | (xorshifted << ((32 - rot) & 31));
  }

  // In [0, 1), a multiple of 2^-24.
  constexpr float next_float() { return unit_float(next_u32()); }

 private:
  static constexpr uint64_t kMultiplier = 6364136223846793005ull;  // Knuth's MMIX LCG multiplier

  constexpr void step() { state_ = state_ * kMultiplier + inc_; }

  // The reference implementation's default stream.
  uint64_t state_ = 0x853c49e6748fea9bull;
  uint64_t inc_ = 0xda3e39cb94b95bdbull;
};

// How the numbers of a pixel's samples relate to each other (render/sampler.h draws them; the
// choice sits here, below the scene layer, because scene files name it).
//  - kSobol (the default): stratified. Each get_1d or get_2d call of a sample is its own group of
//    dimensions, drawn from the first one or two dimensions of the Sobol sequence, whose first 2^m
//    points form a (0, m, 2)-net: every 1/2^m-area box of the square's dyadic grids holds exactly
//    one point. Each group's points are Owen-scrambled by a hash of (seed, pixel, dimension), which
//    keeps that structure and makes every number uniform, and the group's sample order is
//    shuffled by a scramble of the sample index, which decorrelates groups (padded Sobol points;
//    Burley, "Practical Hash-based Owen Scrambling", JCGT 2020; the shape of Cycles' Sobol-Burley
//    and pbrt-v4's PaddedSobolSampler). So the N samples of a pixel cover its area, a light's
//    area and the hemisphere evenly (exactly so for N a power of two), and error falls faster
//    than 1/sqrt(N) where the integrand is smooth. Still unbiased: each sample, alone, is uniform.
//  - kIndependent: every number independent (plain Monte Carlo), a PCG32 stream per sample.
enum class SamplerKind : uint8_t { kSobol, kIndependent };

constexpr std::string_view sampler_name(SamplerKind kind) {
  return kind == SamplerKind::kSobol ? "sobol" : "independent";
}
constexpr std::optional<SamplerKind> parse_sampler(std::string_view name) {
  if (name == "sobol") return SamplerKind::kSobol;
  if (name == "independent") return SamplerKind::kIndependent;
  return std::nullopt;
}

}  // namespace tritrace

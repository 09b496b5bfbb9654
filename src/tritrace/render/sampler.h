// Sampler: the random numbers of one pixel sample, a function of (seed, pixel, sample index,
// dimension) only, so images do not depend on threads, tiles or on which samples a process renders.
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>

#include "tritrace/math/random.h"

namespace tritrace {

// Each (seed, x, y, sample index) owns a PCG32 stream: its initial state and its stream selector
// are two hashes of the four values (mix64 avalanches every bit, so neighbouring pixels and indices
// get unrelated streams), and dimension d of the sample is the stream's d-th number. Starting a
// sample costs three 64-bit mixes and two LCG steps; a number costs one LCG step and its output
// permutation. Sample i is reproduced exactly without drawing samples 0..i-1, which lets sample
// ranges be rendered apart and merged. pbrt-v4's StartPixelSample(pPixel, sampleIndex) is
// start_pixel_sample here; its IndependentSampler keeps one stream per pixel and jumps ahead 65536
// numbers per sample index, which caps a sample's dimensions, while a hashed stream per sample has
// no cap.
//
// Independent numbers converge at the plain Monte Carlo rate; a stratified or low-discrepancy
// sampler (Owen-scrambled Sobol) can later keep this interface.
class Sampler {
 public:
  explicit Sampler(uint64_t seed = 0) : seed_(seed), seed_hash_(hash_words(seed)) {
    start_pixel_sample(0, 0, 0);
  }

  // Starts sample `sample_index` of pixel (x, y) at dimension 0. The same arguments replay the same
  // numbers whatever was drawn before.
  void start_pixel_sample(int x, int y, uint32_t sample_index);

  // The next dimension, in [0, 1) (a multiple of 2^-24, at most 1 - 2^-24).
  float get_1d() {
    ++dimension_;
    return rng_.next_float();
  }
  // The next two dimensions.
  glm::vec2 get_2d() {
    const float u = get_1d();
    return {u, get_1d()};
  }
  // The position inside the pixel: by convention the first two dimensions of a sample (the
  // integrator calls it right after start_pixel_sample), so that a later stratified sampler can
  // give those dimensions its best distribution.
  glm::vec2 get_pixel_2d() { return get_2d(); }

  uint64_t seed() const { return seed_; }
  // How many dimensions the current sample has used.
  uint32_t dimension() const { return dimension_; }

 private:
  Pcg32 rng_;
  uint64_t seed_;
  uint64_t seed_hash_;  // hash_words(seed_), the first link of every key
  uint32_t dimension_ = 0;
};

}  // namespace tritrace

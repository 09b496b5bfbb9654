// Sampler: the keys of (seed, pixel, sample index).
#include "tritrace/render/sampler.h"

namespace tritrace {

void Sampler::start_pixel_sample(int x, int y, uint32_t sample_index) {
  // x and y are packed losslessly into one word and hashed after the seed. The Sobol sampler keys
  // its groups by (that, dimension) and takes the index as the point's number; the independent one
  // hashes the index in too and seeds a PCG32 stream with the key. Its stream selector is a second,
  // salted hash of the key: PCG streams whose increments and states are related can be correlated
  // (Vigna, "The wrap-up on PCG generators", 2018); hashed ones are not in any way a test here can
  // see.
  const uint64_t pixel = (static_cast<uint64_t>(static_cast<uint32_t>(y)) << 32) |
                         static_cast<uint64_t>(static_cast<uint32_t>(x));
  pixel_hash_ = hash_combine(seed_hash_, pixel);
  mirrored_index_ = reverse_bits(sample_index);
  dimension_ = 0;
  if (kind_ == SamplerKind::kIndependent) {
    const uint64_t key = hash_combine(pixel_hash_, sample_index);
    rng_.seed(key, hash_combine(key, 0x5eed5eed5eed5eedull));
  }
}

}  // namespace tritrace

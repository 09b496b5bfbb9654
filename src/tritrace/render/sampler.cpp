// Sampler: seeding one PCG32 stream per (seed, pixel, sample index).
#include "tritrace/render/sampler.h"

namespace tritrace {

void Sampler::start_pixel_sample(int x, int y, uint32_t sample_index) {
  // x and y are packed losslessly into one word; the seed, that word and the index are hashed in
  // turn, so any two different (seed, pixel, index) share a stream only by a 2^-64 chance. The
  // stream selector is a second, salted hash of the key: PCG streams whose increments and states
  // are related can be correlated (Vigna, "The wrap-up on PCG generators", 2018); hashed ones are
  // not in any way a test here can see.
  const uint64_t pixel = (static_cast<uint64_t>(static_cast<uint32_t>(y)) << 32) |
                         static_cast<uint64_t>(static_cast<uint32_t>(x));
  const uint64_t key = hash_combine(hash_combine(seed_hash_, pixel), sample_index);
  rng_.seed(key, hash_combine(key, 0x5eed5eed5eed5eedull));
  dimension_ = 0;
}

}  // namespace tritrace

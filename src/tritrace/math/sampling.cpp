// The sampling routines that are not inline: the concentric disk map and the alias table's build.
#include "tritrace/math/sampling.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tritrace {

glm::vec2 sample_uniform_disk_concentric(glm::vec2 u) {
  // Shirley and Chiu 1997 in the two-case form Shirley credits to Dave Cline: [0,1)^2 to [-1,1)^2,
  // then each concentric square of half-width r to the circle of radius r, the square's triangular
  // quarter around an axis to that axis' quarter of the circle, angle proportional to the position
  // along the square's side.
  const float a = 2.0f * u.x - 1.0f;
  const float b = 2.0f * u.y - 1.0f;
  if (a == 0.0f && b == 0.0f) return {0.0f, 0.0f};
  float r;
  float phi;
  if (std::fabs(a) > std::fabs(b)) {
    r = a;
    phi = 0.25f * kPi * (b / a);
  } else {
    r = b;
    phi = 0.5f * kPi - 0.25f * kPi * (a / b);
  }
  return {r * std::cos(phi), r * std::sin(phi)};
}

AliasTable::AliasTable(std::span<const float> weights) {
  if (weights.size() > std::numeric_limits<uint32_t>::max()) {
    throw std::invalid_argument("AliasTable: more than 2^32 - 1 weights");
  }
  double total = 0.0;
  for (size_t i = 0; i < weights.size(); ++i) {
    const float w = weights[i];
    if (!std::isfinite(w) || w < 0.0f) {
      throw std::invalid_argument("AliasTable: weight " + std::to_string(i) +
                                  " is not a finite non-negative number");
    }
    total += w;  // at most 2^32 finite floats: no overflow in double
  }
  if (total == 0.0) return;

  const size_t n = weights.size();
  bins_.resize(n);
  // Vose's two work lists: the columns whose scaled probability n p_i is below one ("small") take
  // the rest of their column from one that is above ("large"), which then shrinks by what it gave.
  std::vector<double> scaled(n);
  std::vector<uint32_t> small;
  std::vector<uint32_t> large;
  uint32_t heaviest = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const double p = weights[i] / total;
    bins_[i].pmf = static_cast<float>(p);
    scaled[i] = p * static_cast<double>(n);
    (scaled[i] < 1.0 ? small : large).push_back(i);
    if (weights[i] > weights[heaviest]) heaviest = i;
  }
  while (!small.empty() && !large.empty()) {
    const uint32_t s = small.back();
    small.pop_back();
    const uint32_t l = large.back();
    bins_[s].threshold = scaled[s];
    bins_[s].alias = l;
    // Vose's order of operations, (l + s) - 1, which loses less than l - (1 - s).
    scaled[l] = (scaled[l] + scaled[s]) - 1.0;
    if (scaled[l] < 1.0) {
      large.pop_back();
      small.push_back(l);
    }
  }
  // What remains in either list is one up to rounding: those columns return themselves. A weight of
  // zero can only be left here through rounding far beyond double's; it still must never be
  // returned, so its column goes wholly to the heaviest entry.
  const auto settle = [&](uint32_t i) {
    const bool zero = weights[i] == 0.0f;
    bins_[i].threshold = zero ? 0.0 : 1.0;
    bins_[i].alias = zero ? heaviest : i;
  };
  for (const uint32_t i : small) settle(i);
  for (const uint32_t i : large) settle(i);
}

}  // namespace tritrace

// Sampling routines for Monte Carlo integration: warps from uniform numbers in [0, 1)^2 to
// directions, disk and triangle points with their densities, an orthonormal frame around a normal,
// the power heuristic for multiple importance sampling, and the alias table for discrete choices.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <numbers>
#include <span>
#include <vector>

namespace tritrace {

inline constexpr float kPi = std::numbers::pi_v<float>;
inline constexpr float kInvPi = std::numbers::inv_pi_v<float>;

// The unit disk, uniform by area, from the square by Shirley and Chiu's concentric map ("A
// Low Distortion Map Between Disk and Square", JGT 1997): squares around the centre go to circles,
// so strata stay compact and neighbouring samples stay neighbours. Density 1/pi.
glm::vec2 sample_uniform_disk_concentric(glm::vec2 u);

// Directions in a local frame with z up, cosine-weighted: density cos(theta)/pi per steradian.
// Malley's method: a uniform point on the unit disk lifted onto the hemisphere (z = sqrt(1 - r^2))
// has exactly this density (Pharr, Jakob and Humphreys, PBR 4th ed., section A.5.3).
// The clamps at 0 here are std::max, not std::fmax: fmax is a library call (for its NaN rules,
// 1% of a path-traced frame), and the two agree on every value (a NaN gives 0 from both).
inline glm::vec3 sample_cosine_hemisphere(glm::vec2 u) {
  const glm::vec2 d = sample_uniform_disk_concentric(u);
  const float z = std::sqrt(std::max(0.0f, 1.0f - d.x * d.x - d.y * d.y));
  return {d.x, d.y, z};
}
// Zero below the horizon (and on it), where the sampler never goes.
inline float cosine_hemisphere_pdf(float cos_theta) {
  return cos_theta > 0.0f ? cos_theta * kInvPi : 0.0f;
}

// Directions uniform over the upper hemisphere (z >= 0), density 1/(2 pi): z is uniform because a
// sphere's zone between two heights has area proportional to their difference (Archimedes).
inline glm::vec3 sample_uniform_hemisphere(glm::vec2 u) {
  const float z = u.x;
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 2.0f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
constexpr float uniform_hemisphere_pdf() {
  return 0.5f * kInvPi;
}

// Directions uniform over the whole sphere, density 1/(4 pi); z uniform in (-1, 1].
inline glm::vec3 sample_uniform_sphere(glm::vec2 u) {
  const float z = 1.0f - 2.0f * u.x;
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 2.0f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
constexpr float uniform_sphere_pdf() {
  return 0.25f * kInvPi;
}

// Barycentrics (b0, b1, b2) of a point uniformly distributed over a triangle's area, so
// p = b0 v0 + b1 v1 + b2 v2 has density 1/area. Heitz's low-distortion map ("A Low-Distortion Map
// Between Triangle and Square", 2019): it shears the half of the square on each side of its
// diagonal onto the triangle, which preserves area (uniform points stay uniform) and, unlike the
// square-root map, keeps strata compact. b2 is clamped at 0 against rounding.
inline glm::vec3 sample_uniform_triangle(glm::vec2 u) {
  float b0;
  float b1;
  if (u.y > u.x) {
    b0 = 0.5f * u.x;
    b1 = u.y - b0;
  } else {
    b1 = 0.5f * u.y;
    b0 = u.x - b1;
  }
  return {b0, b1, std::max(0.0f, 1.0f - b0 - b1)};
}

// An orthonormal, right-handed basis (x, y, z) with z a given unit normal; converts directions
// between world space and the local shading space where the warps above live (z up).
struct Frame {
  glm::vec3 x{1.0f, 0.0f, 0.0f};
  glm::vec3 y{0.0f, 1.0f, 0.0f};
  glm::vec3 z{0.0f, 0.0f, 1.0f};

  // Duff, Burgess, Christensen, Hery, Kensler, Liani and Villemin, "Building an Orthonormal Basis,
  // Revisited" (JCGT 2017): Frisvad's branch-free construction with copysign, which stays accurate
  // for every unit n, including (0, 0, -1) and normals near the poles where Frisvad's loses it.
  static Frame from_normal(glm::vec3 n) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float b = n.x * n.y * a;
    return {
        {1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x}, {b, sign + n.y * n.y * a, -n.y}, n};
  }

  glm::vec3 to_local(glm::vec3 v) const { return {glm::dot(v, x), glm::dot(v, y), glm::dot(v, z)}; }
  glm::vec3 to_world(glm::vec3 v) const { return x * v.x + y * v.y + z * v.z; }
};

// Veach's power heuristic with exponent 2 ("Robust Monte Carlo Methods for Light Transport
// Simulation", PhD thesis, 1997, section 9.2.4): the MIS weight of a sample drawn nf times from
// the strategy with density f_pdf against ng samples of the one with density g_pdf. Robust at the
// limits: 1 when f_pdf is infinite (a delta distribution, which the other strategy cannot sample),
// 0 when f's term is zero (including 0/0 when both are), and no overflow from squaring large pdfs
// (the ratio g/f is squared, not the pdfs).
inline float power_heuristic(float nf, float f_pdf, float ng, float g_pdf) {
  if (std::isinf(f_pdf)) return 1.0f;
  const float f = nf * f_pdf;
  if (!(f > 0.0f)) return 0.0f;
  const float r = ng * g_pdf / f;
  return 1.0f / (1.0f + r * r);
}

// Walker's alias method ("An Efficient Method for Generating Discrete Random Variables with General
// Distributions", ACM TOMS 1977) with Vose's construction ("A Linear Algorithm for Generating
// Random Numbers with a Given Distribution", IEEE TSE 1991): O(1) sampling of index i with
// probability weights[i] / sum(weights), e.g. choosing a light in proportion to its power. The
// construction runs in double so that the float thresholds are rounded once.
class AliasTable {
 public:
  struct Sample {
    uint32_t index = 0;
    float pmf = 0.0f;  // the probability of choosing `index`
  };

  AliasTable() = default;
  // Throws std::invalid_argument for a NaN, infinite or negative weight, or more than 2^32 - 1
  // weights. A zero total (or no weights) gives an empty table.
  explicit AliasTable(std::span<const float> weights);

  // One uniform u in [0, 1) picks a column (u * size()) and its fraction is the coin that chooses
  // between the column's own index and its alias. The split is exact in double (u has 24 bits), and
  // the coin keeps 24 - log2(size()) bits, which realises each probability within 2^-24 per column
  // that can return it (the column's own plus those aliasing to it); ample for the thousands of
  // lights a table typically holds. Entries of weight zero are never returned.
  // On an empty table returns {0, 0}: callers check empty() first.
  Sample sample(float u) const {
    const auto n = static_cast<uint32_t>(bins_.size());
    if (n == 0) return {};
    const double scaled = static_cast<double>(u) * n;
    uint32_t column = static_cast<uint32_t>(scaled);
    if (column >= n) column = n - 1;  // u == 1 from a careless caller
    const Bin& bin = bins_[column];
    const uint32_t index = scaled - column < bin.threshold ? column : bin.alias;
    return {index, bins_[index].pmf};
  }

  // weights[i] / sum(weights); 0 outside the table.
  float pmf(uint32_t i) const { return i < bins_.size() ? bins_[i].pmf : 0.0f; }
  size_t size() const { return bins_.size(); }
  bool empty() const { return bins_.empty(); }

 private:
  struct Bin {
    double threshold = 1.0;  // the column returns itself when the coin is below this
    float pmf = 0.0f;
    uint32_t alias = 0;
  };
  std::vector<Bin> bins_;
};

}  // namespace tritrace

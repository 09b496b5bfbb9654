// Bsdf: a surface's scattering at one point, built from its Material as a mix of up to four
// lobes (Lambert, GGX conductor, GGX dielectric with or without transmission), with eval, pdf and
// sample consistent with each other. Plain data with a switch per lobe: no virtual call per ray.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "tritrace/render/material/microfacet.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

struct BsdfSample {
  glm::vec3 wi{0.0f};      // local frame, unit length
  glm::vec3 weight{0.0f};  // f |cos theta_i| / pdf; zero when sampling failed
  float pdf = 0.0f;        // solid-angle density; infinite for a delta lobe's direction
  // The radiance scale 1 / eta^2 of a delta refraction, already in `weight` (1 otherwise): weight /
  // radiance_scale is the lobe's tint alone, which the albedo AOV follows through glass.
  float radiance_scale = 1.0f;
  bool delta = false;
  bool valid() const { return weight.x > 0.0f || weight.y > 0.0f || weight.z > 0.0f; }
};

struct Lobe {
  enum class Kind : uint8_t {
    kLambert,     // colour / pi, times (1 - F(cos_o)) (1 - F(cos_i)) when eta > 0 (under a coat)
    kConductor,   // GGX reflection with Schlick's Fresnel from F0 = colour, or the exact Fresnel
                  // of the complex index eta_rgb + i k_rgb when eta_rgb.x > 0
    kDielectric,  // GGX reflection (exact Fresnel) and transmission tinted by colour
    kCoat,        // GGX reflection with exact Fresnel only (the varnish over a coated diffuse)
  };
  Kind kind = Kind::kLambert;
  glm::vec3 colour{0.0f};
  float weight = 1.0f;  // the lobe's share of the mix
  float alpha = 0.0f;   // GGX width
  float eta = 0.0f;     // relative index of the inside; 0 for no Fresnel factor on Lambert
  glm::vec3 eta_rgb{0.0f}, k_rgb{0.0f};  // a conductor's complex index (unused when eta_rgb.x = 0)

  // A perfect mirror or refractor. Glass of relative index 1 is one whatever its roughness: a
  // microfacet of index 1 neither reflects (F = 0) nor bends light, so every microfacet passes wo
  // straight on to -wo (Walter et al. 2007's refraction half vector wo + eta wi vanishes there, and
  // the transmission lobe's width shrinks with |eta - 1| to a delta; pbrt-v4's DielectricBxDF
  // makes the same choice).
  bool delta() const {
    return kind != Kind::kLambert &&
           (alpha < kSmoothAlpha || (kind == Kind::kDielectric && eta == 1.0f));
  }
  // A conductor's reflectance at cos_i (from outside).
  glm::vec3 conductor_fresnel(float cos_i) const {
    return eta_rgb.x > 0.0f ? fresnel_conductor(cos_i, eta_rgb, k_rgb)
                            : fresnel_schlick(colour, cos_i);
  }
};

// Directions are in the local shading frame (z = the surface's lab normal, pointing outside). Every
// lobe is two-sided: seen from below (wo.z < 0) it acts as seen from above with the inside and
// outside swapped, so a dielectric's relative index becomes 1 / eta. Radiance transport: light
// refracted into a denser medium is scaled by 1 / eta^2 (Veach 1997, section 5.2).
class Bsdf {
 public:
  explicit Bsdf(const Material& m) : Bsdf(m, m.albedo) {}
  // With the albedo taken from elsewhere (a texture).
  Bsdf(const Material& m, glm::vec3 albedo);

  // f(wo, wi), without the cosine; 0 for delta lobes.
  glm::vec3 eval(glm::vec3 wo, glm::vec3 wi) const;
  // The solid-angle density with which sample() returns wi from wo, over the non-delta lobes.
  float pdf(glm::vec3 wo, glm::vec3 wi) const;
  // u_lobe chooses the lobe (and between reflection and refraction); u the direction.
  BsdfSample sample(glm::vec3 wo, float u_lobe, glm::vec2 u) const;

  // Whether every lobe is a delta lobe: light sampling can then never contribute.
  bool all_delta() const;
  // Whether some lobe passes light to the other side of the surface.
  bool transmits() const;
  int lobe_count() const { return count_; }
  const Lobe& lobe(int i) const { return lobes_[static_cast<size_t>(i)]; }

  static constexpr int kMaxLobes = 4;

 private:
  // Per-lobe choice probabilities for wo (flipped to z > 0); they sum to 1, or all are 0 for a
  // black surface.
  std::array<float, kMaxLobes> choice(glm::vec3 wo) const;
  std::array<Lobe, kMaxLobes> lobes_{};
  int count_ = 0;
};

// Per lobe, in the frame flipped so that wo.z > 0 (exposed for the tests).
glm::vec3 lobe_eval(const Lobe& lobe, glm::vec3 wo, glm::vec3 wi);
float lobe_pdf(const Lobe& lobe, glm::vec3 wo, glm::vec3 wi);
BsdfSample lobe_sample(const Lobe& lobe, glm::vec3 wo, float u_lobe, glm::vec2 u);

// The largest of a colour's three channels (Russian roulette's and lobe choice's measure).
inline float max_component(glm::vec3 c) {
  return std::max({c.x, c.y, c.z});
}

}  // namespace tritrace
